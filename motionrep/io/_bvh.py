"""BVH (Biovision hierarchy) reader and writer.

The format, and the conventions motionrep applies where BVH files disagree, are in ``specs/formats/bvh.md``.
In short: rotation channels are intrinsic Euler angles in degrees in the order listed; a position channel
replaces that axis of the joint's OFFSET; CRLF, CR, tabs, scientific notation, namespaced names
(``mixamorig:Hips``) and one-frame files are accepted.  The MOTION block is parsed in bulk and its Euler angles
converted to quaternions by compiled loops (C, ``motionrep._ccore``), and the frame values are written back by one.
Every problem raises :class:`~motionrep.errors.BVHFormatError` naming the file and the line.

Size: one concern, the BVH format; the reader and the writer are kept together because each is the other's
specification (the writer must produce exactly what the reader accepts, channel layout and Euler solution
included), and most of the length is the reader naming the line of every malformed case.
"""

from __future__ import annotations

import io
import os
import re

import numpy as np
from numpy.typing import NDArray

from ..model._pose import CHANNEL_NAMES, Motion, Skeleton
from ..errors import BVHFormatError, ValidationError
from ..limits import check_clip
from ..model.rotations import euler_branch, euler_columns, euler_columns_to_quat, euler_to_quat, quat_to_euler_continuous
from ._atomic import atomic_path
from ._files import read_regular
from ._numbers import _python_float, first_control_byte, scan_block
from ._shortest import format_shortest

__all__ = ["read_bvh", "parse_bvh", "write_bvh", "format_bvh", "channel_values"]

_CHANNEL_LOOKUP = {c.lower(): c for c in CHANNEL_NAMES}
_MOTION_RE = re.compile(rb"^[ \t]*MOTION[ \t]*\r?$", re.MULTILINE)
_INT_RE = re.compile(r"[+-]?[0-9]+\Z")  # ASCII digits only (int() would take '1_0' and other scripts' digits)
_FRAMES_RE = re.compile(r"^\s*Frames\s*:\s*(\S*)\s*(.*)$")
_FRAME_TIME_RE = re.compile(r"^\s*Frame\s+Time\s*:\s*(\S*)\s*(.*)$")


def read_bvh(path: str | os.PathLike[str]) -> Motion:
    """Read a BVH file.

    Args:
        path: the file.

    Returns:
        The :class:`~motionrep.Motion`, with the file's channel layout in its skeleton.

    Raises:
        BVHFormatError: naming the file and line, if the file is missing, unreadable or malformed.
    """
    return parse_bvh(read_regular(path, BVHFormatError), path)


# ---------------------------------------------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------------------------------------------
class _Tokens:
    """Header tokens with their line numbers."""

    def __init__(self, text: str, path, ends_at_motion: bool = True):
        self.path = path
        self.items: list[tuple[str, int]] = []
        self.by_line: dict[int, list[str]] = {}
        for lineno, line in enumerate(text.split("\n"), start=1):
            words = line.split()
            if words:
                self.by_line[lineno] = words
                self.items.extend((w, lineno) for w in words)
        self.pos = 0
        self.ends_at_motion = ends_at_motion
        # where the hierarchy ends: the MOTION line, or the last line with text when the file has no MOTION
        self.last_line = max(1, text.count("\n") + 1) if ends_at_motion else max(self.by_line, default=1)

    def error(self, message: str, line: int | None = None) -> BVHFormatError:
        return BVHFormatError(message, self.path, line)

    def peek(self) -> tuple[str, int] | None:
        return self.items[self.pos] if self.pos < len(self.items) else None

    def next(self, what: str) -> tuple[str, int]:
        if self.pos >= len(self.items):
            raise self.error(f"unexpected end of HIERARCHY, expected {what}", self.last_line)
        item = self.items[self.pos]
        self.pos += 1
        return item

    def rest_of_line(self, line: int) -> list[str]:
        """Tokens after the current position that are on ``line``; consumes them."""
        out = []
        while self.pos < len(self.items) and self.items[self.pos][1] == line:
            out.append(self.items[self.pos][0])
            self.pos += 1
        return out

    def number(self, what: str) -> float:
        tok, line = self.next(what)
        value = _python_float(tok.encode("utf-8"))  # the frame values' rule: ASCII, no '_' (unlike float())
        if value is None:
            raise self.error(f"expected a number for {what}, found {tok!r}", line)
        if not np.isfinite(value):
            raise self.error(f"{what} must be finite, found {tok!r}", line)
        return value


class _Header:
    def __init__(self) -> None:
        self.names: list[str] = []
        self.parents: list[int] = []
        self.offsets: list[tuple[float, float, float]] = []
        self.channels: list[tuple[str, ...]] = []
        self.site_parents: list[int] = []
        self.site_offsets: list[tuple[float, float, float]] = []
        self.name_lines: dict[str, int] = {}


def _parse_offset(tok: _Tokens, owner: str) -> tuple[float, float, float]:
    return (tok.number(f"OFFSET x of {owner}"), tok.number(f"OFFSET y of {owner}"),
            tok.number(f"OFFSET z of {owner}"))


def _parse_joint(tok: _Tokens, hdr: _Header, parent: int, keyword: str, kw_line: int) -> None:
    words = tok.rest_of_line(kw_line)
    brace_on_line = bool(words) and words[-1] == "{"
    if brace_on_line:
        words = words[:-1]
    if not words:
        raise tok.error(f"{keyword} without a name", kw_line)
    name = " ".join(words)
    if "{" in name or "}" in name:
        raise tok.error(f"unexpected brace in {keyword} name {name!r}", kw_line)
    if name in hdr.name_lines:
        raise tok.error(f"duplicate joint name {name!r} (first defined at line {hdr.name_lines[name]})", kw_line)
    hdr.name_lines[name] = kw_line
    index = len(hdr.names)
    hdr.names.append(name)
    hdr.parents.append(parent)
    hdr.offsets.append((0.0, 0.0, 0.0))
    hdr.channels.append(())
    if not brace_on_line:
        t, line = tok.next(f"'{{' after {keyword} {name}")
        if t != "{":
            raise tok.error(f"expected '{{' after {keyword} {name}, found {t!r}", line)
    have_offset = have_channels = False
    while True:
        item = tok.peek()
        if item is None:
            where = "before MOTION" if tok.ends_at_motion else "before the end of the file"
            raise tok.error(f"unbalanced braces: {keyword} {name} (line {kw_line}) is never closed {where}",
                            tok.last_line)
        t, line = tok.next("a joint item")
        if t == "}":
            break
        if t == "OFFSET":
            if have_offset:
                raise tok.error(f"second OFFSET in {name}", line)
            hdr.offsets[index] = _parse_offset(tok, name)
            have_offset = True
        elif t == "CHANNELS":
            if have_channels:
                raise tok.error(f"second CHANNELS line in {name}", line)
            hdr.channels[index] = _parse_channels(tok, name, line)
            have_channels = True
        elif t == "JOINT":
            if not have_offset:
                raise tok.error(f"{name} has no OFFSET before its child joints", line)
            _parse_joint(tok, hdr, index, "JOINT", line)
        elif t == "End":
            rest = tok.rest_of_line(line)
            if not rest or rest[0] != "Site":
                raise tok.error("expected 'End Site'", line)
            if rest[1:] and rest[1:] != ["{"]:
                raise tok.error(f"unexpected {' '.join(rest[1:])!r} after End Site", line)
            if rest[1:] != ["{"]:
                t2, l2 = tok.next("'{' after End Site")
                if t2 != "{":
                    raise tok.error(f"expected '{{' after End Site, found {t2!r}", l2)
            t2, l2 = tok.next("OFFSET in End Site")
            if t2 != "OFFSET":
                raise tok.error(f"expected OFFSET in End Site of {name}, found {t2!r}", l2)
            hdr.site_offsets.append(_parse_offset(tok, f"End Site of {name}"))
            hdr.site_parents.append(index)
            t2, l2 = tok.next("'}' closing End Site")
            if t2 != "}":
                raise tok.error(f"expected '}}' closing End Site of {name}, found {t2!r}", l2)
        elif t in ("ROOT", "HIERARCHY", "MOTION"):
            raise tok.error(f"unexpected {t} inside {keyword} {name} (unbalanced braces?)", line)
        elif t == "{":
            raise tok.error(f"unbalanced braces: unexpected '{{' in {name}", line)
        else:
            raise tok.error(f"unexpected {t!r} in {keyword} {name}; expected OFFSET, CHANNELS, JOINT, "
                            "End Site or '}'", line)
    if not have_offset:
        raise tok.error(f"{keyword} {name} has no OFFSET", kw_line)
    if not have_channels:
        raise tok.error(f"{keyword} {name} has no CHANNELS line", kw_line)


def _parse_channels(tok: _Tokens, owner: str, line: int) -> tuple[str, ...]:
    words = tok.rest_of_line(line)
    if not words:
        raise tok.error(f"CHANNELS of {owner} has no count", line)
    if not _INT_RE.match(words[0]):
        raise tok.error(f"CHANNELS count of {owner} must be an integer, found {words[0]!r}", line)
    count = int(words[0])
    names = words[1:]
    if count != len(names):
        raise tok.error(f"CHANNELS of {owner} says {count} but lists {len(names)} channel names", line)
    out = []
    for n in names:
        canon = _CHANNEL_LOOKUP.get(n.lower())
        if canon is None:
            raise tok.error(f"unknown channel {n!r} in {owner}; expected Xposition, Yposition, Zposition, "
                            "Xrotation, Yrotation or Zrotation", line)
        if canon in out:
            raise tok.error(f"channel {canon} listed twice in {owner}", line)
        out.append(canon)
    return tuple(out)


def _parse_hierarchy(text: str, path, ends_at_motion: bool = True) -> _Header:
    tok = _Tokens(text, path, ends_at_motion)
    first = tok.peek()
    if first is None:
        raise tok.error("no HIERARCHY section", 1)
    t, line = tok.next("HIERARCHY")
    if t != "HIERARCHY":
        raise tok.error(f"expected HIERARCHY at the start of the file, found {t!r}", line)
    hdr = _Header()
    t, line = tok.next("ROOT")
    if t != "ROOT":
        raise tok.error(f"expected ROOT, found {t!r}: the hierarchy must start with a ROOT joint", line)
    try:
        _parse_joint(tok, hdr, -1, "ROOT", line)
    except RecursionError:
        raise tok.error(f"joints nested too deeply ({len(hdr.names)} levels or more)",
                        tok.items[max(tok.pos - 1, 0)][1]) from None
    item = tok.peek()
    if item is not None:
        t, line = item
        if t == "ROOT":
            raise tok.error("more than one ROOT: motionrep reads one skeleton per file", line)
        if t == "}":
            raise tok.error("unbalanced braces: '}' without a matching '{'", line)
        raise tok.error(f"unexpected {t!r} after the ROOT joint's closing brace", line)
    return hdr


def _decode(data: bytes, path) -> bytes:
    """Check the bytes are text; return them without a UTF-8 byte-order mark."""
    if not data or data.isspace():
        raise BVHFormatError("file is empty", path, 1)
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    if not data.isascii():
        try:
            data.decode("utf-8")
        except UnicodeDecodeError as exc:
            line = data.count(b"\n", 0, exc.start) + 1
            raise BVHFormatError(f"not a text file: invalid UTF-8 byte 0x{data[exc.start]:02x}", path,
                                 line) from None
    bad = first_control_byte(data)  # control bytes other than tab, LF, VT, FF, CR
    if bad >= 0:
        line = data.count(b"\n", 0, bad) + 1
        raise BVHFormatError(f"not a text file: control byte 0x{data[bad]:02x}", path, line)
    return data


def parse_bvh(data: bytes | str, path: str | os.PathLike[str] | None = None) -> Motion:
    """Parse BVH text (bytes or str) into a Motion; ``path`` is only used in error messages.

    Raises:
        BVHFormatError: naming ``path`` and the line.
    """
    if isinstance(data, str):
        data = data.encode("utf-8")
    data = _decode(bytes(data), path)
    if b"\r" in data:
        data = data.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    m = _MOTION_RE.search(data)
    if m is None:
        if not data.lstrip().startswith(b"HIERARCHY"):
            first = data.split(None, 1)[0][:40].decode("utf-8", "replace")
            raise BVHFormatError(f"expected HIERARCHY at the start of the file, found {first!r}", path,
                                 data[: len(data) - len(data.lstrip())].count(b"\n") + 1)
        _parse_hierarchy(data.decode("utf-8"), path, ends_at_motion=False)  # names a fault in it, if any
        raise BVHFormatError("no MOTION section (the file ends after the hierarchy)", path,
                             data.rstrip().count(b"\n") + 1)
    header_text = data[: m.start()].decode("utf-8")
    hdr = _parse_hierarchy(header_text, path)
    motion_line = header_text.count("\n") + 1  # line number of "MOTION"
    frames, frame_time, block_start, block_line, frames_line = _parse_motion_header(data, m.end(), motion_line,
                                                                                     path)
    channels = tuple(hdr.channels)
    skeleton = Skeleton(
        names=tuple(hdr.names), parents=np.array(hdr.parents), offsets=np.array(hdr.offsets, dtype=np.float64),
        channels=channels, end_site_parents=np.array(hdr.site_parents, dtype=np.int64),
        end_site_offsets=np.array(hdr.site_offsets, dtype=np.float64).reshape(-1, 3))
    too_big = check_clip(frames, "Frames:", joints=skeleton.num_joints,
                         translated=skeleton.translated_joints.shape[0],
                         angles=sum(len(o) for o in skeleton.rotation_orders))
    if too_big:
        raise BVHFormatError(too_big, path, frames_line)
    values = _parse_block(data, block_start, block_line, frames, skeleton.num_channels, path)
    return _motion_from_channels(skeleton, values, 1.0 / frame_time)


def _parse_motion_header(rest: bytes, start: int, motion_line: int, path) -> tuple[int, float, int, int, int]:
    """Read ``Frames:`` and ``Frame Time:`` after the MOTION line.

    ``rest[start:]`` begins at the end of the MOTION line (the file is not copied).  Returns the two values,
    the offset in ``rest`` where the frame lines begin, the line number of the first of them and that of the
    ``Frames:`` line.
    """
    nl = rest.find(b"\n", start)
    pos = len(rest) if nl == -1 else nl + 1
    line_no = motion_line
    found: dict[str, tuple[str, int]] = {}
    for key, regex in (("Frames", _FRAMES_RE), ("Frame Time", _FRAME_TIME_RE)):
        while True:
            if pos >= len(rest):
                raise BVHFormatError(f"missing '{key}:' line after MOTION", path, line_no)
            nl = rest.find(b"\n", pos)
            end = len(rest) if nl == -1 else nl
            line = rest[pos:end].decode("utf-8")
            pos = end + 1
            line_no += 1
            if line.strip():
                break
        match = regex.match(line)
        if not match:
            raise BVHFormatError(f"expected '{key}: <value>', found {line.strip()[:60]!r}", path, line_no)
        if match.group(2):
            raise BVHFormatError(f"unexpected {match.group(2)[:40]!r} after {key}", path, line_no)
        found[key] = (match.group(1), line_no)
    text, ln = found["Frames"]
    if not _INT_RE.match(text):
        raise BVHFormatError(f"Frames must be a whole number, found {text!r}", path, ln)
    frames = int(text)
    if frames <= 0:
        raise BVHFormatError(f"Frames must be at least 1, found {frames}", path, ln)
    text, ln = found["Frame Time"]
    frame_time = _python_float(text.encode("utf-8"))
    if frame_time is None:
        raise BVHFormatError(f"Frame Time must be a number, found {text!r}", path, ln)
    if not np.isfinite(frame_time) or frame_time <= 0:
        raise BVHFormatError(f"Frame Time must be a finite number > 0, found {text!r}", path, ln)
    if not np.isfinite(1.0 / frame_time):
        raise BVHFormatError(f"Frame Time {text} is too small: its frame rate 1 / {text} is not a finite number",
                             path, ln)
    return frames, frame_time, min(pos, len(rest)), line_no + 1, found["Frames"][1]


def _parse_block(data: bytes, start: int, first_line: int, frames: int, channels: int, path) -> NDArray[np.float64]:
    """Parse the frame lines ``data[start:]`` in bulk; ``(frames, channels)`` values.

    Errors name the offending line.
    """
    u = np.frombuffer(data, np.uint8, offset=start)
    # room for the rows the bytes could hold (a value and a separator are two bytes at least), not for what
    # Frames: declares: a short file declaring a million frames is refused as truncated, not given the memory
    scan = scan_block(u, channels, min(frames, u.shape[0] // (2 * channels) + 1) if channels else frames)
    if channels == 0:
        if scan.rows:
            raise BVHFormatError("the skeleton has no channels but the frame lines hold values", path,
                                 first_line + scan.first_data_line)
        # each frame is an empty line: Frames may not exceed the lines the file has
        lines = int(np.count_nonzero(u == 10)) + (1 if u.shape[0] and u[-1] != 10 else 0)
        if lines < frames:
            raise BVHFormatError(f"truncated motion: Frames: {frames} but only {lines} (empty) frame lines", path,
                                 first_line + lines)
        return np.zeros((frames, 0))
    if scan.rows < frames:  # named: the line where the first missing frame should be
        line = first_line + (scan.last_data_line + 1 if scan.rows else 0)
        raise BVHFormatError(f"truncated motion: Frames: {frames} but only {scan.rows} frame lines", path, line)
    if scan.rows > frames:
        raise BVHFormatError(f"more frame lines than Frames: {frames} (line {first_line + scan.extra_line}"
                             f" is frame {frames + 1})", path, first_line + scan.extra_line)
    if scan.first_wrong_line >= 0:
        raise BVHFormatError(f"frame line has {scan.wrong_count} values, expected {channels} (one per channel)",
                             path, first_line + scan.first_wrong_line)
    if scan.bad is not None:
        raise BVHFormatError(f"expected a number, found {scan.bad[2]!r}", path, first_line + scan.bad[1])
    if scan.nonfinite is not None:
        raise BVHFormatError(f"{scan.nonfinite[2]!r} is not a finite number", path,
                             first_line + scan.nonfinite[1])
    return scan.values.reshape(frames, channels)


def _motion_from_channels(skeleton: Skeleton, values: NDArray, fps: float) -> Motion:
    """Build a Motion from ``(F, C)`` channel values laid out as the skeleton's channels."""
    F = values.shape[0]
    J = skeleton.num_joints
    translated = skeleton.translated_joints
    slot = {0: 0, **{int(j): k + 1 for k, j in enumerate(translated)}}  # joint -> row of `translations`
    translations = np.empty((F, 1 + translated.shape[0], 3))  # the root, then the translated joints
    translations[:] = skeleton.offsets[[0, *translated.tolist()]]
    rotations = np.empty((F, J, 4))
    branch = np.zeros((F, J), bool)
    by_order: dict[str, tuple[list[int], list[list[int]]]] = {}
    rot_joints: list[int] = []
    rot_cols: list[list[int]] = []
    col = 0
    for j, chans in enumerate(skeleton.channels):
        cols = []
        for c in chans:
            if c.endswith("position"):
                translations[:, slot[j], "XYZ".index(c[0])] = values[:, col]
            else:
                cols.append(col)
            col += 1
        if cols:
            joints, grouped = by_order.setdefault(skeleton.rotation_orders[j], ([], []))
            joints.append(j)
            grouped.append(cols)
            rot_joints.append(j)
            rot_cols.append(cols)
        else:
            rotations[:, j] = (0.0, 0.0, 0.0, 1.0)
    if rot_joints:  # every joint's Euler angles to a quaternion, in one compiled pass over the frame block
        positions, axes = euler_columns([skeleton.rotation_orders[j] for j in rot_joints])
        columns = np.array([[cols[k] if k >= 0 else -1 for k in ks] for cols, ks in zip(rot_cols, positions.tolist())],
                           np.int64)  # a joint's rotation channels need not be next to each other
        euler_columns_to_quat(values, columns, axes, np.array(rot_joints, np.int64), rotations, degrees=True)
    for order, (joints, cols) in by_order.items():
        branch[:, joints] = euler_branch(values[:, np.array(cols)], order, degrees=True)
    root = translations[:, 0].copy()  # fresh, C-contiguous arrays: Motion keeps them without copying
    moved = translations[:, 1:].copy()
    angles = np.take(values, _rotation_columns(skeleton), axis=1)  # the file's very angles, for writing them back
    for a in (root, rotations, moved, angles):
        a.flags.writeable = False  # fresh and immutable: Motion keeps them without copying
    return Motion(skeleton, fps, root, rotations, moved, euler_branch=branch, euler_angles=angles)


def _rotation_columns(skeleton: Skeleton) -> NDArray[np.int64]:
    """Columns of the rotation channels in the skeleton's channel layout (the order of ``Motion.euler_angles``)."""
    return np.array([c for c, name in enumerate(n for ch in skeleton.channels for n in ch)
                     if name.endswith("rotation")], dtype=np.int64)


# ---------------------------------------------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------------------------------------------
#: Largest difference, per quaternion component, at which ``Motion.euler_angles`` are taken to describe the rotations
_HINT_TOLERANCE = 1e-9


def _fmt_number(v: float) -> str:
    s = np.format_float_positional(float(v), trim="-")
    return "0" if s == "-0" else s


def _dfs_order(skeleton: Skeleton) -> list[int]:
    order: list[int] = []
    stack = [0]
    while stack:
        j = stack.pop()
        order.append(j)
        stack.extend(reversed(skeleton.children[j]))
    return order


def channel_values(motion: Motion) -> NDArray[np.float64]:
    """``(F, C)`` BVH channel values of ``motion`` in the skeleton's channel layout and joint order.

    Euler angles are in degrees: the source's own angles ``motion.euler_angles`` where the motion has them (and
    they describe its rotations), bit for bit; otherwise of the solution ``motion.euler_branch`` names (when
    set), unwrapped over frames (see :func:`~motionrep.model.rotations.quat_to_euler_continuous`).

    Raises:
        ValidationError: if the motion moves a joint along an axis, or rotates it about an axis, for which
            the channel layout has no channel (the data could not be written without loss).
    """
    sk = motion.skeleton
    F = motion.num_frames
    trans = motion.local_translations()
    scale = max(1.0, float(np.abs(sk.offsets).max(initial=0.0)))
    out = np.empty((F, sk.num_channels))
    by_order: dict[str, list[int]] = {}
    for j, order in enumerate(sk.rotation_orders):
        if order:
            by_order.setdefault(order, []).append(j)
        else:
            q = motion.rotations[:, j]
            if np.any(np.abs(np.abs(q[:, 3]) - 1.0) > 1e-9):
                raise ValidationError(f"joint {sk.names[j]!r} rotates but has no rotation channels")
    eulers: dict[int, NDArray] = {}
    first = np.cumsum([0] + [len(o) for o in sk.rotation_orders])  # each joint's first column in euler_angles
    for order, joints in by_order.items():
        e = close = None
        if motion.euler_angles is not None:  # the source's angles, where they describe the rotations
            e = motion.euler_angles[:, first[joints][:, None] + np.arange(len(order))]  # (F, n, len(order))
            q, qh = motion.rotations[:, joints], euler_to_quat(e, order, degrees=True)
            close = np.minimum(np.abs(qh - q).max(-1), np.abs(qh + q).max(-1)) <= _HINT_TOLERANCE
        if close is None or not close.all():
            branch = None if motion.euler_branch is None else motion.euler_branch[:, joints]
            try:
                computed = quat_to_euler_continuous(motion.rotations[:, joints], order, degrees=True, branch=branch)
            except ValidationError:
                raise ValidationError(f"a joint with rotation channels {order} rotates about another axis too; "
                                      "its rotation cannot be written in its channel layout") from None
            e = computed if close is None else np.where(close[..., None], e, computed)
        for k, j in enumerate(joints):
            eulers[j] = e[:, k]
    col = 0
    for j, chans in enumerate(sk.channels):
        axes = sk.position_axes[j]
        for a in "XYZ":
            if a not in axes and np.any(np.abs(trans[:, j, "XYZ".index(a)] - sk.offsets[j, "XYZ".index(a)])
                                        > 1e-9 * scale):
                raise ValidationError(f"joint {sk.names[j]!r} moves along {a} but has no {a}position channel")
        r = 0
        for c in chans:
            if c.endswith("position"):
                out[:, col] = trans[:, j, "XYZ".index(c[0])]
            else:
                out[:, col] = eulers[j][:, r]
                r += 1
            col += 1
    return out


def format_bvh(motion: Motion, decimals: int | None = None) -> str:
    """The BVH text of ``motion`` (LF line endings, tab indentation).

    Joints are written depth first, children in index order, with the skeleton's names, OFFSETs, channel
    layout and rotation orders; End Sites follow their joint's child joints.  OFFSETs are written in their
    shortest exact decimal form.  Frame values are written losslessly by default: each with the fewest digits
    that read back to the very same double (the source file's own angles when the motion was read from BVH, see
    ``Motion.euler_angles``); ``decimals=N`` writes them with ``N`` digits after the point instead (rounded: an
    error of at most ``0.5 * 10**-N`` degree or file unit).

    Raises:
        ValidationError: if the motion cannot be written in its channel layout without loss.

    BVH lists joints depth first; a skeleton whose joints are in another order (say, breadth first) is written
    depth first, so reading the file back gives the same joints in depth-first order.
    """
    return _bvh_bytes(motion, decimals).decode("utf-8")


def _bvh_bytes(motion: Motion, decimals: int | None) -> bytes:
    """The UTF-8 BVH text of ``motion`` (see :func:`format_bvh`)."""
    if decimals is not None and (isinstance(decimals, bool) or not isinstance(decimals, (int, np.integer))
                                 or not 0 <= decimals <= 17):
        raise ValidationError(f"decimals must be an integer from 0 to 17 (or None: exact), got {decimals!r}")
    sk = motion.skeleton
    values = channel_values(motion)
    order = _dfs_order(sk)
    if order != list(range(sk.num_joints)):  # BVH lists joints depth first: reorder the channel columns
        first = np.concatenate(([0], np.cumsum([len(c) for c in sk.channels])))
        values = values[:, np.concatenate([np.arange(first[j], first[j + 1]) for j in order]).astype(np.int64)]
    sites: dict[int, list[int]] = {}
    for e, p in enumerate(sk.end_site_parents.tolist()):
        sites.setdefault(p, []).append(e)
    lines = ["HIERARCHY"]
    stack = [(True, 0, 0)]  # (opening?, joint, depth): an explicit stack, so deep chains do not recurse
    while stack:
        opening, j, depth = stack.pop()
        ind = "\t" * depth
        if opening:
            lines.append(f"{ind}{'ROOT' if j == 0 else 'JOINT'} {sk.names[j]}")
            lines.append(f"{ind}{{")
            lines.append(f"{ind}\tOFFSET " + " ".join(_fmt_number(v) for v in sk.offsets[j]))
            lines.append(f"{ind}\tCHANNELS {len(sk.channels[j])}" + "".join(" " + c for c in sk.channels[j]))
            stack.append((False, j, depth))
            stack.extend((True, child, depth + 1) for child in reversed(sk.children[j]))
            continue
        for e in sites.get(j, []):
            lines.append(f"{ind}\tEnd Site")
            lines.append(f"{ind}\t{{")
            lines.append(f"{ind}\t\tOFFSET " + " ".join(_fmt_number(v) for v in sk.end_site_offsets[e]))
            lines.append(f"{ind}\t}}")
        lines.append(f"{ind}}}")
    lines.append("MOTION")
    lines.append(f"Frames: {motion.num_frames}")
    lines.append(f"Frame Time: {_frame_time(motion.fps)}")
    header = "\n".join(lines) + "\n"
    if values.shape[1] == 0:
        return (header + "\n" * motion.num_frames).encode("utf-8")
    if decimals is None:
        return header.encode("utf-8") + format_shortest(values)
    scale = 10.0 ** decimals
    # + 0.0 turns -0.0 into 0.0; values too large to have digits at 10**-decimals are kept (rounding them could
    # overflow to inf)
    small = np.abs(values) < 2.0 ** 52 / scale
    if small.all():
        rounded = np.round(values, decimals)
    else:
        rounded = values.copy()
        rounded[small] = np.round(values[small], decimals)
    rounded += 0.0
    fast = _format_fixed(rounded, decimals)
    if fast is not None:
        return header.encode("utf-8") + fast
    buf = io.StringIO()
    np.savetxt(buf, rounded, fmt=f"%.{decimals}f", delimiter=" ")
    return (header + buf.getvalue()).encode("utf-8")


_FORMAT_CHUNK = 8192  # values per chunk in _format_fixed (temporaries stay in cache)


def _frame_time(fps: float) -> str:
    """``1 / fps`` as written after ``Frame Time:``: with 15 significant digits when that reads back to the same
    frame rate (a frame time read from a file with up to 15 digits is written back unchanged), else with the
    fewest digits that do."""
    t = 1.0 / fps
    for digits in (15, 16, 17):
        text = f"{t:.{digits}g}"
        if 1.0 / float(text) == fps:
            return text
    return repr(t)


def _last_digit(x: NDArray[np.float64], q: NDArray[np.float64], d: NDArray[np.float64], row: NDArray[np.uint8]
                ) -> None:
    """The last decimal digit of the whole numbers ``x`` (below 2**52: exact) into ``row`` as ASCII, and
    ``x // 10`` into ``q``; ``d`` is scratch of the same shape."""
    np.divide(x, 10.0, out=q)
    np.floor(q, out=q)
    np.multiply(q, -10.0, out=d)
    d += x
    d += 48.0
    row[...] = d


def _format_fixed(rounded: NDArray[np.float64], decimals: int) -> bytes | None:
    """``rounded`` ``(F, C)`` as lines of ``%.{decimals}f`` values joined by single spaces: the same bytes as
    ``numpy.savetxt``, built with whole-array operations (several times faster).  None when a value is too large
    for exact integer arithmetic in doubles (the caller then uses savetxt).

    ``rounded`` holds values already rounded to ``decimals``, so ``k = rint(|v| * 10**decimals)`` is exactly the
    integer whose digits ``%f`` prints; its digits come from exact divisions by 10 (all below 2**52).  Each
    value is written right-aligned into a fixed-width byte row (sign, integer digits, '.', decimals, then a
    space or the line's newline) and the padding is dropped with one boolean selection.
    """
    F, C = rounded.shape
    scale = 10.0 ** decimals
    flat = rounded.ravel()
    T = flat.shape[0]
    top = float(np.abs(flat).max(initial=0.0))
    if top * scale >= 2.0 ** 52:
        return None
    n_int = 1
    while 10.0 ** n_int <= np.floor(top + 0.5):
        n_int += 1
    dec_part = decimals + 1 if decimals else 0
    width = 1 + n_int + dec_part + 1
    text = np.empty((T, width), np.uint8)
    keep = np.empty((T, width), bool)
    cols = np.arange(width)
    unit = 10.0 ** decimals
    for a in range(0, T, _FORMAT_CHUNK):
        v = flat[a:a + _FORMAT_CHUNK]
        m = v.shape[0]
        k = np.abs(v)
        k *= scale
        np.rint(k, out=k)
        negative = (v < 0) & (k > 0)
        whole = np.floor(k / unit)
        chunk = np.empty((width, m), np.uint8)  # column-major inside the chunk: contiguous rows
        col = width - 1
        chunk[col] = 32
        q = np.empty(m)
        d = np.empty(m)
        x = k - whole * unit  # the decimals, as an integer
        for _ in range(decimals):
            col -= 1
            _last_digit(x, q, d, chunk[col])
            x, q = q, x
        if decimals:
            col -= 1
            chunk[col] = 46
        x = whole
        digits = np.ones(m, np.int64)
        for i in range(n_int):
            col -= 1
            if i:
                digits += x > 0
            _last_digit(x, q, d, chunk[col])
            x, q = q, x
        start = width - (digits + negative + dec_part + 1)  # first byte of each value
        chunk[0] = 32
        neg = np.flatnonzero(negative)
        chunk[start[neg], neg] = 45
        text[a:a + m] = chunk.T
        np.less_equal(start[:, None], cols, out=keep[a:a + m])
    text[C - 1::C, width - 1] = 10  # the last value of a line ends it
    return text[keep].tobytes()


def write_bvh(motion: Motion, path: str | os.PathLike[str], decimals: int | None = None) -> None:
    """Write ``motion`` as BVH to ``path`` atomically (see :func:`format_bvh`)."""
    data = _bvh_bytes(motion, decimals)
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
