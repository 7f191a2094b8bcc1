# The two commands of the README: `make demo` and `make test`.
# Both create .venv and install the project with pinned versions first.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp
export MUJOCO_GL ?= egl

.PHONY: install browser test demo bench clean

install: $(STAMP) browser

# The browser test (tests/render/test_viewer_browser.py) drives Debian's Chromium through its
# chromedriver; install both when missing (needs root; otherwise say how, and the test fails with the reason).
browser:
	@if [ ! -x /usr/bin/chromium ] || [ ! -x /usr/bin/chromedriver ]; then \
	  if [ "$$(id -u)" = 0 ]; then \
	    echo "installing the Debian packages chromium and chromium-driver (browser test)"; \
	    export DEBIAN_FRONTEND=noninteractive; \
	    apt-get update -qq && apt-get install -y -qq chromium chromium-driver > /dev/null; \
	  else \
	    echo "warning: /usr/bin/chromium or /usr/bin/chromedriver missing; run: sudo apt-get install -y chromium chromium-driver"; \
	  fi; \
	fi

$(STAMP): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -c constraints.txt -e '.[dev]'
	touch $(STAMP)

test: $(STAMP) browser
	$(PY) -m pytest -q -n 2

demo: $(STAMP)
	$(PY) -m physmind.cli demo --out out/demo

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache
