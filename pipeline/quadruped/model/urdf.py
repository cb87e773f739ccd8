"""A URDF loaded by pinocchio: urdfdom's parser writes what it finds wrong to the process's
standard error from C++, so that text is taken into the error that names the file instead of
appearing above it."""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

import pinocchio as pin
from skatelib.library.errors import ModelError


def free_flyer_model(path: Path) -> pin.Model:
    """The pinocchio model of the URDF at ``path`` on a free-flying base.

    Raises:
        ModelError: Naming the file, with the parser's own words, when it cannot be loaded.
    """
    sys.stderr.flush()
    saved = os.dup(2)
    error: Exception | None = None
    with tempfile.TemporaryFile() as said:
        os.dup2(said.fileno(), 2)
        try:
            model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
        except (RuntimeError, ValueError) as e:
            error = e
        finally:
            os.dup2(saved, 2)
            os.close(saved)
        said.seek(0)
        parser = " ".join(said.read().decode(errors="replace").split())
    if error is not None:
        detail = f"{error}" + (f"; the parser: {parser}" if parser else "")
        raise ModelError(f"{path}: pinocchio cannot load it ({detail}); give a URDF robot description, "
                         "e.g. configs/robots/cyberdog2.urdf")
    if parser:
        print(parser, file=sys.stderr)
    return model
