"""Whole-file checksum of a library: SHA-256 of every byte with the checksum field zeroed.

The writer stores a fixed-length placeholder in the root attribute ``content_sha256``, hashes
the finished file with those 64 bytes set to ASCII zeros, then writes the digest over the
placeholder in place. Any changed byte anywhere (data, metadata or HDF5 bookkeeping) changes
the digest; h5py alone reads a zeroed block back silently.
"""

from __future__ import annotations

import hashlib
import secrets
from pathlib import Path

DIGEST_LEN = 64
_ZEROS = b"0" * DIGEST_LEN


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


def seal(path: Path, marker: bytes) -> str:
    """Replace ``marker`` in the file at ``path`` by the file's digest; returns the digest."""
    raw = bytearray(path.read_bytes())
    d = file_digest(raw, marker)
    if d is None:
        raise RuntimeError(f"{path}: checksum placeholder not found exactly once")
    pos = bytes(raw).find(marker)
    raw[pos : pos + DIGEST_LEN] = d.encode()
    path.write_bytes(bytes(raw))
    return d
