"""The certificate on the terminal: ``skatelib certify``'s table, and the lines ``info`` prints."""

from __future__ import annotations

from dataclasses import asdict
from typing import Any

from rich.markup import escape
from skatelib.library.certificate import Certificate, EntryCertificate
from skatelib.pipeline.views.console import console
from skatelib.pipeline.views.fitted import Col, print_table


def _modes(e: EntryCertificate) -> str:
    """The failure modes of failed rides, the most frequent first."""
    return ", ".join(f"{m} {n}" for m, n in sorted(e.modes.items(), key=lambda mn: -mn[1]) if n) or "-"


def _shove(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f}"


def certificate_table(certificate: Certificate, library: str, stale: list[str]) -> None:
    """Print each entry's figures, what the certificate was drawn from and, when stale, why."""
    import json

    spec = json.loads(certificate.spec_json)
    rows = [[escape(k), f"{e.successes}/{e.samples}", f"{e.rate:.2f}", f"{e.low:.2f}-{e.high:.2f}", escape(_modes(e)),
             f"{e.shove_survived_Ns:.2f}", _shove(e.shove_failed_Ns),
             "-" if e.worst_seed is None else str(e.worst_seed)]
            for k, e in sorted(certificate.entries.items())]
    print_table(console, escape(f"robustness certificate: {spec['samples']} rides per entry on the twin, seed "
                                f"{spec['seed']}, controller fed the {spec['state']} state; code {certificate.code}"),
                ("entry", "passed", "rate", "95 % interval", Col("failure modes", text=True), "shove survived [N s]",
                 "smallest failed [N s]", "worst draw"), rows,
                "rate: rides passed as track --plant mujoco judges them; interval: Wilson's 95 %; shove survived: "
                "every ride shoved no harder passed; worst draw: the failed ride with the gentlest shove, replayed by "
                f"skatelib track {library} --plant mujoco --entry KEY --draw SEED (--video OUT.mp4)")
    if stale:
        console.print(f"[yellow]stale:[/] {escape('; '.join(stale))}")


def _stale(lib: Any) -> list[str]:
    from skatelib.pipeline.certify_spec import library_spec, stale_reasons

    return stale_reasons(lib, lib.certificate, library_spec(lib))


def certificate_json(lib: Any) -> dict[str, Any]:
    """``info --json``'s certificate (without each draw): ``{}`` when the library has none."""
    import json

    if lib.kind != "quadruped" or lib.certificate is None:
        return {}
    cert = lib.certificate
    entries = {k: {f: v for f, v in asdict(e).items() if f != "draws"} | {"rate": e.rate}
               for k, e in sorted(cert.entries.items())}
    return {"certificate": {"spec": json.loads(cert.spec_json), "code": cert.code, "stale": _stale(lib),
                            "entries": entries}}


def certificate_summary(lib: Any) -> None:
    """``info``'s certificate: its table, and whether it is current."""
    if lib.kind == "quadruped" and lib.certificate is not None:
        certificate_table(lib.certificate, str(lib.path), _stale(lib))
