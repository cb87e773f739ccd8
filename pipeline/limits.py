"""Bounds of the numeric arguments the command line and the Python API share, and the check that
refuses a value outside them."""

from __future__ import annotations

MAX_JOBS = 256  # worker processes of one command (--jobs, jobs=)
MAX_SEED = 2**32 - 1  # --seed, seed=: numpy's seeds are non-negative; this many are plenty


def check_range(where: str, name: str, value: int, low: int, high: int) -> int:
    """``value`` when it is an integer in [low, high].

    Raises:
        ValueError: Naming the function (``where``), the argument and its range.
    """
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise ValueError(f"{where}({name}={value!r}): {name} is an integer from {low} to {high}")
    return value


def check_choice(where: str, name: str, value: object, choices: tuple[str, ...]) -> str:
    """``value`` when it is one of ``choices``.

    Raises:
        ValueError: Naming the function (``where``), the argument and the choices.
    """
    if not isinstance(value, str) or value not in choices:
        raise ValueError(f"{where}({name}={value!r}): {name} is one of {', '.join(map(repr, choices))}")
    return value
