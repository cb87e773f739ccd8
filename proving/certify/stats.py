"""An entry's figures from its rides: the success rate's 95 % Wilson score interval, the failure
modes counted, and the shove margin."""

from __future__ import annotations

import math
from collections.abc import Sequence

from skatelib.library.certificate import DrawRecord, EntryCertificate
from skatelib.proving.certify.ride import MODES, DrawResult

Z_95 = 1.959963984540054  # the standard normal's 97.5 % quantile


def wilson(successes: int, n: int, z: float = Z_95) -> tuple[float, float]:
    """The Wilson score interval of a binomial proportion (Wilson 1927; Agresti and Coull 1998,
    Eq. 4): ``(p + z^2/2n -+ z sqrt(p(1-p)/n + z^2/4n^2)) / (1 + z^2/n)`` with ``p = successes/n``.

    Raises:
        ValueError: ``n`` < 1 or ``successes`` outside [0, n].
    """
    if n < 1 or not 0 <= successes <= n:
        raise ValueError(f"wilson({successes}, {n}): need n >= 1 and 0 <= successes <= n")
    p = successes / n
    centre = p + z * z / (2 * n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    d = 1 + z * z / n
    return max(0.0, (centre - half) / d), min(1.0, (centre + half) / d)


def summarize(key: str, results: Sequence[DrawResult], digest: str) -> EntryCertificate:
    """One entry's figures from its rides (in the draws' order)."""
    n, ok = len(results), sum(r.passed for r in results)
    low, high = wilson(ok, n)
    failed = [r for r in results if not r.passed]
    gentlest = min(failed, key=lambda r: (r.shove_Ns, r.seed)) if failed else None
    limit = gentlest.shove_Ns if gentlest else math.inf
    survived = max((r.shove_Ns for r in results if r.passed and r.shove_Ns < limit), default=0.0)
    return EntryCertificate(
        key=key, samples=n, successes=ok, low=low, high=high,
        modes={m: sum(m in r.modes for r in failed) for m in MODES}, shove_survived_Ns=survived,
        shove_failed_Ns=None if gentlest is None else gentlest.shove_Ns,
        worst_seed=None if gentlest is None else gentlest.seed, digest=digest,
        draws=tuple(DrawRecord(r.seed, r.passed, r.shove_Ns, r.modes) for r in results))
