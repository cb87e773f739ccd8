"""The certificate on the terminal: ``skatelib certify``'s table, and the lines ``info`` prints."""

from __future__ import annotations

from typing import Any

from rich.markup import escape
from rich.table import Table
from skatelib.library.certificate import Certificate, EntryCertificate
from skatelib.pipeline.views.console import console


def _modes(e: EntryCertificate) -> str:
    return ", ".join(f"{m} {n}" for m, n in e.modes.items() if n) or "-"


def _shove(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f}"


def certificate_table(certificate: Certificate, library: str, stale: list[str]) -> None:
    """Print each entry's figures, what the certificate was drawn from and, when stale, why."""
    import json

    spec = json.loads(certificate.spec_json)
    t = Table(title=escape(f"robustness certificate: {spec['samples']} rides per entry on the twin, seed "
                           f"{spec['seed']}, controller fed the {spec['state']} state; code {certificate.code}"))
    for col in ("entry", "passed", "rate", "95 % interval", "failure modes", "shove survived [N s]",
                "smallest failed [N s]", "worst draw"):
        t.add_column(escape(col), justify="right")
    for k, e in sorted(certificate.entries.items()):
        t.add_row(escape(k), f"{e.successes}/{e.samples}", f"{e.rate:.2f}", f"{e.low:.2f}-{e.high:.2f}",
                  escape(_modes(e)), f"{e.shove_survived_Ns:.2f}", _shove(e.shove_failed_Ns),
                  "-" if e.worst_seed is None else str(e.worst_seed))
    console.print(t)
    console.print(escape("rate: rides passed as track --plant mujoco judges them; interval: Wilson's 95 %; shove "
                         "survived: every ride shoved no harder passed; worst draw: the failed ride with the "
                         f"gentlest shove, replayed by skatelib track {library} --plant mujoco --entry KEY --draw SEED "
                         "(--video OUT.mp4)"))
    if stale:
        console.print(f"[yellow]stale:[/] {escape('; '.join(stale))}")


def certificate_lines(lib: Any, certificate: Certificate | None, stale: list[str]) -> list[str]:
    """``info``'s lines on the certificate: absent, or the range of rates and whether it is current."""
    if certificate is None:
        return ["certificate: none (skatelib certify LIB rides every entry under drawn errors)"]
    rates = [e.rate for e in certificate.entries.values()]
    lines = [f"certificate: {len(rates)} entries, success rate {min(rates):.2f} to {max(rates):.2f}, code "
             f"{certificate.code}; {'stale: ' + '; '.join(stale) if stale else 'current'}"]
    return lines
