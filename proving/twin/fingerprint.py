"""The fingerprint of the code that judges a ride on the twin: a hash of the controller's
(:mod:`skatelib.control`), the twin's (:mod:`skatelib.sim`) and the proving ground's source, the
module that compiles their C code (:mod:`skatelib.library.native_code`: its flags) and MuJoCo's
version. The build's twin judge keys its cached verdicts with it and a certificate
stores it: a verdict or a certificate made by other code is never taken for this code's."""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path


@functools.cache
def twin_fingerprint() -> str:
    """16 hex digits of a SHA-256 over MuJoCo's version, every source file (Python and C) of the
    three packages and the module that compiles their C code."""
    import mujoco
    import skatelib.control
    import skatelib.proving
    import skatelib.sim
    from skatelib.library import native_code

    h = hashlib.sha256(mujoco.__version__.encode())
    for package in (skatelib.control, skatelib.sim, skatelib.proving):
        for folder in package.__path__:
            for path in sorted(p for p in Path(folder).rglob("*") if p.suffix in (".py", ".c")):
                h.update(path.read_bytes())
    h.update(Path(native_code.__file__).read_bytes())  # how their C is compiled (its flags)
    return h.hexdigest()[:16]
