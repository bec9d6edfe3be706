"""Limits on what a reader accepts from a file, so a small hostile or damaged file cannot take unbounded memory
or time (``specs/limits.md``).

Every reader (BVH, NPZ, HDF5, ``.mrc`` containers and archives) checks what a file *declares* -- frame counts,
array shapes, metadata sizes -- against these limits **before** it allocates anything for it, and refuses a file
beyond them with its format's error naming the file.  The defaults leave room for long studio captures (a
million frames is more than two hours at 120 fps; CMU clips have up to about 20,000); raise them for bigger
data, or lower them in a service that converts files from strangers.

=========================  ==================================  ===========  ========================================
setting                    environment variable                default      what it bounds
=========================  ==================================  ===========  ========================================
``max_frames``             ``MOTIONREP_MAX_FRAMES``            1,000,000    frames of one clip, in any format
``max_clip_bytes``         ``MOTIONREP_MAX_CLIP_BYTES``        2 GiB        memory of one clip's per-frame arrays as
                                                                            motionrep holds them (float64)
``max_metadata_bytes``     ``MOTIONREP_MAX_METADATA_BYTES``    16 MiB       a ``.mrc`` file's metadata once inflated
``max_mrc_expansion``      ``MOTIONREP_MAX_MRC_EXPANSION``     10,000       memory of a ``.mrc`` file's clip per byte of
                                                                            the file (any file may decode to 64 MiB)
``read_timeout``           ``MOTIONREP_READ_TIMEOUT``          60 s         seconds one HDF5 read may take (0: no
                                                                            watchdog)
``max_stdin_bytes``        ``MOTIONREP_MAX_STDIN_BYTES``       16 GiB       standard input (``-``), copied to a
                                                                            temporary file to be read
``max_decode_work``        ``MOTIONREP_MAX_DECODE_WORK``       100,000      work a ``.mrc`` payload may declare per
                                                                            byte of payload (any payload may
                                                                            declare 2 ** 30 units)
=========================  ==================================  ===========  ========================================

Byte sizes in the environment accept ``K``, ``M``, ``G`` suffixes (powers of 1024).  In Python::

    from motionrep import limits
    with limits.override(max_frames=50_000):
        motion = motionrep.read(untrusted_path)

The environment is read when a limit is first needed, so worker processes started by motionrep inherit it.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import os
import re
import threading
from collections.abc import Iterator
from dataclasses import dataclass

from .errors import ValidationError

__all__ = ["Limits", "DEFAULTS", "ENVIRONMENT", "current", "override", "set_limits", "clip_bytes", "check_clip",
           "check_decode_work", "size_text", "DECODE_FREE_WORK"]


@dataclass(frozen=True)
class Limits:
    """The read limits (see the module documentation for their meaning and defaults).

    Raises:
        ValidationError: if a value is not a positive integer (``read_timeout``: a number >= 0).
    """

    max_frames: int = 1_000_000
    max_clip_bytes: int = 2 << 30
    max_metadata_bytes: int = 16 << 20
    max_mrc_expansion: int = 10_000
    read_timeout: float = 60.0
    max_stdin_bytes: int = 16 << 30
    max_decode_work: int = 100_000

    def __post_init__(self) -> None:
        for name in ("max_frames", "max_clip_bytes", "max_metadata_bytes", "max_mrc_expansion", "max_stdin_bytes",
                     "max_decode_work"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValidationError(f"limit {name} must be a positive integer, got {value!r}")
        t = self.read_timeout
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not math.isfinite(t) or t < 0:
            raise ValidationError(f"limit read_timeout must be a number of seconds >= 0, got {t!r}")
        object.__setattr__(self, "read_timeout", float(t))


#: The built-in defaults.
DEFAULTS = Limits()
#: Environment variable of each setting.
ENVIRONMENT = {"max_frames": "MOTIONREP_MAX_FRAMES", "max_clip_bytes": "MOTIONREP_MAX_CLIP_BYTES",
               "max_metadata_bytes": "MOTIONREP_MAX_METADATA_BYTES",
               "max_mrc_expansion": "MOTIONREP_MAX_MRC_EXPANSION", "read_timeout": "MOTIONREP_READ_TIMEOUT",
               "max_stdin_bytes": "MOTIONREP_MAX_STDIN_BYTES", "max_decode_work": "MOTIONREP_MAX_DECODE_WORK"}
#: Clip memory any ``.mrc`` file may decode to, whatever its size (``max_mrc_expansion`` applies beyond it).
MRC_FREE_BYTES = 64 << 20
#: Decode work any payload may declare, whatever its size (``max_decode_work`` per payload byte applies beyond
#: it): about a second of decoding.  A unit is one multiply-add of a network evaluated at one frame.
DECODE_FREE_WORK = 1 << 30

_SIZE = re.compile(r"\s*([0-9]+)\s*([kmgt]?)i?b?\s*\Z", re.IGNORECASE)
_lock = threading.Lock()
_override: Limits | None = None
_local = threading.local()


def _parse(name: str, text: str) -> int | float:
    variable = ENVIRONMENT[name]
    if name == "read_timeout":
        try:
            value = float(text)
        except ValueError:
            raise ValidationError(f"{variable}={text!r}: expected a number of seconds") from None
        return value
    match = _SIZE.match(text)
    if not match:
        raise ValidationError(f"{variable}={text!r}: expected a whole number"
                              + (" (K, M, G suffixes allowed)" if name.endswith("bytes") else ""))
    return int(match.group(1)) << (10 * "kmgt".find(match.group(2).lower()) + 10 if match.group(2) else 0)


def _from_environment() -> Limits:
    values = {}
    for name, variable in ENVIRONMENT.items():
        text = os.environ.get(variable)
        if text is not None and text.strip():
            values[name] = _parse(name, text)
    try:
        return Limits(**values)
    except ValidationError as exc:
        raise ValidationError(f"{exc} (from the environment: "
                              + ", ".join(f"{ENVIRONMENT[k]}={os.environ[ENVIRONMENT[k]]}" for k in values) + ")"
                              ) from None


def current() -> Limits:
    """The limits in force: an :func:`override` in this thread, else :func:`set_limits`, else the environment."""
    stack = getattr(_local, "stack", None)
    if stack:
        return stack[-1]
    if _override is not None:
        return _override
    return _from_environment()


def set_limits(**changes: int | float) -> Limits:
    """Set limits for the whole process (on top of the environment); returns the new limits.

    ``set_limits()`` with no argument goes back to the environment and defaults.
    """
    global _override
    with _lock:
        _override = None
        if changes:
            _override = dataclasses.replace(_from_environment(), **changes)
        return current()


@contextlib.contextmanager
def override(**changes: int | float) -> Iterator[Limits]:
    """Change some limits inside a ``with`` block (this thread only)."""
    new = dataclasses.replace(current(), **changes)
    stack = getattr(_local, "stack", None)
    if stack is None:
        stack = _local.stack = []
    stack.append(new)
    try:
        yield new
    finally:
        stack.pop()


def clip_bytes(frames: int, joints: int = 0, translated: int = 0, angles: int = 0, features: int = 0) -> int:
    """Bytes motionrep holds for a clip's per-frame arrays: ``frames`` x (``joints`` quaternions + root
    translation + ``translated`` joint translations + ``angles`` Euler angles + ``features`` columns) float64,
    plus one Euler-branch byte per joint and frame.  Python integers: never overflows."""
    per_frame = 8 * (4 * joints + 3 + 3 * translated + angles + features) + joints
    return int(frames) * per_frame


def check_clip(frames: int, what: str, *, joints: int = 0, translated: int = 0, angles: int = 0,
               features: int = 0, mrc_bytes: int | None = None) -> str | None:
    """The reason a clip of this size is refused under the current limits, or None if it is accepted.

    ``what`` names the thing declaring the size in the message (``"Frames:"``, ``"num_frames"``...);
    ``mrc_bytes`` is the size of the ``.mrc`` container declaring it (``max_mrc_expansion`` then applies).
    """
    lim = current()
    if frames > lim.max_frames:
        return (f"{what} declares {frames} frames, more than the limit of {lim.max_frames} "
                f"(raise {ENVIRONMENT['max_frames']} to read it)")
    size = clip_bytes(frames, joints, translated, angles, features)
    if size > lim.max_clip_bytes:
        return (f"{what}: a clip of {frames} frames needs {size_text(size)} in memory, more than the limit of "
                f"{size_text(lim.max_clip_bytes)} (raise {ENVIRONMENT['max_clip_bytes']} to read it)")
    if mrc_bytes is not None and size > max(MRC_FREE_BYTES, lim.max_mrc_expansion * mrc_bytes):
        return (f"{what}: a clip of {frames} frames needs {size_text(size)} in memory, more than "
                f"{lim.max_mrc_expansion} times the {mrc_bytes}-byte container (raise "
                f"{ENVIRONMENT['max_mrc_expansion']} to read it)")
    return None


def check_decode_work(work: int, payload_bytes: int, what: str) -> str | None:
    """The reason a payload of ``payload_bytes`` bytes declaring ``work`` units of decode work (``what`` names
    it: ``"450 frames x 3 windows"``) is refused under the current limits, or None if it is accepted: the work
    may be at most ``max(DECODE_FREE_WORK, max_decode_work x payload_bytes)``.  Python integers: never
    overflows."""
    lim = current()
    allowed = max(DECODE_FREE_WORK, lim.max_decode_work * int(payload_bytes))
    if int(work) > allowed:
        return (f"{what} declares {int(work):.3g} units of decode work, more than the limit of {allowed:.3g} for a "
                f"{int(payload_bytes)}-byte payload ({lim.max_decode_work} per byte; raise "
                f"{ENVIRONMENT['max_decode_work']} to decode it)")
    return None


def size_text(n: int) -> str:
    """``n`` bytes for a message: ``1.5 GiB``, ``12.0 MiB``, ``300 bytes``."""
    for unit, shift in (("GiB", 30), ("MiB", 20), ("KiB", 10)):
        if n >= 1 << shift:
            return f"{n / (1 << shift):.1f} {unit}"
    return f"{n} bytes"
