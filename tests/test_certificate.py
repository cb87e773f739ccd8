"""The robustness certificate without riding: the Wilson interval against textbook values, the
draws' seeds and ranges, the ``[certify]`` table's checks, the certificate's round trip through
the library file, its staleness, and the runtime's ``min_success``. Each has a doctored input
that the check refuses."""

from __future__ import annotations

import dataclasses
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest
from skatelib.library.certificate import Certificate, entry_digest
from skatelib.library.errors import ConfigError, SkatelibError
from skatelib.pipeline.certify_run import store_certificate
from skatelib.pipeline.certify_spec import stale_reasons
from skatelib.pipeline.config import load_config
from skatelib.proving.certify.draw import draw_seeds, make_draw
from skatelib.proving.certify.ride import DrawResult
from skatelib.proving.certify.spec import CertifySpec
from skatelib.proving.certify.stats import summarize, wilson
from skatelib.runtime import EntryNotFound, MotionLibrary

from tests.helpers import TINY

REFERENCE = Path(__file__).parent / "data" / "tiny-reference.h5"  # v0.30_s1 and v0.40_s1

# Newcombe (1998), "Two-sided confidence intervals for the single proportion", Stat. Med. 17,
# Table I, method 3 (Wilson score without continuity correction): successes, n, lower, upper.
NEWCOMBE = [(81, 263, 0.2553, 0.3662), (15, 148, 0.0624, 0.1605), (0, 20, 0.0, 0.1611), (1, 29, 0.0061, 0.1718)]


@pytest.mark.parametrize(("k", "n", "low", "high"), NEWCOMBE)
def test_wilson_interval_matches_the_textbook(k, n, low, high):
    """The 95 % Wilson interval equals Newcombe's published values to their 4 decimals, and
    scipy's independent implementation to 1e-12."""
    from scipy.stats import binomtest

    lo, hi = wilson(k, n)
    assert (round(lo, 4), round(hi, 4)) == (low, high)
    ci = binomtest(k, n).proportion_ci(confidence_level=0.95, method="wilson")
    assert abs(lo - ci.low) < 1e-12 and abs(hi - ci.high) < 1e-12


def test_a_wald_interval_fails_the_textbook_check():
    """Negative control: the Wald interval (p -+ z sqrt(p(1-p)/n)) differs from Newcombe's Wilson
    values (0 of 20 gives 0 to 0), so the check above can fail."""
    k, n = 0, 20
    p = k / n
    half = 1.959963984540054 * np.sqrt(p * (1 - p) / n)
    assert (round(p + half, 4)) != 0.1611
    with pytest.raises(ValueError, match="0 <= successes <= n"):
        wilson(21, 20)


def test_a_draw_is_made_by_its_seed_alone_within_its_ranges():
    """An entry's draw seeds depend on the table's seed and the entry key only; N draws are the
    first N of any larger N; a draw made again from its seed alone is the same; every drawn value
    lies in its range. Another table seed or another entry gives other seeds."""
    spec = CertifySpec(samples=50)
    seeds = draw_seeds(spec, "v0.50_s2")
    assert seeds == draw_seeds(dataclasses.replace(spec, samples=50), "v0.50_s2")
    assert seeds[:7] == draw_seeds(dataclasses.replace(spec, samples=7), "v0.50_s2")
    assert len(set(seeds)) == 50
    assert not set(seeds) & set(draw_seeds(spec, "v0.70_s2"))
    assert not set(seeds) & set(draw_seeds(dataclasses.replace(spec, seed=1), "v0.50_s2"))
    ranges = spec.ranges()
    for s in seeds:
        d = make_draw(spec, s)
        assert d == make_draw(CertifySpec(), s)  # N and the seed of the table do not enter a draw
        e = d.errors
        for name, value in (("robot_mass", e.mass_scale), ("floor_mu", e.floor_mu), ("truck_stiffness", e.kb_scale),
                            ("rolling", e.rolling_scale), ("deck_mass", e.deck_mass_scale),
                            ("motor_strength", e.motor_scale), ("payload_kg", e.payload_kg),
                            ("shove_Ns", d.shove_Ns), ("payload_z_m", e.payload_pos_m[2])):
            lo, hi = ranges[name]
            assert lo <= value <= hi, (name, value)
        assert 0.0 <= d.shove_at <= 1.0 and -np.pi <= d.shove_direction_rad <= np.pi
    assert make_draw(spec, seeds[0]) != make_draw(spec, seeds[1])


def _config(tmp_path: Path, table: str) -> Path:
    path = tmp_path / "c.toml"
    path.write_text(f'extends = "{TINY.as_posix()}"\n\n[certify]\n{table}\n')
    return path


@pytest.mark.parametrize(("table", "key", "says"), [
    ("bogus = 1", "certify.bogus", "unknown key; allowed keys in \\[certify\\]: samples"),
    ("floor_mu = [0.8, 0.4]", "certify.floor_mu", "low <= high"),
    ("floor_mu = [0.5]", "certify.floor_mu", "low <= high"),
    ("robot_mass = [0.05, 1.0]", "certify.robot_mass", "0.1x to 10x the planned value"),
    ("floor_mu = [0.0, 0.5]", "certify.floor_mu", "more than 0"),
    ("shove_Ns = [0, 80]", "certify.shove_Ns", "0 to 50"),
    ("state = 'guess'", "certify.state", "'true', 'estimate'"),
    ("samples = 0", "certify.samples", "out of range"),
    ("payload_kg = 'heavy'", "certify.payload_kg", "must be a list"),
])
def test_a_bad_certify_table_is_refused_naming_file_and_key(tmp_path, table, key, says):
    """An unknown key, a reversed or short range, a range outside what its --perturb key may
    take, an unknown state, no samples: a ConfigError naming the file and the key."""
    path = _config(tmp_path, table)
    with pytest.raises(ConfigError, match=says) as e:
        load_config(path)
    assert e.value.key == key and str(path) in str(e.value)


def test_the_certify_table_is_read_and_leaves_the_build_alone(tmp_path):
    """A valid table is read as given; the entries' cache keys (the problem's JSON) do not
    change with it, so certifying differently never re-solves a library."""
    cfg = load_config(_config(tmp_path, "samples = 7\nfloor_mu = [0.5, 0.55]"))
    assert cfg.certify.samples == 7 and cfg.certify.floor_mu == (0.5, 0.55)
    assert cfg.problem_json() == load_config(TINY).problem_json()
    assert load_config(TINY).certify == CertifySpec()


def _rides(key: str, passed: list[bool]) -> list[DrawResult]:
    return [DrawResult(key, 100 + i, ok, () if ok else ("fall",), 0.1 * i, "" if ok else "fall: x")
            for i, ok in enumerate(passed)]


def test_summary_counts_modes_and_the_shove_margin():
    """Three of five pass; the gentlest failed shove is 0.2 N s (seed 102), so every ride shoved
    up to 0.1 N s passed; the modes are the failed rides'."""
    rides = _rides("k", [True, True, False, True, False])
    e = summarize("k", rides, "d")
    assert (e.successes, e.samples, e.worst_seed) == (3, 5, 102)
    assert e.shove_failed_Ns == pytest.approx(0.2) and e.shove_survived_Ns == pytest.approx(0.1)
    assert e.modes["fall"] == 2 and e.modes["speed"] == 0
    assert (e.low, e.high) == wilson(3, 5)
    clean = summarize("k", _rides("k", [True] * 4), "d")
    assert clean.shove_failed_Ns is None and clean.worst_seed is None and clean.shove_survived_Ns == pytest.approx(0.3)


@pytest.fixture
def certified(tmp_path):
    """A copy of the tiny library with a certificate made up of rides: v0.30_s1 passed 1 of 2,
    v0.40_s1 2 of 2."""
    path = tmp_path / "lib.h5"
    shutil.copy(REFERENCE, path)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the reference file is format 1.5
        lib = MotionLibrary.open(path)
        entries = {k: summarize(k, _rides(k, ok), entry_digest(lib[k].arrays))
                   for k, ok in (("v0.30_s1", [True, False]), ("v0.40_s1", [True, True]))}
        cert = Certificate(CertifySpec(samples=2).as_json(), "0123456789abcdef", entries)
        store_certificate(path, cert)
    return path, cert


def test_the_certificate_round_trips_through_the_file(certified):
    """Written into the library (format 1.6, checksum renewed), read back equal, draws and all."""
    path, cert = certified
    lib = MotionLibrary.open(path)
    assert lib.attrs["format_version"] == "1.6"
    assert lib.certificate == cert and Certificate.from_json(cert.to_json()) == cert
    assert lib.certificate is not None and lib.certificate.entries["v0.30_s1"].draws[1].modes == ("fall",)


def test_a_certificate_of_other_code_distributions_or_data_is_stale(certified):
    """stale_reasons names other judging code, other distributions and a changed entry; figures
    made on other arrays are not the entry's (current_for is None). The certificate made by this
    code on these entries from these distributions is current."""
    from skatelib.proving.twin.fingerprint import twin_fingerprint

    path, cert = certified
    lib = MotionLibrary.open(path)
    reasons = stale_reasons(lib, cert, CertifySpec(floor_mu=(0.3, 0.8)))
    assert any("other code" in r for r in reasons) and any("other distributions" in r for r in reasons)
    current = dataclasses.replace(cert, code=twin_fingerprint())
    assert stale_reasons(lib, current, CertifySpec()) == []
    e = lib["v0.30_s1"]
    moved = {**e.arrays, "state": e.state + 1e-9}
    assert cert.current_for("v0.30_s1", moved) is None and cert.current_for("v0.30_s1", e.arrays) is not None
    doctored = dataclasses.replace(current, entries={**cert.entries, "v0.30_s1": dataclasses.replace(
        cert.entries["v0.30_s1"], digest="0" * 16)})
    assert stale_reasons(lib, doctored, CertifySpec()) == ["entries changed since: v0.30_s1"]


def test_select_and_route_skip_entries_below_min_success(certified):
    """With min_success 0.9 the entry that passed 1 of 2 is skipped, with its rate named in
    EntryNotFound; without min_success both are served; an uncertified library serves none under
    min_success and says why; min_success outside [0, 1] is a ValueError."""
    path, _ = certified
    lib = MotionLibrary.open(path)
    assert lib.select(0.3).key == "v0.30_s1"
    assert lib.select(0.3, clamp=True, min_success=0.9).key == "v0.40_s1"
    assert lib.select(0.3, min_success=0.5).key == "v0.30_s1"
    with pytest.raises(EntryNotFound, match=r"v0.30_s1 \(success rate 0.50 < min_success 0.9\)"):
        lib.select(0.3, min_success=0.9)
    assert [e.key for e in lib.route(0.0, 0.4, min_success=0.9)] == ["v0.40_s1"]
    with pytest.raises(EntryNotFound, match=r"skipped below min_success: v0\.30_s1"):
        lib.route(0.0, 0.3, min_success=0.9)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        plain = MotionLibrary.open(REFERENCE)
    with pytest.raises(EntryNotFound, match=r"v0.30_s1 \(no certificate\)"):
        plain.select(0.3, min_success=0.1)
    with pytest.raises(ValueError, match="min_success"):
        lib.select(0.3, min_success=1.5)


def test_certify_refuses_a_bad_table_and_track_draw_off_the_twin(tmp_path):
    """``certify --config`` with a reversed range exits 2 naming the file and the key, before any
    ride and with the library unchanged; ``track --draw`` without ``--plant mujoco`` exits 2 saying
    what to add."""
    from tests.helpers import run_cli

    lib = tmp_path / "lib.h5"
    shutil.copy(REFERENCE, lib)
    bad = _config(tmp_path, "floor_mu = [0.8, 0.4]")
    r = run_cli(["certify", str(lib), "--config", str(bad), "--no-progress"])
    assert r.returncode == 2 and str(bad) in r.stderr and "certify.floor_mu" in r.stderr, r.stderr
    assert lib.read_bytes() == REFERENCE.read_bytes()
    t = run_cli(["track", str(lib), "--draw", "5", "-e", "v0.30_s1"])
    assert t.returncode == 2 and "give --plant mujoco and one --entry" in t.stderr, t.stderr


def test_an_entry_of_no_rides_is_not_certified_and_a_bad_certificate_only_matters_when_asked(certified):
    """An entry whose figures hold no ride (rate NaN) is skipped under any min_success, not passed;
    a certificate that cannot be read refuses min_success but leaves select and route without it."""
    path, cert = certified
    lib = MotionLibrary.open(path)
    empty = dataclasses.replace(cert.entries["v0.40_s1"], successes=0, samples=0)
    store_certificate(path, dataclasses.replace(cert, entries={**cert.entries, "v0.40_s1": empty}))
    lib = MotionLibrary.open(path)
    with pytest.raises(EntryNotFound, match=r"v0.40_s1 \(success rate nan < min_success 0\)"):
        lib.select(0.4, min_success=0.0)
    broken = MotionLibrary.open(path)
    broken.attrs = {**broken.attrs, "certificate_json": "{not json"}  # as a damaged certificate reads
    assert broken.select(0.4).key == "v0.40_s1" and [e.key for e in broken.route(0.0, 0.4)] == ["v0.40_s1"]
    with pytest.raises(SkatelibError):
        broken.select(0.4, min_success=0.5)
