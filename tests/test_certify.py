"""``skatelib certify`` riding: a few draws of one entry of the tiny library on the twin. The same
seed gives the same certificate in this process, on loky workers and on a dask LocalCluster
(another seed gives another one); a certification interrupted after two rides and run again equals
an uninterrupted one, reusing the two; the command stores the certificate, ``info`` reads it back,
and ``track --draw`` rides a stored draw again to the stored verdict."""

from __future__ import annotations

import dataclasses
import shutil
import warnings
from pathlib import Path

import pytest

pytest.importorskip("mujoco")
from skatelib.pipeline.certify_run import CertifyOptions, certify
from skatelib.proving.certify.spec import CertifySpec
from skatelib.runtime import MotionLibrary

from tests.helpers import run_cli

REFERENCE = Path(__file__).parent / "data" / "tiny-reference.h5"
KEY = "v0.30_s1"
SPEC = CertifySpec(samples=3, seed=5)


@pytest.fixture
def lib(tmp_path, monkeypatch):
    monkeypatch.setenv("SKATELIB_CACHE_DIR", str(tmp_path / "cache"))
    path = tmp_path / "lib.h5"
    shutil.copy(REFERENCE, path)
    warnings.filterwarnings("ignore", message=".*format 1.5")  # the reference file's format
    return path


@pytest.mark.slow  # three runners, a dask cluster among them
def test_same_seed_same_certificate_on_every_runner(lib):
    """Serial, two loky workers and a dask LocalCluster give identical certificates (draws,
    verdicts, figures); another seed gives another certificate."""
    distributed = pytest.importorskip("distributed")
    serial = certify(lib, SPEC, [KEY], CertifyOptions(jobs=1, cache=False))
    loky = certify(lib, SPEC, [KEY], CertifyOptions(jobs=2, cache=False))
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        dask = certify(lib, SPEC, [KEY], CertifyOptions(backend="dask", scheduler=client, cache=False))
    assert serial.to_json() == loky.to_json() == dask.to_json()
    other = certify(lib, dataclasses.replace(SPEC, seed=6), [KEY], CertifyOptions(jobs=1, cache=False))
    assert [d.seed for d in other.entries[KEY].draws] != [d.seed for d in serial.entries[KEY].draws]
    assert other.to_json() != serial.to_json()


def test_an_interrupted_certification_resumes_to_the_same_certificate(lib):
    """Ctrl-C after two rides (raised from the progress callback): the two are cached; the run
    again rides the third alone and its certificate equals one made without interruption."""
    heard: list[bool] = []

    def stop_after_two(result, cached):
        heard.append(cached)
        if len(heard) == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        certify(lib, SPEC, [KEY], CertifyOptions(jobs=1), stop_after_two)
    heard.clear()
    resumed = certify(lib, SPEC, [KEY], CertifyOptions(jobs=1), lambda r, cached: heard.append(cached))
    assert heard.count(True) == 2 and heard.count(False) == 1
    whole = certify(lib, SPEC, [KEY], CertifyOptions(jobs=1, cache=False))
    assert resumed.to_json() == whole.to_json()


def test_certify_stores_info_reads_and_track_draw_replays(lib):
    """``certify`` writes the certificate (the table printed, ``info`` shows it current); ``track
    --draw`` of the stored worst draw (or, none failing, the first) gives the stored verdict."""
    r = run_cli(["certify", str(lib), "-e", KEY, "--samples", "3", "--seed", "5", "-j", "1", "--no-progress"],
                timeout=600)  # the fixture's cache folder, through the environment
    assert r.returncode == 0, r.stdout + r.stderr
    cert = MotionLibrary.open(lib).certificate
    assert cert is not None and cert.entries[KEY].samples == 3
    i = run_cli(["info", str(lib)])
    assert "robustness certificate" in i.stdout and "stale" not in i.stdout, i.stdout
    e = cert.entries[KEY]
    draw = next((d for d in e.draws if d.seed == e.worst_seed), e.draws[0])
    t = run_cli(["track", str(lib), "--plant", "mujoco", "-e", KEY, "--draw", str(draw.seed)], timeout=600)
    assert t.returncode == (0 if draw.passed else 1), t.stdout + t.stderr
    assert f"draw {draw.seed}" in t.stdout


@pytest.mark.slow  # a worker pool started and interrupted
def test_sigint_leaves_no_worker_and_the_library_unchanged(lib, tmp_path):
    """SIGINT to ``certify -j 2`` once its first rides are cached: exit 130 saying how many rides
    are cached, after 10 s no process of its session is alive (found by session, not by name), the
    library's bytes as they were."""
    import os
    import signal
    import subprocess
    import time

    from tests.helpers import CLI
    from tests.test_reliability import _session

    before = lib.read_bytes()
    cache = Path(os.environ["SKATELIB_CACHE_DIR"])
    p = subprocess.Popen([*CLI, "certify", str(lib), "--samples", "8", "-j", "2", "--no-progress"],
                         env={**os.environ, "COLUMNS": "200"}, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, start_new_session=True)
    deadline = time.monotonic() + 300
    while not list((cache / "entries").glob("*.entry")) and time.monotonic() < deadline and p.poll() is None:
        time.sleep(0.2)
    assert p.poll() is None, "certify ended before it could be interrupted"
    assert len(_session(p.pid)) >= 3  # the command and its two workers
    os.kill(p.pid, signal.SIGINT)
    _, stderr = p.communicate(timeout=60)
    time.sleep(10)
    assert _session(p.pid) == [], "processes of the interrupted certify are still running"
    assert p.returncode == 130 and "rides are cached" in stderr and "resume" in stderr, stderr
    assert lib.read_bytes() == before


@pytest.mark.slow
def test_the_python_api_certifies_and_stores_as_the_command_does(lib):
    """``skatelib.certify`` rides and stores what the runner gives for the same table (the same
    certificate, read back from the file); arguments out of range are refused before any ride."""
    import skatelib

    heard: list[bool] = []
    cert = skatelib.certify(lib, [KEY], samples=2, seed=5, jobs=1, cache=False,
                            progress=lambda result, cached: heard.append(cached))
    assert heard == [False, False] and cert.entries[KEY].samples == 2
    assert MotionLibrary.open(lib).certificate.to_json() == cert.to_json()
    direct = certify(lib, dataclasses.replace(SPEC, samples=2), [KEY], CertifyOptions(jobs=1, cache=False))
    assert direct.entries[KEY] == cert.entries[KEY]
    before = lib.read_bytes()
    for bad in ({"jobs": 0}, {"samples": 0}, {"backend": "ray"}):
        with pytest.raises(ValueError, match=next(iter(bad))):
            skatelib.certify(lib, [KEY], **bad)  # type: ignore[arg-type]
    assert lib.read_bytes() == before
