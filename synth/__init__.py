"""CLEVRER-style scene generator on MuJoCo: videos, annotations, ground truth, questions.

MuJoCo chooses its OpenGL backend when first imported, so the headless EGL
backend is selected here, before any submodule imports mujoco, unless the
user already set MUJOCO_GL.
"""

import os

os.environ.setdefault("MUJOCO_GL", "egl")
