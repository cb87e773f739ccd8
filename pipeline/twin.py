"""``skatelib model --twin``: the physical twin's MJCF from a library's ``/model`` or from a config
(the same figures a build of it would store), written atomically."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from skatelib.library.atomic import atomic_path
from skatelib.library.errors import SkatelibError


def twin_figures(source: Path | Any) -> Any:
    """The twin's figures of a library file or of a loaded quadruped config."""
    from skatelib.sim.figures import TwinFigures

    if isinstance(source, Path):
        from skatelib.runtime import MotionLibrary

        lib = MotionLibrary.open(source)
        if lib.kind != "quadruped":
            raise SkatelibError(f"{source}: the twin is a quadruped's; this library is {lib.kind}")
        return TwinFigures.from_library(lib)
    if source.meta.kind != "quadruped":
        raise SkatelibError(f"{source.path}: a {source.meta.kind}'s twin is made from its built library (it stands "
                            "in a planned posture): skatelib build CONFIG, then skatelib model LIB.h5 --twin OUT.xml")
    from skatelib.pipeline.quadruped.entries import quadruped_model
    from skatelib.pipeline.quadruped.model.system import SkateSystem

    record = quadruped_model(source, SkateSystem.from_config(source))
    return TwinFigures.from_record(record, source.urdf_path.read_text())


def write_twin(source: Path | Any, out: Path) -> Path:
    """Write the twin's MJCF for a library file or a config to ``out``.

    Raises:
        ImportError: MuJoCo is not installed (names the extra).
    """
    try:
        from skatelib.sim.scene import twin_xml
    except ImportError as e:
        raise ImportError(f"the twin needs MuJoCo ({e}); pip install 'skatelib[sim]'") from e
    from skatelib.pipeline.build.preflight import check_output

    check_output(out, [source] if isinstance(source, Path) else [source.path], what="twin")
    xml = _humanoid_xml(source) if isinstance(source, Path) and _is_humanoid(source) else twin_xml(twin_figures(source))
    with atomic_path(out) as tmp:
        tmp.write_text(xml)
    return out


def _is_humanoid(path: Path) -> bool:
    from skatelib.runtime import MotionLibrary

    return MotionLibrary.open(path).kind == "humanoid"


def _humanoid_xml(path: Path) -> str:
    """The humanoid twin standing in the first successful entry's first posture."""
    from skatelib.proving.humanoid.loop import figures_for
    from skatelib.runtime import MotionLibrary
    from skatelib.sim.humanoid.robot import humanoid_xml

    lib = MotionLibrary.open(path)
    key = next((e.key for e in lib if e.success), None)
    if key is None:
        raise SkatelibError(f"{path}: no entry of this library was solved: no posture to stand the twin in")
    return humanoid_xml(figures_for(lib, key))
