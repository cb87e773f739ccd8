"""Checks made before any solve or compile, so that a build fails in a second with a clear
message instead of after all the solving: the output path, the overwrite rule, the cache
folder, the dask scheduler's address and reachability, leftovers of killed builds."""

from __future__ import annotations

import re
import socket
import tempfile
from collections.abc import Sequence
from pathlib import Path

from skatelib.library import trust
from skatelib.library.atomic import head
from skatelib.library.digest import read_raw
from skatelib.library.errors import ConfigError, LibraryFormatError, OutputError
from skatelib.library.schema import FORMAT_NAME, HDF5_SIGNATURE
from skatelib.library.temporaries import remove_stale_temporaries
from skatelib.library.trust import CACHE_ENV, cache_dir

SCHEDULER_RE = re.compile(r"^(tcp|tls)://(?P<host>\[[0-9a-fA-F:]+\]|[^:/\s]+):(?P<port>\d{1,5})$")


def is_skatelib_library(path: Path) -> bool:
    """True when ``path`` is an HDF5 file that names itself a skatelib motion library, even a
    damaged one. Reads the raw bytes only (as the reader does first): a damaged file can hang HDF5's
    parser."""
    try:
        raw = read_raw(path)  # a device or a folder is none; a file that is not HDF5 is read no further
    except LibraryFormatError:
        return False
    return raw.startswith(HDF5_SIGNATURE) and FORMAT_NAME.encode() in raw


def is_hdf5(path: Path) -> bool:
    """True when ``path`` starts with the HDF5 signature (a library, perhaps a damaged or foreign one)."""
    return head(path, len(HDF5_SIGNATURE)) == HDF5_SIGNATURE


def is_rerun_recording(path: Path) -> bool:
    """True when ``path`` starts with the Rerun recording signature."""
    return head(path, 3) == b"RRF"


def check_output(out: Path, inputs: Sequence[Path] = (), force: bool | None = None, what: str = "library") -> None:
    """Refuse an output that is a folder, one of the inputs, an existing file of another type
    (unless ``force``), or in a folder that cannot be written; remove stale temporaries there.

    Args:
        force: The command's ``--force`` (overwrite a file of another type); None for a command
            without that option, whose advice then does not name it.
        what: ``"library"`` (an HDF5 motion library), ``"recording"`` (a Rerun ``.rrd``),
            ``"twin"`` (a MuJoCo MJCF file), ``"video"`` (an MP4 or a GIF), ``"frontier"`` or
            ``"profile"`` (JSON), ``"mcap"`` or ``"report"`` (HTML).

    Raises:
        OutputError: Saying what to do.
    """
    out = Path(out)
    example, same_type, kind = _OUTPUTS[what]
    if out.is_dir():
        raise OutputError(out, f"is a folder; name the {what} file, e.g. {out / example}")
    resolved = out.resolve()
    for p in inputs:
        if Path(p).resolve() == resolved:
            raise OutputError(out, "is an input of this command; choose another output file")
    if out.exists() and not force and not same_type(out):
        advice = "choose another output file, or pass --force" if force is False else (
            "choose another output file, or remove that one")
        raise OutputError(out, f"exists and is not a {kind}; refusing to overwrite it ({advice})")
    _writable(out.parent, out, "its folder {folder} cannot be written ({why}); choose another output")
    remove_stale_temporaries(out.parent)


def check_folder(out: Path) -> None:
    """A folder that a command writes files into (``plot -o``, ``export -o``): not a file, and
    writable, or (when it does not exist) its nearest existing parent writable; nothing is made
    here (the command makes the folder with its files, so that a failure leaves none). Stale
    temporaries of killed writers are removed there and beside it.

    Raises:
        OutputError: Saying what to do.
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise OutputError(out, "is a file; name a folder for the files, e.g. out/figures")
    existing = out
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise OutputError(out, f"{existing} is a file, so the folder cannot be made; choose another one")
    _writable(existing, out, "the folder cannot be written ({why}); choose another one" if existing == out
              else "it would be made in {folder}, which cannot be written ({why}); choose another one")
    for folder in {existing, existing.parent}:
        remove_stale_temporaries(folder)


def _writable(folder: Path, named: Path, message: str, mode: int = 0o777) -> None:
    """Make ``folder`` if needed (with ``mode``) and write a probe file in it, or refuse naming ``named``."""
    try:
        folder.mkdir(mode=mode, parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".skatelib-probe-"):
            pass
    except OSError as e:
        blocking = next((p for p in (folder, *folder.parents) if p.exists() and not p.is_dir()), None)
        why = f"{blocking} is a file" if blocking is not None else e.strerror
        raise OutputError(named, message.format(folder=folder, why=why)) from e


def check_cache_dir(entries_too: bool = True) -> Path:
    """The cache folder exists (or can be made, private to the user) and is writable, it and its
    subfolders belong to the user and no one else can write them, and a shared cache named in
    ``$SKATELIB_TRUSTED_CACHE`` is read-only (:mod:`skatelib.library.trust`).

    Args:
        entries_too: False when the command keeps only compiled code there (``--no-cache``,
            ``solve``, ``frontier``): the advice then is not to pass ``--no-cache``.

    Raises:
        OutputError: Naming the folder, what is wrong with it and what to do.
    """
    d = cache_dir()
    try:
        d.mkdir(mode=0o700, parents=True, exist_ok=True)
        trust.check_own(d, trust.OWN_ADVICE if entries_too else trust.compile_advice())
        (d / "entries").mkdir(mode=0o700, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=d, prefix=".skatelib-probe-"):
            pass
    except OSError as e:
        advice = ("set ${env} to a writable folder, or pass --no-cache" if entries_too else
                  "the compiled stage functions are kept there even without the entry cache: set ${env} to a "
                  "writable folder, or set [optimization] compile = false (3-4x slower solves)")
        raise OutputError(d, f"the cache folder cannot be used ({e.strerror}); "
                             + advice.format(env=CACHE_ENV)) from e
    shared = trust.trusted_cache()
    if shared is not None:
        trust.check_shared(shared)
    remove_stale_temporaries(d / "entries")
    return d


def check_compile_dir() -> Path:
    """The folder of compiled code (:func:`trust.compile_dir`) can be used: when it is the cache
    folder, :func:`check_cache_dir`'s checks for a command that keeps only compiled code there
    (``--no-cache``, ``solve``, ``frontier``); when ``$SKATELIB_COMPILE_DIR`` sets it apart, the
    same rules for that folder (private, the user's own, writable).

    Raises:
        OutputError: Naming the folder, what is wrong with it and what to do.
    """
    d = trust.compile_dir()
    if d == cache_dir():
        return check_cache_dir(entries_too=False)
    _writable(d, d, f"the folder of compiled code cannot be used ({{why}}); set {trust.COMPILE_ENV} to a writable "
                    "folder, or set [optimization] compile = false (3-4x slower solves)", mode=0o700)
    trust.check_own(d, trust.compile_advice())
    return d


def check_scheduler(address: str, timeout_s: float = 3.0) -> None:
    """The dask scheduler address is ``tcp://HOST:PORT`` (or ``tls://``) and something listens there.

    Raises:
        ConfigError: On a malformed or unreachable address (key ``--scheduler``).
    """
    m = SCHEDULER_RE.match(address)
    if m is None:
        raise ConfigError("--scheduler", "--scheduler", f"{address!r} is not an address like tcp://HOST:PORT")
    if address.startswith("tls://"):
        from skatelib.pipeline.build.sweep import tls_settings

        tls_settings()
    host, port = m["host"].strip("[]"), int(m["port"])
    try:
        with socket.create_connection((host, port), timeout=timeout_s):
            pass
    except OSError as e:
        raise ConfigError("--scheduler", "--scheduler",
                          f"no dask scheduler answers at {address} within {timeout_s:.0f} s ({e.strerror or e}); "
                          "start one with 'dask scheduler' or check the address") from e



def is_mjcf(path: Path) -> bool:
    """Whether ``path`` starts like a MuJoCo model file."""
    return head(path, 64).lstrip().startswith(b"<mujoco")


def is_mcap(path: Path) -> bool:
    """Whether ``path`` starts with the MCAP magic."""
    return head(path, 5) == b"\x89MCAP"


def is_json(path: Path) -> bool:
    """Whether ``path`` starts like a JSON object (a frontier file)."""
    return head(path, 64).lstrip().startswith(b"{")


def is_html(path: Path) -> bool:
    """Whether ``path`` starts like an HTML document (a report)."""
    return head(path, 64).lstrip().lower().startswith((b"<!doctype html", b"<html"))


def is_video(path: Path) -> bool:
    """Whether ``path`` starts like an MP4 (an ``ftyp`` box) or a GIF."""
    start = head(path, 12)
    return start[4:8] == b"ftyp" or start[:6] in (b"GIF87a", b"GIF89a")


# what -> (an example file name, whether an existing file is of that kind, what it is called)
_OUTPUTS = {
    "library": ("library.h5", is_skatelib_library, "skatelib library"),
    "recording": ("recording.rrd", is_rerun_recording, "Rerun recording"),
    "twin": ("twin.xml", is_mjcf, "MuJoCo model"),
    "video": ("run.mp4", is_video, "video"),
    "frontier": ("frontier.json", is_json, "JSON file"),
    "profile": ("profile.json", is_json, "JSON file"),
    "mcap": ("library.mcap", is_mcap, "MCAP file"),
    "report": ("report.html", is_html, "HTML file"),
}
