"""How many threads a solve evaluates its stage derivatives on.

The stage Jacobians and Lagrangian Hessians of one solve are independent of each other, so CasADi
evaluates them on several threads at once (``map(n, "thread", threads)``); the results are the
same to the bit. The Hessian is about half of an IPOPT iteration of the push-off, so a solve with a
second core takes about a fifth less time (docs/design-notes.md). The rest of the iteration (MUMPS)
stays on one thread.
"""

from __future__ import annotations

import math
import os

import casadi as ca
from skatelib.library.errors import SkatelibError

ENV = "OMP_NUM_THREADS"  # the usual setting; the build's worker processes run with it at 1
# At most this many threads: CasADi starts them at every call, and with 80 stages a thread then
# still has 10 of the Hessian's 0.55 ms blocks to evaluate against some 0.05 ms to start.
MAX_THREADS = 8


def stage_threads() -> int:
    """``OMP_NUM_THREADS`` if set (its first entry where it lists several levels), else the cores
    this process may use (its CPU affinity and any CPU quota of its container), at most
    :data:`MAX_THREADS`.

    Raises:
        SkatelibError: ``OMP_NUM_THREADS`` is not a whole number of at least 1.
    """
    value = os.environ.get(ENV, "").split(",")[0].strip()
    if value:
        if not value.isdigit() or int(value) < 1:
            raise SkatelibError(f"environment variable {ENV}={os.environ[ENV]!r} is not a number of threads: "
                                f"set a whole number of at least 1, or unset it to use every core")
        return min(int(value), MAX_THREADS)
    from joblib import cpu_count

    return max(1, min(cpu_count(), MAX_THREADS))


def mapped(fn: ca.Function, n_stages: int, threads: int) -> ca.Function:
    """``fn`` mapped over the stages on at most ``threads`` threads (serially for one), as few as
    give each thread the same share: CasADi gives every thread the largest share, evaluating
    padding stages, so 80 stages on 64 threads would evaluate 128 (here: 40 threads of two)."""
    per_thread = math.ceil(n_stages / max(threads, 1))
    used = math.ceil(n_stages / per_thread)
    return fn.map(n_stages, "thread", used) if used > 1 else fn.map(n_stages, "serial")
