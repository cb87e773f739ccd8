"""Checks of option values at the command line's edge that Typer's types do not make: click's
ranges (``min=``, ``max=``) let NaN through (every comparison with it is false) and take infinity
where no ``max`` is set; a ``--perturb`` that names nothing ran the plant as planned under the name
``''``. Each is a Typer callback: a refusal is a usage error (exit 2) naming the option, the value
and what is allowed. And the refusal of a library none of whose entries was solved (exit 1)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import typer
from rich.markup import escape
from skatelib.pipeline.limits import MAX_JOBS, MAX_SEED
from skatelib.pipeline.track_setup import unnamed_errors
from skatelib.pipeline.views.console import err_console

MAX_ATOL = 1e6  # --atol, in each channel's unit: beyond it every library equals every other
MAX_RTOL = 1.0  # --rtol: 1 lets a value differ by its own size

__all__ = ["MAX_ATOL", "MAX_JOBS", "MAX_RTOL", "MAX_SEED", "allowed", "distinct", "exit_if_nothing_solved", "finite",
           "perturbation"]


def finite(param: typer.CallbackParam, value: Any) -> Any:
    """A float option's (or a repeated one's) value when every number in it is finite.

    Raises:
        typer.BadParameter: Naming the value and the option's range.
    """
    for v in value if isinstance(value, (list, tuple)) else [value]:
        if isinstance(v, float) and not math.isfinite(v):
            raise typer.BadParameter(f"{v} is not a finite number; allowed: {allowed(param)}")
    return value


def distinct(value: list[str] | None) -> list[str] | None:
    """A repeated option's values, each once, in the order first given (``-e K -e K`` rides K once)."""
    return list(dict.fromkeys(value)) if value else value


def exit_if_nothing_solved(library: Path, what: str) -> None:
    """Exit 1, saying so, when no entry of the library was solved: nothing to ``what``."""
    from skatelib.runtime import MotionLibrary

    if not any(e.success for e in MotionLibrary.open(library)):
        err_console.print(escape(f"{library}: no entry of this library was solved: nothing to {what}"))
        raise typer.Exit(1)


def allowed(param: typer.CallbackParam) -> str:
    """The range of a numeric option, as its ``min=`` and ``max=`` set it."""
    kind = getattr(param, "type", None)  # click's IntRange or FloatRange
    low, high = getattr(kind, "min", None), getattr(kind, "max", None)
    if low is None and high is None:
        return "a finite number"
    if high is None:
        return f"at least {low:g}"
    if low is None:
        return f"at most {high:g}"
    return f"{low:g} to {high:g}"


def perturbation(value: str | None) -> str | None:
    """A ``--perturb`` value that names at least one model error (or ``none``).

    Raises:
        typer.BadParameter: An empty value (or commas alone), with the spelling of no error.
    """
    if value is not None and (why := unnamed_errors(value)) is not None:
        raise typer.BadParameter(why)
    return value
