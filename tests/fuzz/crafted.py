"""Hostile and damaged files, crafted the way an attacker (or an unlucky disk) would make them.

Each :class:`Case` is one file (or a small set of files) built in a directory, the command a user would run on it,
and what motionrep must answer: one line naming the file, exit code 1, no output file, no bytes of anything
outside the file in the output, memory and time bounded by the documented limits (``specs/limits.md``).

Used by ``tests/test_hostile.py`` (library and command line, in the default test run) and by
``tests/fuzz/run.py`` (the before/after table and the mutant counts, outside it).  Building the cases is quick
(under a second); only :func:`zip_bomb` writes a large compressed stream, and only when asked.
"""

from __future__ import annotations

import io
import json
import os
import struct
import zipfile
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import h5py
import numpy as np

from motionrep import Motion
from motionrep.io.container import MAGIC
from motionrep.io import write
from motionrep.model.synthetic import chain_skeleton, humanoid_skeleton, synthetic_motion

SECRET = b"TOP-SECRET-0123456789abcdef-do-not-leak\n" * 8  # 320 bytes; in no file motionrep may read


@dataclass
class Case:
    """One crafted input.

    Attributes:
        name: short identifier.
        issue: what the issue (14) reported for it before the fix.
        path: the file given to motionrep.
        command: the ``motionrep`` arguments (``{out}`` is the output path).
        message: a fragment the one-line error must contain.
        kind: ``"refuse"`` (exit 1, error naming the file) or ``"accept"`` (exit 0; output checked by ``check``).
        check: for ``accept`` cases, a function of the output path that returns None when it is right.
    """

    name: str
    issue: str
    path: Path
    command: list[str]
    message: str
    kind: str = "refuse"
    check: Callable[[Path], str | None] | None = None
    out_suffix: str = ".npz"
    extra: dict = field(default_factory=dict)


# ---------------------------------------------------------------------------------------------------------------
# building blocks
# ---------------------------------------------------------------------------------------------------------------
def small_motion(frames: int = 20) -> Motion:
    return synthetic_motion(humanoid_skeleton(), frames=frames, seed=3)


def write_v1_hdf5(motion: Motion, path: Path, clip: str = "base") -> None:
    """An HDF5 file laid out as motionrep 0.1 wrote them (format version 1: variable-length strings, no checksums,
    the earliest HDF5 object formats), to check that old files stay readable and to reproduce damage found in
    them."""
    from motionrep.io._stored import motion_fields, skeleton_fields

    scalars, arrays = motion_fields(motion)
    arrays.pop("euler_angles", None)
    sk_scalars, sk_arrays = skeleton_fields(motion.skeleton)
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "motionrep-hdf5"
        f.attrs["format_version"] = np.int64(1)
        f.attrs["quat_order"] = "xyzw"
        group = f.create_group("clips", track_order=True).create_group(clip)
        for key, value in {**scalars, **sk_scalars}.items():
            group.attrs[key] = value if isinstance(value, str) else np.float64(value) if isinstance(value, float) \
                else np.int64(value)
        skeleton = group.create_group("skeleton")
        for key, value in sk_arrays.items():
            if isinstance(value, list):
                skeleton.create_dataset(key, data=np.array(value, dtype=h5py.string_dtype("utf-8")).reshape(-1))
            else:
                skeleton.create_dataset(key, data=np.asarray(value))
        for key, value in arrays.items():
            a = np.asarray(value)
            a = a.astype(np.uint8) if a.dtype == np.bool_ else a
            if a.size == 0:
                group.create_dataset(key, data=a)
            else:
                group.create_dataset(key, data=a, chunks=(min(a.shape[0], max(1, (1 << 18) // max(1, a[0].nbytes))),)
                                     + a.shape[1:], compression="gzip", compression_opts=4, shuffle=True)


def write_v1_npz(motion: Motion, path: Path) -> None:
    """An NPZ file as motionrep 0.1 wrote them (format version 1: no ``euler_angles``)."""
    buf = io.BytesIO()
    write(motion.replace(euler_angles=None), path)
    np.save(buf, np.array(1, dtype=np.int64))
    with zipfile.ZipFile(path) as src:
        members = {i.filename: src.read(i) for i in src.infolist()}
    members["format_version.npy"] = buf.getvalue()
    with zipfile.ZipFile(path, "w") as out:
        for name, data in members.items():
            out.writestr(name, data)


def mrc_parts(motion: Motion | None = None, codec: str = "svd",
              params: dict[str, str] | None = None, version: int = 2) -> tuple[dict, bytes]:
    """``(metadata, payload)`` of a real, small ``.mrc`` container: ``svd`` (rank 2), or any other codec (e.g.
    ``transform``, the default codec of ``motionrep compress``, or ``adaptive-fourier``) with ``params`` at its
    default bound; ``version=1``: the metadata as container version 1 had it (the bound as ``extra.max_error``
    text, no setting digest), which :func:`pack_meta` packs as a version-1 file."""
    from motionrep.pipeline.compress import compress_motion

    if codec == "svd" and not params:
        motion = motion or synthetic_motion(chain_skeleton(3), frames=12, seed=2)
        data = compress_motion(motion, "svd", params={"rank": 2}, max_error=None).data
    else:
        motion = motion or synthetic_motion(chain_skeleton(3), frames=40, seed=2)
        data = compress_motion(motion, codec, params=params).data
    meta_len = struct.unpack_from("<I", data, 16)[0]
    meta = json.loads(zlib.decompress(data[20:20 + meta_len]))
    if version == 1:
        from motionrep.model.bound import MaxError

        bound = meta.pop("bound")
        meta["extra"].pop("setting_sha256")
        meta["extra"]["max_error"] = None if bound["kind"] == "none" else \
            str(MaxError(bound["value"], bound["kind"] == "percent"))
    return meta, data[20 + meta_len:-4]


def mrc_version(meta: dict | str) -> int:
    """The container version whose metadata ``meta`` is (2 when it has the structured ``bound``)."""
    return 2 if ('"bound":' in meta if isinstance(meta, str) else "bound" in meta) else 1


def npz_parts(path: Path) -> tuple[dict[str, bytes], dict[str, np.ndarray]]:
    """The members' bytes and the arrays of the NPZ file ``path`` (the material of NPZ mutants)."""
    with zipfile.ZipFile(path) as z:
        members = {i.filename: z.read(i) for i in z.infolist()}
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    return members, arrays


def pack_raw(metadata: bytes, payload: bytes, version: int = 1) -> bytes:
    """``.mrc`` bytes around already-compressed metadata, with a valid length and CRC-32 (what an attacker does)."""
    total = 20 + len(metadata) + len(payload) + 4
    body = struct.pack("<8sHHII", MAGIC, version, 0, total, len(metadata)) + metadata + payload
    return body + struct.pack("<I", zlib.crc32(body))


def pack_meta(meta: dict | str, payload: bytes) -> bytes:
    """``.mrc`` bytes of this metadata, of the container version it is (:func:`mrc_version`)."""
    text = meta if isinstance(meta, str) else json.dumps(meta, sort_keys=True, separators=(",", ":"))
    return pack_raw(zlib.compress(text.encode("utf-8"), 9), payload, mrc_version(meta))


def npy_bytes(header: str, data: bytes = b"", version: tuple[int, int] = (1, 0)) -> bytes:
    """A ``.npy`` member with this exact header text (padded as numpy pads it)."""
    text = header.encode("latin1")
    pad = (64 - (10 + len(text) + 1) % 64) % 64
    text += b" " * pad + b"\n"
    return b"\x93NUMPY" + bytes(version) + struct.pack("<H", len(text)) + text + data


def npz_with(path: Path, base: Path, replace: dict[str, bytes], deflate: bool = False) -> None:
    """A copy of the archive ``base`` with some members' bytes replaced (``name.npy`` keys)."""
    with zipfile.ZipFile(base) as src, zipfile.ZipFile(path, "w") as out:
        for info in src.infolist():
            data = replace.pop(info.filename, None)
            out.writestr(info.filename, src.read(info) if data is None else data,
                         zipfile.ZIP_DEFLATED if deflate else zipfile.ZIP_STORED)
        for name, data in replace.items():
            out.writestr(name, data, zipfile.ZIP_DEFLATED if deflate else zipfile.ZIP_STORED)


def zip_bomb(path: Path, base: Path, gigabytes: float = 2.5) -> None:
    """An NPZ whose ``rotations.npy`` inflates to ``gigabytes`` GB of zeros from a few MB (built by repeating one
    compressed block, so it takes seconds)."""
    J = 31
    frames = int(gigabytes * 1e9) // (J * 4 * 8)
    header = npy_bytes("{'descr': '<f8', 'fortran_order': False, 'shape': (%d, %d, 4), }" % (frames, J))
    size = len(header) + frames * J * 32
    block = 1 << 20
    comp = zlib.compressobj(9, zlib.DEFLATED, -15)
    stream = [comp.compress(header)]
    zero_block = comp.compress(bytes(block)) + comp.flush(zlib.Z_FULL_FLUSH)
    left = size - len(header)
    crc = zlib.crc32(header)
    zeros = bytes(block)
    while left >= block:
        stream.append(zero_block)
        crc = zlib.crc32(zeros, crc)
        left -= block
    stream.append(comp.compress(bytes(left)) + comp.flush())
    crc = zlib.crc32(bytes(left), crc)
    with zipfile.ZipFile(base) as src:
        members = [(i.filename, src.read(i)) for i in src.infolist() if i.filename != "rotations.npy"]
    with zipfile.ZipFile(path, "w", allowZip64=True) as out:
        for name, data in members:
            out.writestr(name, data)
        info = zipfile.ZipInfo("rotations.npy")
        info.compress_type = zipfile.ZIP_DEFLATED
        info.CRC, info.file_size = crc, size
        compressed = b"".join(stream)
        info.compress_size = len(compressed)
        with out._lock:  # write a pre-compressed member: local header, data, then the directory entry
            info.header_offset = out.fp.tell()
            out._writecheck(info)
            out._didModify = True
            out.fp.write(info.FileHeader(zip64=True))
            out.fp.write(compressed)
            out.filelist.append(info)
            out.NameToInfo[info.filename] = info
            out.start_dir = out.fp.tell()


# ---------------------------------------------------------------------------------------------------------------
# the cases
# ---------------------------------------------------------------------------------------------------------------
BVH_ZERO_CHANNELS = ("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 0\nJOINT b\n{\nOFFSET 0 1 0\nCHANNELS 0\n"
                     "End Site\n{\nOFFSET 0 1 0\n}\n}\n}\nMOTION\nFrames: 1000000000\nFrame Time: 0.01\n")
BVH_ONE = ("HIERARCHY\nROOT Hips\n{\n\tOFFSET 0 0 0\n\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation "
           "Yrotation\n\tEnd Site\n\t{\n\t\tOFFSET 0 1 0\n\t}\n}\nMOTION\nFrames: 2\nFrame Time: {ft}\n"
           "{a} 0 0 -192.5 5.1072e-06 181\n0 0 0 1e-300 -0 359.9\n")


def build(directory: Path, bomb: bool = False) -> list[Case]:
    """Write every crafted case into ``directory``; return them."""
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    cases: list[Case] = []
    motion = small_motion()
    # the cases are built from files of the oldest format versions, which every motionrep reads (so that the same
    # files can be given to an older checkout: tests/fuzz/run.py --crafted --pythonpath)
    good_h5 = d / "good.h5"
    write_v1_hdf5(motion, good_h5, clip="good")
    good_npz = d / "good.npz"
    write_v1_npz(motion, good_npz)
    secret = d / "secret.txt"
    secret.write_bytes(SECRET)
    F, J = motion.num_frames, motion.num_joints

    def h5_edit(name: str, edit) -> Path:
        path = d / f"{name}.h5"
        path.write_bytes(good_h5.read_bytes())
        with h5py.File(path, "r+") as f:
            edit(f, f["clips/good"])
        return path

    def convert(name: str, path: Path, message: str, issue: str) -> None:
        cases.append(Case(name, issue, path, ["convert", str(path), "{out}"], message))

    # ---- HDF5: reaching outside the file ---------------------------------------------------------------------
    def external_storage(f, g):
        del g["root_translation"]
        g.create_dataset("root_translation", shape=(F, 3), dtype="<f8", external=[(str(secret), 0, F * 24)])

    convert("h5-external-storage", h5_edit("h5-external-storage", external_storage), "external file",
            "the secret file's bytes came out in out.npz (exit 0)")
    other = d / "other.h5"
    with h5py.File(other, "w") as f:
        f["data"] = np.zeros((F, J, 4))
        f["data"][:, :, 3] = 1.0

    def external_link(f, g):
        del g["rotations"]
        g["rotations"] = h5py.ExternalLink(str(other), "/data")

    convert("h5-external-link", h5_edit("h5-external-link", external_link), "external link",
            "h5py followed the link into another file")

    def soft_loop(f, g):
        f["clips/loop"] = h5py.SoftLink("/clips/loop")

    convert("h5-soft-link-loop", h5_edit("h5-soft-link-loop", soft_loop), "soft link", "traceback (KeyError)")

    def soft_dataset(f, g):
        f["stolen"] = g["rotations"][()]
        del g["rotations"]
        g["rotations"] = h5py.SoftLink("/stolen")

    convert("h5-soft-link-dataset", h5_edit("h5-soft-link-dataset", soft_dataset), "soft link",
            "the link was followed")

    def virtual(f, g):
        layout = h5py.VirtualLayout(shape=(F, J, 4), dtype="<f8")
        layout[:] = h5py.VirtualSource(str(other), "data", shape=(F, J, 4))
        del g["rotations"]
        g.create_virtual_dataset("rotations", layout)

    convert("h5-virtual-dataset", h5_edit("h5-virtual-dataset", virtual), "virtual dataset",
            "data assembled from another file")

    # ---- HDF5: bombs and damage ------------------------------------------------------------------------------
    def huge_shape(f, g):
        del g["rotations"]
        g.create_dataset("rotations", shape=(10 ** 9, J, 4), dtype="<f8", chunks=(1024, J, 4))

    convert("h5-declared-1e9-frames", h5_edit("h5-declared-1e9-frames", huge_shape), "frames",
            "asked for 566 GiB (MemoryError traceback)")

    def bad_filter(f, g):
        data = g["rotations"][()]
        del g["rotations"]
        dcpl = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
        dcpl.set_chunk((F, J, 4))
        dcpl.set_filter(307, h5py.h5z.FLAG_OPTIONAL, ())  # bzip2: HDF5 would look for a plugin to load
        space = h5py.h5s.create_simple((F, J, 4))
        h5py.h5d.create(g.id, b"rotations", h5py.h5t.IEEE_F64LE, space, dcpl=dcpl).write(
            h5py.h5s.ALL, h5py.h5s.ALL, np.ascontiguousarray(data))

    convert("h5-unknown-filter", h5_edit("h5-unknown-filter", bad_filter), "filter 307",
            "HDF5 would load a filter plugin found through the environment")
    # found by fuzzing: a version 1 file (motionrep 0.1's writer, a 20-frame walk) with 7 bytes overwritten at
    # offset 2123, the size field of a global-heap string (the clip's 'kind'): the HDF5 library (2.0) spins on it
    # with the interpreter held; motionrep before the watchdog never returned (killed after 800 s)
    spin = d / "h5-damaged-spin.h5"
    spin.write_bytes((Path(__file__).with_name("data") / "global-heap-spin.h5").read_bytes())
    cases.append(Case("h5-damaged-spin", "the HDF5 library spins reading a damaged attribute (hang)", spin,
                      ["convert", str(spin), "{out}"], "HDF5"))
    good_v2 = d / "good-v2.h5"  # the checksums are format version 2's
    write(motion, good_v2, clip="good")
    flipped = bytearray(good_v2.read_bytes())
    with h5py.File(good_v2, "r") as f:
        at = f["clips/good/rotations"].id.get_offset()
        if at is None:  # chunked: the first chunk's address
            at = f["clips/good/rotations"].id.get_chunk_info(0).byte_offset
    flipped[at + 40] ^= 0x55
    (d / "h5-flipped-data.h5").write_bytes(bytes(flipped))
    convert("h5-flipped-data-byte", d / "h5-flipped-data.h5", "rotations",
            "HDF5 stored no checksum: damage could change the motion silently")

    # ---- NPZ ---------------------------------------------------------------------------------------------------
    path = d / "npz-huge-header.npz"
    npz_with(path, good_npz, {"rotations.npy": npy_bytes(
        "{'descr': '<f8', 'fortran_order': False, 'shape': (%d, 19, 4), }" % 2 ** 33, b"\0" * 64)})
    convert("npz-header-2^33-frames", path, "frames", "asked for 4.75 TiB")
    path = d / "npz-token-error.npz"
    npz_with(path, good_npz, {"fps.npy": npy_bytes("{'descr': '<f8', 'fortran_order': False, 'shape': (\"", b"")})
    convert("npz-damaged-npy-header", path, "fps", "traceback (tokenize.TokenError)")
    path = d / "npz-object-array.npz"
    npz_with(path, good_npz, {"skeleton_names.npy": npy_bytes(
        "{'descr': '|O', 'fortran_order': False, 'shape': (1,), }", b"\x80\x04N.")})
    convert("npz-pickled-member", path, "objects", "refused (pickles never loaded)")
    path = d / "npz-short-member.npz"
    npz_with(path, good_npz, {"rotations.npy": npy_bytes(
        "{'descr': '<f8', 'fortran_order': False, 'shape': (%d, %d, 4), }" % (F, J), b"\0" * 80)})
    convert("npz-short-member", path, "rotations", "traceback or garbage")
    if bomb:
        path = d / "npz-zip-bomb.npz"
        zip_bomb(path, good_npz)
        convert("npz-zip-bomb-2.5GB", path, "rotations", "refused only after inflating 2.5 GB")

    # ---- .mrc --------------------------------------------------------------------------------------------------
    meta, payload = mrc_parts()

    def mrc(name: str, data: bytes, message: str, issue: str, command: str = "decompress") -> None:
        path = d / f"{name}.mrc"
        path.write_bytes(data)
        cmd = ["decompress", str(path), "-o", "{out}"] if command == "decompress" else ["info", str(path)]
        cases.append(Case(name, issue, path, cmd, message))

    def edited(**changes) -> dict:
        m = json.loads(json.dumps(meta))
        for key, value in changes.items():
            target = m
            parts = key.split("__")
            for p in parts[:-1]:
                target = target[p]
            target[parts[-1]] = value
        return m

    mrc("mrc-num-frames-1e6", pack_meta(edited(num_frames=10 ** 6), payload), "num_frames",
        "8 KB file decoded into a 632 MB npz (2.3 GB RSS)")
    mrc("mrc-num-frames-1e7", pack_meta(edited(num_frames=10 ** 7), payload), "num_frames", "about 15 GB")
    mrc("mrc-metadata-inflation", pack_raw(zlib.compress(b" " * (400 << 20), 9), payload), "inflates",
        "400 MB of whitespace inflated from 416 KB")
    deep = json.dumps(meta)[:-1] + ',"deep":' + "[" * 100000 + "]" * 100000 + "}"
    mrc("mrc-deep-json", pack_meta(deep, payload), "nested", "traceback (RecursionError)")
    table = edited()
    table["arrays"][0]["shape"] = [10 ** 30, 3]
    mrc("mrc-shape-1e30", pack_meta(table, payload), "shape", "traceback (OverflowError)")
    mrc("mrc-evaluation-list", pack_meta(edited(evaluation=[1, 2]), payload), "evaluation",
        "traceback (TypeError) in motionrep info", command="info")
    # a Fourier codec's outcome, refused by that codec's check (Codec.check_info) before its payload is looked at
    mrc("mrc-omega-text", pack_meta(edited(codec__name="adaptive-fourier", codec__version=3,
                                           codec__info={"K": 2, "omega": ["x", "y"]}), payload), "omega",
        "traceback (ValueError) in motionrep info", command="info")
    mrc("mrc-frames-text", pack_meta(edited(num_frames="12"), payload), "num_frames", "traceback or garbage")
    mrc("mrc-skeleton-types", pack_meta(edited(skeleton__names=[1, 2, 3]), payload), "skeleton", "traceback")
    mrc("mrc-unknown-codec", pack_meta(edited(codec__name="nope", codec__plugin="motionrep-nope"), payload), "nope",
        "'unknown codec' without the file")
    mrc("mrc-wrong-representation", pack_meta(edited(representation__version=99), payload), "representation",
        "the wrong representation version without the file")
    # the transform codec (the default): its outcome and its own payload header
    meta, payload = mrc_parts(codec="transform")
    mrc("mrc-transform-num-frames-1e6", pack_meta(edited(num_frames=10 ** 6), payload), "num_frames",
        "the frame count claim, with the default codec")
    mrc("mrc-transform-step-text", pack_meta(edited(codec__info={**meta["codec"]["info"], "step": ["x", None]}),
                                             payload), "", "traceback (ValueError) in motionrep info: the outcome "
        "is described generically", command="info")
    cases[-1].kind = "accept"
    from motionrep.plugin.coding import IntegerEncoder

    # a payload header claiming 2^32 frames x 2^20 features, the rest zeros: version 2 (LEB128 counts, what the
    # codec writes) and version 1 (raw bits of the range coder, what files of 0.1.0 hold)
    claim = bytes([0xFF, 0xFF, 0xFF, 0xFF, 0x0F, 0xFF, 0xFF, 0x3F, 15]) + bytes(len(payload))
    table = edited()
    table["arrays"][0]["shape"] = [len(claim)]
    mrc("mrc-transform-payload-4e9-frames", pack_meta(table, claim), "transform payload declares 4294967296 frames",
        "payload error without the file")
    enc = IntegerEncoder()
    enc.encode_raw([2 ** 32 - 1], 32)
    enc.encode_raw([2 ** 20 - 1], 20)
    enc.encode_raw([15], 16)
    claim = enc.to_bytes() + bytes(len(payload))
    table = edited(codec__version=1)
    table["arrays"][0]["shape"] = [len(claim)]
    mrc("mrc-transform-v1-payload-4e9-frames", pack_meta(table, claim),
        "transform payload declares 4294967296 frames", "payload error without the file")

    # ---- BVH ---------------------------------------------------------------------------------------------------
    path = d / "bvh-zero-channels-1e9.bvh"
    path.write_text(BVH_ZERO_CHANNELS)
    convert("bvh-frames-1e9-no-channels", path, "Frames", "135-byte file asked for 22 GiB")
    path = d / "bvh-frame-time-1e-320.bvh"
    path.write_text(BVH_ONE.replace("{ft}", "1e-320").replace("{a}", "0"))
    convert("bvh-frame-time-1e-320", path, "Frame Time", "'fps must be finite' without the file or line")
    path = d / "bvh-dev-zero.bvh"
    if not path.exists():
        try:
            path.symlink_to("/dev/zero")
        except OSError:  # pragma: no cover - no symlinks here
            path = None
    if path is not None:
        convert("bvh-symlink-to-dev-zero", path, "character device", "read until memory ran out")
    path = d / "bvh-fifo.bvh"
    if hasattr(os, "mkfifo"):
        if not path.exists():
            os.mkfifo(path)
        convert("bvh-fifo", path, "FIFO", "blocked forever")
        for suffix in (".npz", ".h5", ".mrc"):
            fifo = d / f"fifo{suffix}"
            if not fifo.exists():
                os.mkfifo(fifo)
            if suffix == ".mrc":
                cases.append(Case(f"fifo{suffix}", "blocked forever", fifo, ["decompress", str(fifo), "-o", "{out}"],
                                  "FIFO"))
            else:
                convert(f"fifo{suffix}", fifo, "FIFO", "blocked forever")

    # ---- lossless BVH ------------------------------------------------------------------------------------------
    path = d / "bvh-exact.bvh"
    path.write_text(BVH_ONE.replace("{ft}", "0.0083333").replace("{a}", "1.8e302"))

    def same_values(out: Path) -> str | None:
        src = _values(path.read_bytes())
        got = _values(out.read_bytes())
        if got.shape != src.shape or not np.array_equal(got.view(np.uint64), src.view(np.uint64)):
            return f"channel values differ: {got.tolist()} != {src.tolist()}"
        return None

    cases.append(Case("bvh-exact-values", "angles unwrapped (-192.5 -> 167.5 + 360k), 5.1072e-06 -> 0.000005, "
                      "1.8e302 -> inf", path, ["convert", str(path), "{out}"], "", kind="accept",
                      check=same_values, out_suffix=".bvh"))
    return cases


def _values(data: bytes) -> np.ndarray:
    data = data.replace(b"\r\n", b"\n")
    start = data.index(b"\n", data.index(b"Frame Time")) + 1
    return np.array([float(t) for t in data[start:].split()])


def check_leak(outputs: list[Path]) -> bool:
    """True if any output holds bytes of :data:`SECRET`."""
    marker = SECRET[:16]
    for p in outputs:
        if p.is_file() and marker in p.read_bytes():
            return True
    return False


__all__ = ["Case", "build", "SECRET", "check_leak", "write_v1_hdf5", "write_v1_npz", "mrc_parts", "mrc_version", "npz_parts", "pack_meta", "pack_raw",
           "npy_bytes", "npz_with", "zip_bomb", "small_motion"]
