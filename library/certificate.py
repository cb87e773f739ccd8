"""The robustness certificate a library may carry (``skatelib certify``, root attribute
``certificate_json``): per entry, how many of N rides on the twin under drawn model errors and
shoves it survived, with a 95 % Wilson interval, the failure modes, the shove margin and each
draw; with it, the distributions it was drawn from (the ``[certify]`` table), N, the seed and a
hash of the code that judged it. Each entry's part also holds a digest of the entry's arrays, so a
rebuilt entry's old figures are never taken for its own."""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from skatelib.library import schema
from skatelib.library.errors import SkatelibError


def entry_digest(arrays: dict[str, np.ndarray]) -> str:
    """A digest of an entry's times, states and controls (what a ride follows); 16 hex digits."""
    h = hashlib.sha256()
    for name in (schema.D_T, schema.D_STATE, schema.D_CONTROL):
        a = np.ascontiguousarray(arrays[name], dtype=np.float64)
        h.update(name.encode() + str(a.shape).encode() + a.tobytes())
    return h.hexdigest()[:16]


@dataclass(frozen=True)
class DrawRecord:
    """One ride: the draw's seed, whether it passed, its shove [N s] and its failure modes."""

    seed: int
    passed: bool
    shove_Ns: float
    modes: tuple[str, ...] = ()


@dataclass(frozen=True)
class EntryCertificate:
    """One entry's figures.

    Attributes:
        low / high: The success rate's 95 % Wilson interval.
        modes: Failed rides per failure mode (a ride may fail in several).
        shove_survived_Ns: The largest shove every ride shoved no harder survived [N s] (0: none).
        shove_failed_Ns: The smallest shove of a failed ride [N s] (None: none failed).
        worst_seed: The seed of the failed ride with the smallest shove (None: none failed).
        digest: :func:`entry_digest` of the entry that was ridden.
    """

    key: str
    samples: int
    successes: int
    low: float
    high: float
    modes: dict[str, int]
    shove_survived_Ns: float
    shove_failed_Ns: float | None
    worst_seed: int | None
    digest: str
    draws: tuple[DrawRecord, ...] = field(default=(), repr=False)

    @property
    def rate(self) -> float:
        """Successes per ride."""
        return self.successes / self.samples if self.samples else float("nan")


@dataclass(frozen=True)
class Certificate:
    """A library's certificate: ``spec_json`` (the ``[certify]`` table it was drawn from, N and the
    seed among it), ``code`` (the hash of the controller's, the twin's and the proving ground's
    code and MuJoCo's version) and the entries' figures."""

    spec_json: str
    code: str
    entries: dict[str, EntryCertificate]

    def to_json(self) -> str:
        return json.dumps({"spec": json.loads(self.spec_json), "code": self.code,
                           "entries": {k: asdict(e) for k, e in sorted(self.entries.items())}}, sort_keys=True)

    @classmethod
    def from_json(cls, text: str, where: str = "certificate_json") -> Certificate:
        """Raises:
            SkatelibError: The text is not a certificate (naming ``where``; certify the library again).
        """
        try:
            d = json.loads(text)
            entries = {k: _entry(e) for k, e in d["entries"].items()}
            return cls(json.dumps(d["spec"], sort_keys=True), str(d["code"]), entries)
        except (ValueError, KeyError, TypeError) as e:
            raise SkatelibError(f"{where}: not a readable certificate ({e}); run 'skatelib certify' again") from e

    def current_for(self, key: str, arrays: dict[str, np.ndarray]) -> EntryCertificate | None:
        """The entry's figures when they were made on these very arrays (None otherwise)."""
        e = self.entries.get(key)
        return e if e is not None and e.digest == entry_digest(arrays) else None


def _entry(d: dict[str, Any]) -> EntryCertificate:
    draws = tuple(DrawRecord(int(r["seed"]), bool(r["passed"]), float(r["shove_Ns"]), tuple(r["modes"]))
                  for r in d.get("draws", ()))
    return EntryCertificate(
        key=str(d["key"]), samples=int(d["samples"]), successes=int(d["successes"]), low=float(d["low"]),
        high=float(d["high"]), modes={str(k): int(v) for k, v in d["modes"].items()},
        shove_survived_Ns=float(d["shove_survived_Ns"]),
        shove_failed_Ns=None if d["shove_failed_Ns"] is None else float(d["shove_failed_Ns"]),
        worst_seed=None if d["worst_seed"] is None else int(d["worst_seed"]), digest=str(d["digest"]), draws=draws)


def certificate_figures(text: Any) -> dict[str, Any]:
    """A stored certificate as flat figures for ``skatelib diff`` (``code``, ``spec``,
    ``<key>.rate``, ``.low``, ``.high``, ``.shove_survived_Ns``, ``.shove_failed_Ns``); {} for none."""
    if text is None:
        return {}
    c = Certificate.from_json(str(text))
    out: dict[str, Any] = {"code": c.code, "spec": c.spec_json}
    for k, e in sorted(c.entries.items()):
        out |= {f"{k}.rate": e.rate, f"{k}.low": e.low, f"{k}.high": e.high,
                f"{k}.shove_survived_Ns": e.shove_survived_Ns, f"{k}.shove_failed_Ns": e.shove_failed_Ns}
    return out
