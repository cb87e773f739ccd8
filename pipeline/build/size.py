"""A build's size before any work, and the bound above which it does not start unattended.

Each config figure has its own range, but their product has none: a period of 5 s at 5 ms steps
over 20 strides (every figure in range) is 20,001 knots, a million variables in one solve, and
that build used 1.8 GB within 40 s while still compiling, without a word; 5,920 entries were
accepted as readily. So ``build``, ``solve`` and ``frontier`` estimate the work first (the robot
kind's ``size``: entries, the largest solve's knots x variables per knot, the sum over every
solve) and refuse beyond :data:`MAX_ENTRIES` or :data:`MAX_SOLVE_VARIABLES` unless ``--yes``.
The bounds hold the shipped configs with room (the default library: 43 entries, the largest
solve 171 knots x 52 variables).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from skatelib.library.errors import SkatelibError

MAX_ENTRIES = 500  # entries (or frontier searches) of one command
MAX_SOLVE_VARIABLES = 100_000  # knots x variables per knot of one solve (the default's largest: 8,892)


@dataclass(frozen=True)
class BuildSize:
    """The work a command would do, estimated from its config alone.

    Attributes:
        entries: The entries it would write (a frontier: the searches).
        largest_knots: Knots of its largest solve.
        variables_per_knot: Decision variables per knot (the quadruped: 28 states and 24 controls).
        total_variables: Knots x variables summed over every solve it may try.
    """

    entries: int
    largest_knots: int
    variables_per_knot: int
    total_variables: int

    @property
    def largest_variables(self) -> int:
        return self.largest_knots * self.variables_per_knot

    def __str__(self) -> str:
        return (f"{self.entries:,} entries, the largest solve {self.largest_knots:,} knots x {self.variables_per_knot} "
                f"variables = {self.largest_variables:,} variables, about {self.total_variables:,} variables "
                "over every solve")


class BuildTooLarge(SkatelibError):
    """A build beyond the size bounds, refused before any work (exit 2).

    Attributes:
        path: The config.
        size: The estimate.
    """

    def __init__(self, path: Path, size: BuildSize) -> None:
        self.path, self.size = path, size
        super().__init__(f"{path}: this would be {size}; beyond the bounds of {MAX_ENTRIES:,} entries and "
                         f"{MAX_SOLVE_VARIABLES:,} variables in one solve (knots: strides x period_s / dt_s), it "
                         "could take hours and many GB of memory. Check [sweep], [transitions], [schedule] and "
                         "[optimization], or pass --yes to go on")

    def __reduce__(self) -> tuple[type, tuple[Path, BuildSize]]:
        return type(self), (self.path, self.size)


def check_size(path: Path, size: BuildSize, yes: bool) -> None:
    """Refuse a build beyond :data:`MAX_ENTRIES` or :data:`MAX_SOLVE_VARIABLES` unless ``yes``.

    Raises:
        BuildTooLarge: Naming the config, the estimate, the bounds and ``--yes``.
    """
    if not yes and (size.entries > MAX_ENTRIES or size.largest_variables > MAX_SOLVE_VARIABLES):
        raise BuildTooLarge(path, size)
