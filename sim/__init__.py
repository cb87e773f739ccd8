"""The physical twin: the CyberDog2 and its skateboard built from real joints in MuJoCo, from the
same figures the optimizer used (a library's ``/model`` and URDF, or a config's), so that a test
can compare the two. Imports ``skatelib.library`` and ``skatelib.runtime`` only (and MuJoCo).

Without a display MuJoCo renders (``skatelib.sim.render``, for videos) through EGL: ``MUJOCO_GL=egl`` is set
here when neither it nor ``DISPLAY`` is, before any module of the package imports MuJoCo (which
reads it when first imported)."""

import os

if "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
    os.environ["MUJOCO_GL"] = "egl"
