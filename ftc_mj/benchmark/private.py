"""The private split's key: the draws of ``--split private`` derive from a secret given at run time, so nobody
without it can reproduce them, and so nobody can tune on them.

The key comes from the environment variable :data:`KEY_ENV` or from a file (``--key-file``; its bytes, one
trailing newline dropped), at least :data:`MIN_KEY_BYTES` bytes. Draw ``index`` of version ``v`` is seeded
by ``HMAC-SHA256(key, "ftc-mj private draw" ‖ v ‖ index)`` (:func:`private_entropy`): a keyed hash, so the
index and every output of a run say nothing about another draw's stream without the key. The key itself
is never written anywhere: the outputs keep only :func:`key_id` (the first 16 hex digits of its SHA-256),
which tells two folders of different keys apart.
"""

from __future__ import annotations

import hashlib
import hmac
import os
from pathlib import Path

from ..errors import BadInput

KEY_ENV = "FTC_MJ_PRIVATE_KEY"
"""The environment variable holding the private split's key."""
MIN_KEY_BYTES = 16
"""Shortest key (128 bits: a key id of a shorter, guessable one would give the key away by search)."""


def read_key(key_file: str | None = None) -> bytes:
    """The private key from ``key_file`` (if given) or :data:`KEY_ENV`; :class:`BadInput` (one line) without
    one or with one shorter than :data:`MIN_KEY_BYTES`."""
    if key_file is not None:
        path = Path(key_file)
        try:
            key = path.read_bytes()
        except OSError as err:
            raise BadInput(f"--key-file: cannot read {key_file} ({err.strerror})") from None
        key = key[:-1] if key.endswith(b"\n") else key
        where = "--key-file"
    else:
        key = os.environ.get(KEY_ENV, "").encode()
        where = KEY_ENV
    if not key:
        raise BadInput(f"--split private: needs a key: set {KEY_ENV} or give --key-file")
    if len(key) < MIN_KEY_BYTES:
        raise BadInput(f"{where}: the private key has {len(key)} bytes; it needs at least {MIN_KEY_BYTES}")
    return key


def key_id(key: bytes) -> str:
    """First 16 hex digits of the key's SHA-256: what the outputs keep to tell keys apart."""
    return hashlib.sha256(key).hexdigest()[:16]


def private_key_id(key: bytes | None) -> dict[str, str]:
    """What a private bench's outputs keep of its key: ``{"private_key_id": key_id(key)}`` (part of the bench's
    identity: a folder of one key refuses another's runs)."""
    if key is None:
        raise BadInput(f"--split private: needs a key: set {KEY_ENV} or give --key-file")
    return {"private_key_id": key_id(key)}


def private_entropy(key: bytes, version: str, index: int) -> int:
    """The 256-bit entropy of private draw ``index`` of ``version``: HMAC-SHA256 of the version and index
    under ``key`` (module docstring)."""
    msg = b"ftc-mj private draw\0" + version.encode() + b"\0" + str(index).encode()
    return int.from_bytes(hmac.new(key, msg, hashlib.sha256).digest(), "big")
