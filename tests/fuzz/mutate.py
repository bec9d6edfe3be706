"""Mutants of valid motion files, for the fuzz tests (``tests/test_format_fuzz.py``, hypothesis picks the seeds)
and the fuzz benchmark (``tests/fuzz/run.py``, 100,000 seeds per format).

Every function takes a ``random.Random`` and returns the mutant's bytes (HDF5 structural mutants are written with
h5py to a given path).  The mutations are those of a damaged disk or transfer (bytes overwritten, inserted,
removed, truncated) and those of an attacker who keeps checksums valid (edited ``.mrc`` metadata with a fresh
CRC-32, replaced ``.npy`` members and headers, HDF5 objects replaced by links, external storage, odd types).
"""

from __future__ import annotations

import io
import json
import random
import struct
import zipfile
import zlib
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from .crafted import SECRET, mrc_version, npy_bytes, pack_meta, pack_raw

__all__ = ["mutate_bytes", "mrc_mutant", "npz_mutant", "h5_mutant", "bvh_mutant", "glb_mutant",
           "gltf_json_mutant", "split_glb", "join_glb", "json_value", "SECRET_VALUE"]

#: A value that only a file outside the one being read holds (a leak if it shows up in what was read).
SECRET_VALUE = 1234567.890625

_INTS = [0, 1, -1, 2, 3, 7, 255, 256, 65535, 2 ** 31 - 1, 2 ** 31, 2 ** 32, 2 ** 53 + 1, 2 ** 63, 10 ** 30,
         -(10 ** 30), 10 ** 6, 10 ** 7, 10 ** 9]
_FLOATS = [0.0, -0.0, 0.5, -1.5, 1e-320, 5e-324, 1e308, -1e308, 1.8e302, 30.0, 1e-9, float("nan"), float("inf")]
_STRINGS = ["", "x", "svd", "adaptive-fourier", "root-quat-axis-angle", "xyzw", "motion", "features",
            "Xrotation Yrotation Zrotation", "Xposition Spin", "a" * 5000, "\u00e9\u4e2d\U0001f600", "\x00", "NaN"]


def json_value(rng: random.Random, depth: int = 0) -> Any:
    """A random JSON value: extremes of every type, short containers, now and then something deeply nested."""
    r = rng.random()
    if r < 0.25:
        return rng.choice(_INTS)
    if r < 0.4:
        return rng.choice(_FLOATS)
    if r < 0.55:
        return rng.choice(_STRINGS)
    if r < 0.62:
        return rng.choice([True, False, None])
    if r < 0.64:  # deep nesting, spliced into the JSON text by _dumps (json itself cannot write it)
        return f"__DEEP_{rng.choice([50, 500, 5000, 100000])}__"
    if depth > 3:
        return None
    if r < 0.85:
        return [json_value(rng, depth + 1) for _ in range(rng.randrange(0, 5))]
    return {rng.choice(_STRINGS[:8] + ["K", "omega", "rank", "max_error", "frame"]): json_value(rng, depth + 1)
            for _ in range(rng.randrange(0, 4))}


def mutate_bytes(data: bytes, rng: random.Random, count: int | None = None) -> bytes:
    """A damaged copy: 1-4 edits of overwritten, flipped, inserted or removed bytes, a truncation, a repeated
    block, or an integer field set to an extreme."""
    b = bytearray(data)
    for _ in range(count or rng.randrange(1, 5)):
        if not b:
            break
        op = rng.random()
        at = rng.randrange(len(b))
        if op < 0.3:
            n = rng.randrange(1, 9)
            b[at:at + n] = bytes(rng.randrange(256) for _ in range(min(n, len(b) - at)))
        elif op < 0.45:
            b[at] ^= 1 << rng.randrange(8)
        elif op < 0.55:
            b[at:at] = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 17)))
        elif op < 0.65:
            del b[at:at + rng.randrange(1, 17)]
        elif op < 0.75:
            del b[rng.randrange(len(b)):]
        elif op < 0.85:
            n = rng.randrange(1, 65)
            b[at:at] = b[at:at + n]
        else:
            width = rng.choice([2, 4, 8])
            value = rng.choice([0, 1, 2 ** (8 * width) - 1, 2 ** (8 * width - 1) - 1, 2 ** (8 * width - 1)])
            b[at:at + width] = value.to_bytes(width, "little")[:max(0, len(b) - at)]
    return bytes(b)


# ---- .mrc --------------------------------------------------------------------------------------------------------
def _paths(value: Any, prefix: tuple = ()) -> list[tuple]:
    out = [prefix]
    if isinstance(value, dict):
        for k, v in value.items():
            out.extend(_paths(v, prefix + (k,)))
    elif isinstance(value, list):
        for i, v in enumerate(value[:6]):
            out.extend(_paths(v, prefix + (i,)))
    return out


def _edit_json(meta: dict, rng: random.Random) -> dict:
    meta = json.loads(json.dumps(meta))
    for _ in range(rng.randrange(1, 4)):
        paths = [p for p in _paths(meta) if p]
        path = rng.choice(paths)
        parent = meta
        for k in path[:-1]:
            parent = parent[k]
        key = path[-1]
        op = rng.random()
        if op < 0.6:
            parent[key] = json_value(rng)
        elif op < 0.75:
            if isinstance(parent, dict):
                del parent[key]
            else:
                parent.pop(key)
        elif op < 0.85 and isinstance(parent[key], list) and parent[key]:
            parent[key] = parent[key] * rng.choice([2, 100]) if rng.random() < 0.5 else parent[key][:-1]
        elif op < 0.95 and isinstance(parent[key], (int, float)) and not isinstance(parent[key], bool):
            parent[key] = rng.choice([parent[key] * 2, parent[key] + 1, -parent[key], parent[key] * 10 ** 6])
        else:
            meta[rng.choice(["num_frames", "fps", "arrays", "skeleton", "codec", "evaluation"])] = json_value(rng)
    return meta


def _dumps(meta: dict) -> str:
    text = json.dumps(meta, sort_keys=True)
    for n in (50, 500, 5000, 100000):
        text = text.replace(f'"__DEEP_{n}__"', "[" * n + "]" * n)
    return text


def mrc_mutant(meta: dict, payload: bytes, rng: random.Random) -> bytes:
    """A mutant ``.mrc``: edited metadata with a valid CRC (half), damaged bytes re-checksummed (a third), or
    damaged bytes as they are."""
    r = rng.random()
    if r < 0.5:
        pay = payload if rng.random() < 0.8 else mutate_bytes(payload, rng)
        return pack_meta(_dumps(_edit_json(meta, rng)), pay)
    data = pack_meta(meta, payload)
    if r < 0.85:  # damage, then a valid length and CRC again: only the metadata checks stand between
        meta_len = struct.unpack_from("<I", data, 16)[0]
        blob, pay = data[20:20 + meta_len], data[20 + meta_len:-4]
        if rng.random() < 0.5:
            blob = mutate_bytes(blob, rng)
        else:
            text = zlib.decompress(blob)
            blob = zlib.compress(mutate_bytes(text, rng), 9)
        if rng.random() < 0.3:
            pay = mutate_bytes(pay, rng)
        return pack_raw(blob, pay, mrc_version(meta))
    return mutate_bytes(data, rng)


# ---- glTF (.glb) -------------------------------------------------------------------------------------------------
def split_glb(data: bytes) -> tuple[dict, bytes]:
    """The JSON document and the BIN chunk of a ``.glb`` file motionrep wrote."""
    json_len = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + json_len])
    rest = data[20 + json_len:]
    return doc, rest[8:8 + struct.unpack_from("<I", rest, 0)[0]] if rest else b""


def join_glb(text: bytes, blob: bytes) -> bytes:
    """A ``.glb`` file of a JSON chunk and a BIN chunk, its framing (lengths, padding) valid."""
    text += b" " * (-len(text) % 4)
    blob += b"\0" * (-len(blob) % 4)
    body = struct.pack("<I4s", len(text), b"JSON") + text + struct.pack("<I4s", len(blob), b"BIN\0") + blob
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


# numbers an attacker puts where glTF expects counts, offsets, indices, scales or key values
_GLTF_NUMBERS = [10 ** 400, -(10 ** 400), 10 ** 12, 2 ** 31, 2 ** 32 + 1, 2 ** 63, 1e308, -1e308, 1e200, 5e-324,
                 float("nan"), float("inf"), 0, -1, 65536, 1_000_000, 0.5]


def _numeric_edit(doc: dict, rng: random.Random) -> None:
    numbers = [p for p in _paths(doc) if p and _at(doc, p) is not True and _at(doc, p) is not False
               and isinstance(_at(doc, p), (int, float))]
    if numbers:
        path = rng.choice(numbers)
        parent = _at(doc, path[:-1])
        old = parent[path[-1]]
        parent[path[-1]] = rng.choice(_GLTF_NUMBERS + [old * 1000, old + 1, -old, old * 10 ** 6])


def _at(doc: Any, path: tuple) -> Any:
    for k in path:
        doc = doc[k]
    return doc


def gltf_json_mutant(doc: dict, blob: bytes, rng: random.Random) -> bytes:
    """A mutant ``.glb`` whose framing is valid and whose JSON chunk is edited: values replaced by random JSON
    (lists, objects, huge integers, NaN, deep nesting), numbers set to extremes, entries removed, lists repeated
    or cut; a fifth of them with damaged BIN bytes too."""
    doc = json.loads(json.dumps(doc))
    for _ in range(rng.randrange(1, 4)):
        if rng.random() < 0.5:
            _numeric_edit(doc, rng)
        else:
            doc = _edit_json(doc, rng)
    text = _dumps(doc).encode()
    if rng.random() < 0.2:
        blob = mutate_bytes(blob, rng)
    return join_glb(text, blob)


def glb_mutant(data: bytes, rng: random.Random) -> bytes:
    """A damaged ``.glb``: bytes overwritten, inserted, removed or truncated anywhere (half of them with the
    header's total length put right, so the damage reaches the chunks)."""
    out = bytearray(mutate_bytes(data, rng))
    if len(out) >= 12 and rng.random() < 0.5:
        out[8:12] = struct.pack("<I", len(out))
    return bytes(out)


# ---- NPZ ---------------------------------------------------------------------------------------------------------
_DTYPES = ["<f8", "<f4", "<i8", "<u1", "|b1", "<U5", "|S3", "<c16", ">f8", "|O"]


def _random_member(rng: random.Random, like: np.ndarray) -> bytes:
    shape = list(like.shape)
    op = rng.random()
    if op < 0.5 and shape:
        i = rng.randrange(len(shape))
        shape[i] = rng.choice([0, 1, 2, shape[i] + 1, max(0, shape[i] - 1), shape[i] * 2])
    elif op < 0.7:
        shape = [rng.randrange(0, 4) for _ in range(rng.randrange(0, 4))]
    dtype = like.dtype.str if rng.random() < 0.5 else rng.choice(_DTYPES)
    buf = io.BytesIO()
    if dtype == "|O":
        np.save(buf, np.array([None] * max(1, int(np.prod(shape))), dtype=object), allow_pickle=True)
    else:
        a = np.zeros(shape, dtype=dtype)
        if a.dtype.kind == "f":
            a[...] = rng.choice([0.0, 1.0, float("nan"), float("inf"), 1e308, -0.5])
        np.save(buf, a)
    return buf.getvalue()


def _header_edit(member: bytes, rng: random.Random) -> bytes:
    if not member.startswith(b"\x93NUMPY") or len(member) < 12:
        return mutate_bytes(member, rng)
    hlen = struct.unpack_from("<H", member, 8)[0]
    header = member[10:10 + hlen].decode("latin1")
    data = member[10 + hlen:]
    op = rng.random()
    if op < 0.4:
        chars = list(header)
        for _ in range(rng.randrange(1, 4)):
            at = rng.randrange(len(chars))
            chars[at] = rng.choice("(),:'\"{}[]0123456789 -eEUO<>|fi" + "\\")
        header = "".join(chars)
    elif op < 0.7:
        n = rng.choice([2 ** 31, 2 ** 33, 10 ** 12, 10 ** 30, -1, 0])
        header = "{'descr': '<f8', 'fortran_order': False, 'shape': (%d, 19, 4), }" % n
    else:
        header = rng.choice(["{", "{'descr': '<f8'}", "{'descr': '<f8', 'fortran_order': 1, 'shape': ()}",
                             "{'descr': [('a', '<f8')], 'fortran_order': False, 'shape': (2,), }",
                             "{'descr': '<f8', 'fortran_order': False, 'shape': (" + "(" * 500 + ")"])
    return npy_bytes(header, data)


def npz_mutant(members: dict[str, bytes], arrays: dict[str, np.ndarray], rng: random.Random) -> bytes:
    """A mutant NPZ: members replaced (other dtypes and shapes, pickles, headers declaring huge shapes, damaged
    header text), removed or added, stored or deflated; or the archive's bytes damaged."""
    out = dict(members)
    deflate = rng.random() < 0.4
    r = rng.random()
    if r < 0.75:
        for _ in range(rng.randrange(1, 3)):
            name = rng.choice(sorted(out))
            op = rng.random()
            if op < 0.35:
                out[name] = _random_member(rng, arrays[name[:-4]] if name[:-4] in arrays else np.zeros(3))
            elif op < 0.6:
                out[name] = _header_edit(out[name], rng)
            elif op < 0.7:
                del out[name]
                if not out:
                    break
            elif op < 0.8:
                out[name] = mutate_bytes(out[name], rng)
            elif op < 0.9:
                out[name] = out[name][: rng.randrange(len(out[name]) + 1)]
            else:
                out[rng.choice(["extra.npy", "euler_angles.npy", "features.npy", "x"])] = _random_member(
                    rng, np.zeros((3, 2)))
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED if deflate else zipfile.ZIP_STORED) as z:
        for name, data in out.items():
            z.writestr(name, data)
    data = buf.getvalue()
    return mutate_bytes(data, rng) if r >= 0.75 else data


# ---- HDF5 --------------------------------------------------------------------------------------------------------
def _h5_structural(path: Path, base: bytes, rng: random.Random, secret_dir: Path) -> None:
    path.write_bytes(base)
    with h5py.File(path, "r+") as f:
        clips = f["clips"]
        clip = clips[next(iter(clips))]
        names = ["rotations", "root_translation", "joint_translations", "euler_branch", "euler_angles",
                 "skeleton/names", "skeleton/parents", "skeleton/offsets", "skeleton/channels"]
        name = rng.choice([n for n in names if n in clip] or ["rotations"])
        op = rng.random()
        like = clip[name] if name in clip else None
        shape = like.shape if like is not None else (3, 4)
        if name in clip:
            del clip[name]
        if op < 0.15:
            clip[name] = h5py.SoftLink(rng.choice(["/clips", f"/clips/{name}", "/nowhere", "/"]))
        elif op < 0.25:
            target = secret_dir / "secret.h5"
            if not target.exists():
                with h5py.File(target, "w") as s:
                    s["data"] = np.full((64, 64, 4), SECRET_VALUE)
            clip[name] = h5py.ExternalLink(str(target), "/data")
        elif op < 0.35:
            secret = secret_dir / "secret.bin"
            if not secret.exists():
                secret.write_bytes(np.full(4096, SECRET_VALUE).tobytes() + SECRET)
            n = int(np.prod(shape)) if shape else 1
            clip.create_dataset(name, shape=shape, dtype="<f8", external=[(str(secret), 0, max(8, n * 8))])
        elif op < 0.45:
            target = secret_dir / "secret.h5"
            if not target.exists():
                with h5py.File(target, "w") as s:
                    s["data"] = np.full((64, 64, 4), SECRET_VALUE)
            layout = h5py.VirtualLayout(shape=shape, dtype="<f8")
            layout[...] = h5py.VirtualSource(str(target), "data", shape=(64, 64, 4))[
                tuple(slice(0, min(s, 64)) for s in shape)] if len(shape) == 3 else h5py.VirtualSource(
                str(target), "data", shape=(64, 64, 4))[0, 0, 0]
            try:
                clip.create_virtual_dataset(name, layout)
            except Exception:
                clip[name] = np.zeros(shape)
        elif op < 0.6:
            dtype = rng.choice(["<f8", "<i4", "|u1", "<f2", h5py.string_dtype("utf-8"), "<c16",
                                h5py.vlen_dtype(np.float64), h5py.ref_dtype, np.dtype([("a", "<f8")])])
            shp = tuple(rng.choice([0, 1, 2, s, s + 1]) for s in shape) if rng.random() < 0.6 else ()
            try:
                clip.create_dataset(name, shape=shp, dtype=dtype)
            except Exception:
                clip.create_dataset(name, data=np.zeros(shp))
        elif op < 0.7:
            big = (rng.choice([10 ** 6, 10 ** 9, 2 ** 40]),) + tuple(shape[1:])
            clip.create_dataset(name, shape=big, dtype="<f8", chunks=(1,) + tuple(max(1, s) for s in shape[1:]))
        elif op < 0.85:
            key = rng.choice(["fps", "kind", "quat_order", "units", "format", "format_version"])
            target = f if key.startswith("format") else clip
            value = rng.choice([np.array([1.0, 2.0]), "x", np.int64(-1), np.float64("nan"), b"\xff\xfe",
                                np.zeros(10 ** 5), h5py.Empty("f8"), np.array([b"a", b"b"])])
            try:
                target.attrs[key] = value
            except Exception:
                target.attrs[key] = "?"
            clip[name] = np.zeros(shape)
        else:
            clips[rng.choice(["x", "good", "a/b"]) if rng.random() < 0.5 else "link"] = (
                h5py.SoftLink("/clips") if rng.random() < 0.5 else h5py.ExternalLink(str(secret_dir / "secret.h5"),
                                                                                    "/"))
            clip[name] = np.zeros(shape)


def h5_mutant(path: Path, bases: list[bytes], rng: random.Random, secret_dir: Path) -> None:
    """Write a mutant HDF5 file to ``path``: bytes of a version 1 or 2 file damaged (as the issue's probe did:
    7 random bytes, and other damage), or objects replaced by links, external storage, virtual datasets, other
    types and shapes, huge declared shapes, odd attributes."""
    base = rng.choice(bases)
    if rng.random() < 0.7:
        if rng.random() < 0.5:
            b = bytearray(base)
            at = rng.randrange(len(b) - 7)
            b[at:at + 7] = bytes(rng.randrange(256) for _ in range(7))
            path.write_bytes(bytes(b))
        else:
            path.write_bytes(mutate_bytes(base, rng))
        return
    try:
        _h5_structural(path, base, rng, secret_dir)
    except Exception:  # a mutation h5py itself cannot make: use the damaged bytes instead
        path.write_bytes(mutate_bytes(base, rng))


# ---- BVH ---------------------------------------------------------------------------------------------------------
_BVH_WORDS = [b"ROOT", b"JOINT", b"End", b"Site", b"{", b"}", b"OFFSET", b"CHANNELS", b"MOTION", b"Frames:",
              b"Frame", b"Time:", b"Xrotation", b"Yposition", b"HIERARCHY", b"nan", b"inf", b"1e999", b"-0",
              b"0", b"3", b"1000000000", b"99999999999999999999", b"1e-320", b"\xef\xbb\xbf", b"\t", b"\r\n"]


def bvh_mutant(text: bytes, rng: random.Random) -> bytes:
    """A mutant BVH: tokens replaced, deleted or repeated, lines dropped, repeated or swapped, bytes damaged."""
    r = rng.random()
    if r < 0.3:
        return mutate_bytes(text, rng)
    lines = text.split(b"\n")
    for _ in range(rng.randrange(1, 4)):
        i = rng.randrange(len(lines))
        op = rng.random()
        words = lines[i].split()
        if op < 0.4 and words:
            j = rng.randrange(len(words))
            words[j] = rng.choice(_BVH_WORDS)
            lines[i] = b" ".join(words)
        elif op < 0.55:
            del lines[i]
            if not lines:
                lines = [b""]
        elif op < 0.7:
            lines.insert(i, lines[i] * rng.choice([1, 2]))
        elif op < 0.8:
            j = rng.randrange(len(lines))
            lines[i], lines[j] = lines[j], lines[i]
        elif op < 0.9 and words:
            words.insert(rng.randrange(len(words) + 1), rng.choice(_BVH_WORDS))
            lines[i] = b" ".join(words)
        else:
            lines[i] = lines[i][: rng.randrange(len(lines[i]) + 1)]
    return b"\n".join(lines)
