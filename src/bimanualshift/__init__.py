"""BimanualShift: frozen single-arm policies turned into bimanual policies with few demonstrations."""

import os

# Headless rendering by default; must be set before MuJoCo or PyOpenGL are imported.
os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("PYOPENGL_PLATFORM", os.environ["MUJOCO_GL"])

__version__ = "0.1.0"
