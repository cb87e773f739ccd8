"""The physical twin: the CyberDog2 and its skateboard built from real joints in MuJoCo, from the
same figures the optimizer used (a library's ``/model`` and URDF, or a config's), so that a test
can compare the two. Imports ``skatelib.library`` and ``skatelib.runtime`` only (and MuJoCo)."""
