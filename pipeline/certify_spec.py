"""Which ``[certify]`` table a certification draws from, and whether a stored certificate is
current: made by the installed twin code (:mod:`skatelib.proving.twin.fingerprint`), from the
same distributions, on the entries as they are (each entry's digest)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from skatelib.library import schema
from skatelib.library.certificate import Certificate
from skatelib.library.errors import ConfigError
from skatelib.pipeline.config_tables import build_section
from skatelib.proving.certify.spec import CertifySpec, check_spec


def library_spec(lib: Any) -> CertifySpec:
    """The ``[certify]`` table of the config a library was built from (its defaults when the config
    had none).

    Raises:
        ConfigError: Naming the library and the key of a table that does not validate.
    """
    where = Path(f"{lib.path} (its {schema.A_CONFIG_RESOLVED})")
    text = lib.attrs.get(schema.A_CONFIG_RESOLVED)
    data = json.loads(str(text)).get("certify", {}) if text else {}
    return check_spec(build_section(where, "certify", CertifySpec, data), where)


def config_spec(config: Path) -> CertifySpec:
    """The ``[certify]`` table of a quadruped config file (validated with the whole config).

    Raises:
        ConfigError: Naming the file and the key.
    """
    from skatelib.pipeline.config import load_config
    from skatelib.pipeline.quadruped.config import QuadrupedConfig

    cfg = load_config(config)
    if not isinstance(cfg, QuadrupedConfig):
        raise ConfigError(config, "meta.kind", "a certificate rides the quadruped's twin: give a quadruped config")
    return cfg.certify


def stale_reasons(lib: Any, certificate: Certificate, spec: CertifySpec | None = None) -> list[str]:
    """Why ``certificate`` is not this library's current one (empty: it is): other judging code
    (when MuJoCo is here to tell), other distributions than ``spec``'s (when given), entries
    ridden that have changed since."""
    reasons = []
    try:
        from skatelib.proving.twin.fingerprint import twin_fingerprint

        if certificate.code != twin_fingerprint():
            reasons.append(f"judged by other code ({certificate.code}; this code is {twin_fingerprint()})")
    except ImportError:
        reasons.append("the judging code cannot be checked here (MuJoCo is not installed)")
    if spec is not None and _distributions(certificate.spec_json) != _distributions(spec.as_json()):
        reasons.append("drawn from other distributions than the [certify] table's")
    changed = [k for k, e in certificate.entries.items() if k not in lib or certificate.current_for(k, lib[k].arrays)
               is None]
    if changed:
        reasons.append(f"entries changed since: {', '.join(changed)}")
    return reasons


def _distributions(spec_json: str) -> dict[str, Any]:
    return {k: v for k, v in json.loads(spec_json).items() if k not in ("samples", "seed")}
