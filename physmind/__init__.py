"""PhysMind's composition root: the ``physmind`` command line and the video-to-world pipeline.

``world`` <- ``tools`` <- ``server``; ``world`` <- ``perception``; ``world`` <- ``planner``;
only this package imports several of them and wires them together.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("physmind")
except PackageNotFoundError:  # running from a checkout that was never installed
    __version__ = "0+unknown"
