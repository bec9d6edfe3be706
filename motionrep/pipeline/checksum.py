"""The SHA-256 of a clip's source: what ``motionrep compress --resume`` compares with the checksum a container
records (``extra.source_sha256``, ``specs/databases.md``) to know that a clip's source has not changed."""

from __future__ import annotations

from typing import Any

__all__ = ["clip_checksum", "content_digest", "SOURCE_CHECKSUM_KEY"]

#: Key of ``Container.extra`` holding the SHA-256 (hex) of the clip's source (:func:`clip_checksum`), written when
#: it is known (batch compression); what ``--resume`` compares.
SOURCE_CHECKSUM_KEY = "source_sha256"


def content_digest(value: Any, hasher: Any = None) -> Any:
    """A SHA-256 over ``value``'s content, the same in every process and on every machine: dataclasses field by
    field, arrays by dtype, shape and little-endian bytes, strings, numbers, None, tuples and lists.

    Returns:
        The ``hashlib`` object (``.hexdigest()``).
    """
    import dataclasses
    import hashlib

    import numpy as np

    h = hashlib.sha256() if hasher is None else hasher
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        h.update(f"<{type(value).__name__}>".encode())
        for f in dataclasses.fields(value):
            h.update(f.name.encode() + b"=")
            content_digest(getattr(value, f.name), h)
    elif isinstance(value, np.ndarray):
        a = np.ascontiguousarray(value)
        h.update(f"<array {a.dtype.str[1:]} {a.shape}>".encode())
        h.update(a.astype(a.dtype.newbyteorder("<"), copy=False).tobytes())
    elif isinstance(value, (tuple, list)):
        h.update(f"<seq {len(value)}>".encode())
        for v in value:
            content_digest(v, h)
    else:
        h.update(f"<{type(value).__name__} {value!r}>".encode())
    return h


def clip_checksum(source: Any, name: str | None = None) -> str:
    """The SHA-256 (hex) of clip ``name``'s source: of the file's bytes for a file of one clip (BVH, NPZ,
    ``.mrc``), of the container's bytes for a clip of an archive, of the clip's content as stored
    (:func:`content_digest`) for a clip of a database.  Recorded in every container a batch writes, so that
    ``--resume`` knows a clip whose source has not changed."""
    import hashlib

    if source.kind == "archive":
        return hashlib.sha256(source.archive.read_bytes(source.resolve(name))).hexdigest()
    if source.kind == "database":
        return "db-" + content_digest(source.read_stored(name)[1]).hexdigest()
    source.resolve(name)
    h = hashlib.sha256()
    with open(source.path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()
