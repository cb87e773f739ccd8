"""Ctrl-C and SIGTERM during an in-process solve.

While IPOPT iterates, CasADi runs Python's signal handlers between iterations; when a handler
raises, CasADi prints a warning, stops the solve and returns it as an ordinary failed one: the
``KeyboardInterrupt`` never reaches the caller, and a build would go on to the next attempt. So the
command line's handlers (:func:`install`) also record that an interrupt came, and every solver call
is followed by :func:`check`, which raises ``KeyboardInterrupt`` again. The record belongs to this
process (worker processes start without one) and is cleared at the start of every command
(:func:`reset`).
"""

from __future__ import annotations

import signal
import threading
from typing import Any

_ARRIVED = threading.Event()  # set by the handler, whatever the code it interrupts does with the exception


def reset() -> None:
    """Forget an earlier interrupt (a command starts)."""
    _ARRIVED.clear()


def arrived() -> bool:
    """Whether Ctrl-C or SIGTERM came since the command started."""
    return _ARRIVED.is_set()


def check() -> None:
    """Raise ``KeyboardInterrupt`` when an interrupt came, even one a solver swallowed.

    Raises:
        KeyboardInterrupt: Ctrl-C or SIGTERM came since :func:`reset`.
    """
    if _ARRIVED.is_set():
        raise KeyboardInterrupt


def handle(signum: int, frame: Any) -> None:
    """The handler of SIGINT and SIGTERM: record the interrupt, then raise ``KeyboardInterrupt``
    (SIGTERM stops a command like Ctrl-C: workers stopped, finished entries cached)."""
    _ARRIVED.set()
    raise KeyboardInterrupt


def install() -> None:
    """Clear the record and handle SIGINT and SIGTERM with :func:`handle` (from the main thread)."""
    reset()
    signal.signal(signal.SIGINT, handle)
    signal.signal(signal.SIGTERM, handle)
