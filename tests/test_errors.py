"""skatelib's errors keep their context across processes: an error raised in a worker (a video
the encoder could not write, a library a job could not read) reaches the command line whole, with
the attributes its message and exit code come from."""

from __future__ import annotations

import pickle
from pathlib import Path

import pytest
from skatelib.library.errors import ConfigError, LibraryFormatError, OutputError, exit_code


@pytest.mark.parametrize("error", [
    ConfigError(Path("a.toml"), "sweep.strides", "out of range"),
    LibraryFormatError(Path("lib.h5"), "/entries/x", "missing"),
    OutputError(Path("run.mp4"), "the video encoder failed"),
])
def test_an_error_survives_pickling(error):
    """Unpickled, the error has the same type, message, attributes and exit code."""
    back = pickle.loads(pickle.dumps(error))
    assert type(back) is type(error) and str(back) == str(error)
    assert vars(back) == vars(error) and exit_code(back) == exit_code(error)
