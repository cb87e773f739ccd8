"""skatelib builds motion libraries for legged robots on skateboards and serves them to the robot's
controller. This is its Python API: the commands ``build``, ``validate`` and ``track`` as functions
with typed keyword arguments, returning the commands' result records.

```python
import skatelib

report = skatelib.build("my.toml", "out/my.h5", jobs=2, progress=True)  # the command's progress bar
checked = skatelib.validate(report.path)
runs = skatelib.track(report.path, plant="mujoco", perturb="none")
print([(r.key, r.passed) for r in runs], checked.valid)
```

Errors are the command's: a wrong config key raises :class:`ConfigError` naming the file and the
key, a damaged library :class:`LibraryFormatError`, both :class:`SkatelibError`. The functions are
in :mod:`skatelib.pipeline.api`; ``import skatelib`` loads nothing until one is used, so the robot's
runtime (:mod:`skatelib.runtime`: :class:`MotionLibrary`, numpy and h5py only) imports nothing of the
build. Building needs the ``[build]`` extra, ``track`` the ``[control]`` one (and ``[sim]`` on the
twin).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

# Each public name -> the module that defines it, imported on first use. A command's function
# (build, validate, track and those to come) lives in skatelib.pipeline.api and is named here.
_EXPORTS = {
    "build": "skatelib.pipeline.api",
    "validate": "skatelib.pipeline.api",
    "track": "skatelib.pipeline.api",
    "certify": "skatelib.pipeline.api_certify",
    "Certificate": "skatelib.library.certificate",
    "BuildReport": "skatelib.pipeline.build.orchestrate",
    "EntryEvent": "skatelib.pipeline.build.contract",
    "ValidationReport": "skatelib.pipeline.validate",
    "EntryVerdict": "skatelib.pipeline.validate",
    "TrackResult": "skatelib.proving.verdict",
    "TwinResult": "skatelib.proving.twin.verdict",
    "MotionLibrary": "skatelib.runtime",
    "SkatelibError": "skatelib.library.errors",
    "ConfigError": "skatelib.library.errors",
    "LibraryFormatError": "skatelib.library.errors",
    "OutputError": "skatelib.library.errors",
}

__all__ = ["BuildReport", "Certificate", "ConfigError", "EntryEvent", "EntryVerdict", "LibraryFormatError",
           "MotionLibrary", "OutputError", "SkatelibError", "TrackResult", "TwinResult", "ValidationReport", "build",
           "certify", "track", "validate"]  # the names of _EXPORTS (a test holds them equal)

if TYPE_CHECKING:
    from skatelib.library.errors import ConfigError, LibraryFormatError, OutputError, SkatelibError
    from skatelib.pipeline.api import build, track, validate
    from skatelib.pipeline.build.contract import EntryEvent
    from skatelib.pipeline.build.orchestrate import BuildReport
    from skatelib.pipeline.validate import EntryVerdict, ValidationReport
    from skatelib.proving.twin.verdict import TwinResult
    from skatelib.proving.verdict import TrackResult
    from skatelib.runtime import MotionLibrary


def __getattr__(name: str) -> Any:
    """A public name, imported from its module on first use (PEP 562)."""
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'skatelib' has no attribute {name!r}; public names: {', '.join(__all__)}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
