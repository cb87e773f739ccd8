"""Entries by their robustness certificate (``select``/``route`` with ``min_success``): an entry
is used when the library's certificate (:mod:`skatelib.library.certificate`) holds figures made
on this very entry (its arrays' digest) with a success rate of at least ``min_success``. The
runtime cannot tell whether the certificate's judging code is the installed one (the robot has
no twin); ``skatelib info`` and ``skatelib certify`` report a certificate of other code as stale."""

from __future__ import annotations

from collections.abc import Iterable
from math import isfinite

from skatelib.library.certificate import Certificate
from skatelib.runtime.entry import Entry


def check_min_success(min_success: float | None) -> None:
    """Raises:
        ValueError: ``min_success`` not a number from 0 to 1.
    """
    if min_success is not None and not (isfinite(min_success) and 0.0 <= min_success <= 1.0):
        raise ValueError(f"min_success={min_success!r}: a success rate from 0 to 1 (or None: no certificate needed)")


def usable(entries: Iterable[Entry], certificate: Certificate | None,
           min_success: float | None) -> tuple[list[Entry], str]:
    """The successful ``entries`` certified at ``min_success`` or better (every successful one when
    it is None) and a note naming the successful ones left out and why ('' when none was)."""
    check_min_success(min_success)
    kept, skipped = [], []
    for e in entries:
        if not e.success:
            continue
        if min_success is None:
            kept.append(e)
            continue
        figures = None if certificate is None else certificate.current_for(e.key, e.arrays)
        if figures is None:
            why = "no certificate" if certificate is None or e.key not in certificate.entries else \
                "its certificate was made on other data (certify the library again)"
            skipped.append(f"{e.key} ({why})")
        elif not figures.rate >= min_success:  # a rate of no rides (NaN) is no rate
            skipped.append(f"{e.key} (success rate {figures.rate:.2f} < min_success {min_success:g})")
        else:
            kept.append(e)
    return kept, (f"; skipped below min_success: {', '.join(skipped)}" if skipped else "")
