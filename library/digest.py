"""Whole-file checksum of a library: SHA-256 of every byte with the checksum field zeroed.

The writer stores a fixed-length placeholder in the root attribute ``content_sha256``, hashes
the finished file with those 64 bytes set to ASCII zeros, then writes the digest over the
placeholder in place. Any changed byte anywhere (data, metadata or HDF5 bookkeeping) changes
the digest; h5py alone reads a zeroed block back silently.

Readers verify the raw bytes *before* handing the file to HDF5 (:func:`verify_raw`): a damaged
file can send HDF5's parser into an endless loop (a zeroed 4 KB block in the attribute heap did,
in the reliability fuzz test), so no byte of a file is parsed until its digest matches.
"""

from __future__ import annotations

import hashlib
import re
import secrets
from pathlib import Path
from typing import Any

from skatelib.library import schema
from skatelib.library.errors import LibraryFormatError

DIGEST_LEN = 64
_ZEROS = b"0" * DIGEST_LEN
_HEX64 = re.compile(rb"[0-9a-f]{64}")
# The attribute value follows its name in the attribute message (name, datatype and dataspace
# messages, then the 64 bytes); 256 bytes is generous for every HDF5 attribute-message version.
_NAME_TO_VALUE_MAX = 256
_USERBLOCK_MAX = 1 << 16  # HDF5 looks for its signature at 0, 512, 1024, ... (a user block before it)


def placeholder() -> bytes:
    """A random 64-byte marker, unique in the file with overwhelming probability."""
    return secrets.token_hex(DIGEST_LEN // 2).encode()


def file_digest(raw: bytes | bytearray | memoryview, field: bytes) -> str | None:
    """SHA-256 of ``raw`` with the one occurrence of ``field`` zeroed; None when ``field`` does
    not occur exactly once."""
    mv = memoryview(raw)
    b = raw if isinstance(raw, bytes) else bytes(mv)
    pos = b.find(field)
    if pos < 0 or b.find(field, pos + 1) >= 0:
        return None
    h = hashlib.sha256()
    h.update(mv[:pos])
    h.update(_ZEROS)
    h.update(mv[pos + DIGEST_LEN :])
    return h.hexdigest()


def verify_raw(raw: bytes, name: bytes) -> tuple[bool, str | None]:
    """Check a file's bytes against its stored digest without parsing HDF5.

    Looks for the attribute ``name`` (``b"content_sha256"``) in the raw bytes and for the 64 hex
    digits of its value right after it. Returns whether any such value was found (False: the
    attribute is missing or its bytes are damaged) and the one that is the file's digest (None
    when none is: the file is corrupt).
    """
    found = False
    start = raw.find(name)
    while start >= 0:
        seg = raw[start + len(name): start + len(name) + _NAME_TO_VALUE_MAX]
        m = _HEX64.search(seg)
        if m is not None:
            found = True
            if file_digest(raw, m.group()) == m.group().decode():
                return True, m.group().decode()
        start = raw.find(name, start + 1)
    return found, None


def seal(raw: bytearray, marker: bytes) -> str:
    """Replace ``marker`` in a file's bytes by the file's digest, in place; returns the digest."""
    d = file_digest(raw, marker)
    if d is None:
        raise RuntimeError("checksum placeholder not found exactly once")
    pos = bytes(raw).find(marker)
    raw[pos : pos + DIGEST_LEN] = d.encode()
    return d


def refuse_damaged(path: Path, raw: bytes) -> str:
    """Refuse a damaged file before HDF5 parses any of it (see :mod:`skatelib.library.digest`);
    returns the verified digest."""
    found, digest = verify_raw(raw, schema.A_CHECKSUM.encode())
    if digest is not None:
        return digest
    field = f"/@{schema.A_CHECKSUM}"
    if found:
        raise LibraryFormatError(path, field, "the file does not match its checksum: it is corrupt; rebuild it")
    if not raw.startswith(schema.HDF5_SIGNATURE) and schema.HDF5_SIGNATURE not in raw[:_USERBLOCK_MAX]:
        raise LibraryFormatError(path, "/", "not an HDF5 file (truncated, corrupt or of another type); "
                                            "give a library written by 'skatelib build'")
    eof = hdf5_end_of_file(raw)
    if eof is not None and eof > len(raw):
        raise LibraryFormatError(path, "/", f"truncated: {len(raw)} of its {eof} bytes are there; "
                                            "copy it again or rebuild it with 'skatelib build'")
    if schema.FORMAT_NAME.encode() not in raw:
        raise LibraryFormatError(path, f"/@{schema.A_FORMAT}",
                                 "not a skatelib motion library (an HDF5 file without its format name)")
    raise LibraryFormatError(path, field, "checksum attribute missing or damaged: the file is corrupt; rebuild it")


def hdf5_end_of_file(raw: bytes) -> int | None:
    """The file length HDF5's superblock (at offset 0, 8-byte addresses) records, or None."""
    if not raw.startswith(schema.HDF5_SIGNATURE) or len(raw) < 64:
        return None
    version = raw[8]
    if version in (0, 1):
        if raw[13] != 8:  # size of offsets
            return None
        at = 24 + (4 if version == 1 else 0) + 16  # fixed fields, base and free-space addresses
    elif version in (2, 3):
        if raw[9] != 8:
            return None
        at = 12 + 16  # fixed fields, base and superblock-extension addresses
    else:
        return None
    return int.from_bytes(raw[at:at + 8], "little")


def check_checksum_attribute(path: Path, stored_sum: Any, digest: str | None) -> None:
    """The checksum attribute HDF5 reads is the one verified on the raw bytes."""
    if stored_sum is None:
        raise LibraryFormatError(path, f"/@{schema.A_CHECKSUM}", "required root attribute missing")
    field = stored_sum if isinstance(stored_sum, bytes) else str(stored_sum).encode()
    if field.decode(errors="replace") != digest:
        raise LibraryFormatError(
            path, f"/@{schema.A_CHECKSUM}", "the file does not match its checksum: it is corrupt; rebuild it"
        )


def read_raw(path: Path) -> bytes:
    """The file's bytes; of a file that is not HDF5, no more than where HDF5 looks for its signature.

    Raises:
        LibraryFormatError: A folder, a device, a missing or unreadable file.
    """
    if path.is_dir():
        raise LibraryFormatError(path, "/", "is a folder, not a library file; give the .h5 file in it")
    if not path.is_file():
        if path.exists():
            raise LibraryFormatError(path, "/", "is not a regular file (a device or a pipe); give the .h5 file")
        raise LibraryFormatError(path, "/", "no such file; build one with 'skatelib build'")
    try:
        with open(path, "rb") as f:
            raw = f.read(_USERBLOCK_MAX)  # where HDF5 looks for its signature (after a user block)
            if schema.HDF5_SIGNATURE in raw:  # another file is read no further
                f.seek(0)
                raw = f.read()
    except OSError as e:
        raise LibraryFormatError(path, "/", f"cannot be read ({e.strerror}); give a file this user can read") from e
    return raw

