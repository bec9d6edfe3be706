"""The bytes of a ``transform`` payload of version 2 or 3: the same quantised wavelet coefficients as version 1
(:class:`~._stream.Quantised`), coded by a compiled adaptive binary arithmetic coder with context mixing
(:mod:`._ccoder`, plain C in ``_c/mrcoder.c``). Layout and models in ``specs/codecs.md`` ("Payload version 2",
"Payload version 3").

Compared with version 1 (static models fitted per clip and stored, pass-parallel range decoding): the models
adapt as the clip is decoded, so none is stored; each coefficient's zero flag, sign and magnitude bits are
predicted from three contexts at once (its neighbourhood in time and in the coarser level, the same with the
time and parent parts apart, and the feature itself at that level), mixed by weights that adapt too; features
whose coefficients are all zero are flagged once and cost nothing more (not even their step exponent).
10-15 % fewer bytes on the CMU clips at every bound (``benchmarks/results/rate_coding.md``), lossless: the same
integers, so the same decoded motion.

Version 3 (the default, :data:`VERSION`) is version 2 whose fixed-context counters start from states trained on
clips (``_c/mrprior3.h``, written by ``benchmarks/prior3.py``) instead of from P = 1/2: the same layout and
decisions, fewer bytes spent learning (``benchmarks/results/rate5.md``). ``version`` selects either.
"""

from __future__ import annotations

import numpy as np

from motionrep.errors import PayloadError

from . import _ccoder
from ._stream import Quantised
from ._wavelet import level_sizes, num_levels

__all__ = ["pack", "unpack", "declared", "VALUES_PER_BYTE", "VERSION", "VERSIONS"]

#: The version :func:`pack` writes by default, and the versions this module reads and writes.
VERSION = 3
VERSIONS = (2, 3)

#: ``F * D + D + R`` of a payload is at most this many times its bytes (the encoder pads with zero bytes when a
#: clip of nearly constant features would code in fewer), so a header cannot make the decoder allocate or work
#: out of proportion to the data.
VALUES_PER_BYTE = 4096


def _fail(exc: ValueError, version: int) -> PayloadError:
    return PayloadError(f"transform payload (version {version}): {exc}")


def _check(version: int) -> int:
    if version not in VERSIONS:
        raise ValueError(f"transform payload version {version!r}: this stream writes and reads {VERSIONS}")
    return int(version)


def pack(q: Quantised, version: int = VERSION) -> bytes:
    """The payload bytes of ``q`` in ``version`` (2 or 3).

    Raises:
        ValueError: for values the format cannot hold (the encoder's search never produces them), or another
            version.
    """
    F, D = int(q.num_frames), int(q.num_features)
    coef = np.ascontiguousarray(np.concatenate([np.asarray(c, np.int64) for c in q.coefficients], axis=0))
    return _ccoder.encode(F, D, int(q.region_frames), np.ascontiguousarray(q.feature_exponents, np.int64),
                          np.ascontiguousarray(q.region_exponents, np.int64), coef, _check(version))


def declared(data: bytes, version: int = VERSION) -> tuple[int, int, int]:
    """``(frames F, features D, region frames)`` the head of payload bytes of ``version`` declares (nothing else
    is decoded; the head is the same in versions 2 and 3), for ``Codec.check_payload``.

    Raises:
        PayloadError: for a malformed head (a count out of its range).
    """
    version = _check(version)
    try:
        F, D, region = _ccoder.declared(data)
    except ValueError as exc:
        raise _fail(exc, version) from None
    return int(F), int(D), int(region)


def unpack(data: bytes, version: int = VERSION) -> Quantised:
    """The :class:`~._stream.Quantised` content of payload bytes of ``version`` (2 or 3). A feature whose
    coefficients are all zero gets the step exponent 0 (its step is not stored: it decodes to zeros at any step).

    Raises:
        PayloadError: for damaged or inconsistent data (one line saying what).
    """
    F, D, region = declared(data, version)
    if F * D + D + -(-F // region) > VALUES_PER_BYTE * len(data):  # before anything is allocated
        raise PayloadError(f"transform payload (version {version}): {F} frames x {D} features cannot be held in "
                           f"{len(data)} bytes (damaged data)")
    fexp = np.empty(D, np.int64)
    rexp = np.empty(-(-F // region), np.int64)
    coef = np.empty((F, D), np.int64)
    try:
        _ccoder.decode(data, fexp, rexp, coef, version)
    except ValueError as exc:
        raise _fail(exc, version) from None
    sizes = level_sizes(F, num_levels(F))
    bounds = np.cumsum([0] + sizes)
    return Quantised(F, D, region, fexp, rexp, [coef[a:b] for a, b in zip(bounds[:-1], bounds[1:])])
