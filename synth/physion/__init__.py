"""Physion++-style contact-prediction trials on MuJoCo (``physmind synth --suite physion``).

``spec`` holds the trial description, ``categories`` the five seeded samplers,
``mujoco_run`` the MJCF, simulation and rendering, ``generate`` the dataset
writer (trials.json, videos/, cameras/, annotations/, ground_truth/).
"""

import os

os.environ.setdefault("MUJOCO_GL", "egl")
