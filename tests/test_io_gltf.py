"""glTF 2.0: round trips through motionrep's own files, files other tools write, and hostile files."""

from __future__ import annotations

import base64
import json
import math
import struct
from pathlib import Path

import numpy as np
import pygltflib
import pytest
from scipy.spatial.transform import Rotation

from motionrep import Motion, Skeleton, character_height, global_positions
from motionrep.errors import GLTFFormatError
from motionrep.io import gltf_bytes, list_clips, read, read_clips, read_stored, write
from motionrep.io._bvh import channel_values
from motionrep.model.synthetic import humanoid_skeleton, odd_skeleton, synthetic_motion

from helpers import real_params, run_cli_caught

#: glTF stores float32: a round trip agrees within float32 rounding; the promise is 1e-6 of the height.
TOLERANCE = 1e-6


def fk_error(a: Motion, b: Motion) -> float:
    """Largest joint or end-site position difference, as a fraction of a's character height."""
    return float(np.abs(global_positions(a) - global_positions(b)).max() / character_height(a.skeleton))


def odd_motion(frames: int = 40) -> Motion:
    """A root without position channels, one- and two-axis joints, a joint without channels, position channels
    on other joints, units in cm (a motion a BVH file can hold)."""
    sk = odd_skeleton()
    m = synthetic_motion(sk, frames=frames, fps=120.0, seed=3)
    return m.replace(root_translation=np.broadcast_to(sk.offsets[0], (frames, 3)))


def split_glb(data: bytes) -> tuple[dict, bytes]:
    json_len = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + json_len])
    rest = data[20 + json_len:]
    blob = rest[8:8 + struct.unpack_from("<I", rest, 0)[0]] if rest else b""
    return doc, blob


def join_glb(doc: dict, blob: bytes) -> bytes:
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    blob += b"\0" * (-len(blob) % 4)
    body = struct.pack("<I4s", len(text), b"JSON") + text + struct.pack("<I4s", len(blob), b"BIN\0") + blob
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


# ---------------------------------------------------------------------------------------------------------------
# motionrep's own files
# ---------------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("suffix", [".glb", ".gltf"])
@pytest.mark.parametrize("motion", [
    pytest.param(synthetic_motion(humanoid_skeleton(), frames=60, fps=30.0), id="humanoid"),
    pytest.param(synthetic_motion(humanoid_skeleton("XYZ"), frames=1, fps=24.0, seed=4), id="one-frame"),
    pytest.param(odd_motion(), id="odd-skeleton"),
])
def test_round_trip_keeps_skeleton_layout_and_positions(tmp_path, motion, suffix):
    path = tmp_path / f"clip{suffix}"
    write(motion, path)
    back = read(path)
    assert back.skeleton == motion.skeleton  # names, parents, exact offsets, channels, end sites, units
    assert back.fps == motion.fps and back.num_frames == motion.num_frames
    assert fk_error(motion, back) < TOLERANCE
    channel_values(back)  # the BVH writer accepts it: no motion invented on axes without channels
    assert list_clips(path) == ["clip"] and read_stored(path)[0] == "clip"


def test_gltf_file_is_one_self_contained_file(tmp_path):
    path = tmp_path / "walk.gltf"
    write(synthetic_motion(humanoid_skeleton(), frames=5), path)
    doc = json.loads(path.read_text())
    assert [p.name for p in tmp_path.iterdir()] == ["walk.gltf"]
    assert doc["buffers"][0]["uri"].startswith("data:application/octet-stream;base64,")
    assert doc["asset"]["version"] == "2.0" and doc["asset"]["generator"].startswith("motionrep")


def test_written_layout(tmp_path):
    motion = synthetic_motion(humanoid_skeleton(), frames=12, fps=24.0)
    sk = motion.skeleton
    doc, blob = split_glb(gltf_bytes(motion, clip="walk", up="y"))
    J, E = sk.num_joints, sk.num_end_sites
    assert doc["scenes"][0]["nodes"] == [0] and doc["nodes"][0]["children"] == [1]
    assert [n["name"] for n in doc["nodes"][1:1 + J]] == list(sk.names)
    assert doc["skins"][0]["joints"] == list(range(1, 1 + J + E))
    anim = doc["animations"][0]
    assert anim["name"] == "walk" and anim["extras"]["motionrep"]["fps"] == 24.0
    times_acc = doc["accessors"][anim["samplers"][0]["input"]]
    assert times_acc["count"] == 12 and times_acc["max"] == [pytest.approx(11 / 24)]
    targets = {(c["target"]["node"], c["target"]["path"]) for c in anim["channels"]}
    assert (1, "translation") in targets and all((1 + j, "rotation") in targets for j in range(J))
    info = doc["nodes"][0]["extras"]["motionrep"]
    assert info["format"] == "motionrep-gltf" and info["version"] == 1
    assert info["channels"][0] == " ".join(sk.channels[0])
    # pygltflib (the container library) reads it back
    g = pygltflib.GLTF2.load_from_bytes(gltf_bytes(motion))
    assert len(g.animations) == 1 and len(g.skins) == 1


def test_units_scale_and_up_axis_on_the_armature(tmp_path):
    motion = synthetic_motion(humanoid_skeleton().replace(units="cm"), frames=40)
    zup = _turn_to_z_up(motion)
    doc, _ = split_glb(gltf_bytes(zup))
    arm = doc["nodes"][0]
    assert arm["scale"] == [0.01, 0.01, 0.01]
    assert arm["rotation"] == pytest.approx([-math.sqrt(0.5), 0, 0, math.sqrt(0.5)])
    assert arm["extras"]["motionrep"]["up"] == "z"
    path = tmp_path / "z.glb"
    write(zup, path, scale=0.5)
    back = read(path)
    assert back.skeleton.units == "cm" and fk_error(zup, back) < TOLERANCE
    # read as another tool would (without motionrep's description): metres, Y-up
    foreign = _strip_description(path, tmp_path / "foreign.glb")
    theirs = read(foreign)
    assert theirs.skeleton.units == "m"
    mine = global_positions(zup)
    want = 0.5 * np.stack([mine[..., 0], mine[..., 2], -mine[..., 1]], axis=-1)
    order = [theirs.skeleton.names.index(n) for n in zup.skeleton.names]  # end sites are joints there
    got = global_positions(theirs)[:, order]
    assert np.abs(got - want[:, :zup.num_joints]).max() < TOLERANCE * 0.5 * character_height(zup.skeleton)


def _turn_to_z_up(motion: Motion) -> Motion:
    """The same motion in a Z-up world (a turn of +90 degrees about X applied to the root)."""
    turn = Rotation.from_euler("x", 90, degrees=True)
    root = turn * Rotation.from_quat(motion.rotations[:, 0])
    rot = np.array(motion.rotations)
    rot[:, 0] = root.as_quat()
    sk = motion.skeleton
    off = np.array(sk.offsets)
    off[0] = turn.apply(off[0])
    return Motion(sk.replace(offsets=off), motion.fps, turn.apply(np.array(motion.root_translation)), rot)


def _strip_description(src: Path, dst: Path) -> Path:
    doc, blob = split_glb(src.read_bytes())
    del doc["nodes"][0]["extras"]
    dst.write_bytes(join_glb(doc, blob))
    return dst


def test_foreign_reading_of_a_y_up_file_gives_the_same_world_positions(tmp_path):
    motion = synthetic_motion(humanoid_skeleton(), frames=30)  # in cm: written at 0.01 m per unit
    path = tmp_path / "a.glb"
    write(motion, path, up="y")
    theirs = read(_strip_description(path, tmp_path / "b.glb"))
    J = motion.num_joints
    order = [theirs.skeleton.names.index(n) for n in motion.skeleton.names]
    assert np.abs(global_positions(theirs)[:, order] - 0.01 * global_positions(motion)[:, :J]).max() \
        < TOLERANCE * 0.01 * character_height(motion.skeleton)
    assert theirs.fps == motion.fps


@pytest.mark.parametrize("path", real_params())
def test_real_clips_bvh_gltf_bvh(tmp_path, path):
    """BVH -> glTF -> BVH: the clip read back has the BVH file's skeleton and channel layout, its channel values
    can be written (the BVH text round trip itself is lossless, tests/test_io_bvh.py), and FK agrees."""
    motion = read(path)
    write(motion, tmp_path / "x.glb")
    back = read(tmp_path / "x.glb")
    assert back.skeleton == motion.skeleton
    channel_values(back)
    assert fk_error(motion, back) < TOLERANCE


# ---------------------------------------------------------------------------------------------------------------
# files other tools write (built here the way Blender / COLLADA2GLTF / glTF-Transform lay them out)
# ---------------------------------------------------------------------------------------------------------------
class Builder:
    """A small glTF document with float accessors in one buffer."""

    def __init__(self):
        self.doc = {"asset": {"version": "2.0", "generator": "test"}, "scene": 0, "scenes": [{"nodes": [0]}],
                    "nodes": [], "accessors": [], "bufferViews": [], "buffers": [], "animations": []}
        self.blob = b""

    def node(self, **fields) -> int:
        self.doc["nodes"].append(fields)
        return len(self.doc["nodes"]) - 1

    def accessor(self, values, kind: str, with_range: bool = False) -> int:
        a = np.asarray(values, dtype="<f4")
        raw = a.tobytes()
        self.doc["bufferViews"].append({"buffer": 0, "byteOffset": len(self.blob), "byteLength": len(raw)})
        self.blob += raw
        acc = {"bufferView": len(self.doc["bufferViews"]) - 1, "componentType": 5126, "count": int(a.shape[0]),
               "type": kind}
        if with_range:
            acc.update(min=[float(a.min())], max=[float(a.max())])
        self.doc["accessors"].append(acc)
        return len(self.doc["accessors"]) - 1

    def animation(self, name, channels) -> None:
        anim = {"channels": [], "samplers": []}
        if name is not None:
            anim["name"] = name
        for node, path, times, values, interpolation in channels:
            kind = {"rotation": "VEC4"}.get(path, "VEC3")
            anim["samplers"].append({"input": self.accessor(np.asarray(times)[:, None], "SCALAR", True),
                                     "output": self.accessor(values, kind), "interpolation": interpolation})
            anim["channels"].append({"sampler": len(anim["samplers"]) - 1, "target": {"node": node, "path": path}})
        self.doc["animations"].append(anim)

    def glb(self) -> bytes:
        self.doc["buffers"] = [{"byteLength": len(self.blob)}]
        return join_glb(self.doc, self.blob)


def _quat(axis: str, degrees) -> np.ndarray:
    return Rotation.from_euler(axis, degrees, degrees=True).as_quat()


def blender_like(frames: int = 12, fps: float = 24.0) -> Builder:
    """An armature object (turned, scaled) with a skinned mesh and bones with rest rotations, baked per frame,
    a constant channel with two keys, scale keys with rounding noise and a cubic-spline channel."""
    b = Builder()
    t = np.arange(frames) / fps
    arm = b.node(name="Armature", rotation=list(_quat("x", -90)), scale=[0.01, 0.01, 0.01], children=[])
    hips = b.node(name="Hips", translation=[0.0, 0.0, 95.0], rotation=list(_quat("x", 90)), children=[])
    spine = b.node(name="Spine", translation=[0.0, 12.0, 0.0], rotation=list(_quat("z", 5)), children=[])
    head = b.node(name="Head", translation=[0.0, 30.0, 0.0], scale=[1.0, 1.0000156, 1.0], children=[])
    leg = b.node(name="Upper Leg.L", translation=[8.0, 0.0, 0.0], rotation=list(_quat("z", 180)), children=[])
    shin = b.node(name="Lower{Leg}", translation=[0.0, 45.0, 0.0], children=[])
    mesh = b.node(name="Body", mesh=0, skin=0)
    b.doc["nodes"][arm]["children"] = [hips, mesh]
    b.doc["nodes"][hips]["children"] = [spine, leg]
    b.doc["nodes"][spine]["children"] = [head]
    b.doc["nodes"][leg]["children"] = [shin]
    b.doc["skins"] = [{"joints": [hips, spine, head, leg, shin]}]
    b.doc["meshes"] = [{"primitives": [{"attributes": {"POSITION": b.accessor(np.zeros((3, 3)), "VEC3")}}]}]
    wave = np.sin(2 * np.pi * t)
    hips_rot = (Rotation.from_euler("y", 30 * wave[:, None], degrees=True) * Rotation.from_quat(_quat("x", 90))).as_quat()
    b.animation("Walk", [
        (hips, "translation", t, np.stack([10 * t, 2 * wave, 95 + wave], axis=-1), "LINEAR"),
        (hips, "rotation", t, hips_rot, "LINEAR"),
        (spine, "rotation", [t[0], t[-1]], [_quat("z", 5)] * 2, "LINEAR"),  # constant: two keys
        (head, "rotation", t, Rotation.from_euler("x", 20 * wave[:, None], degrees=True).as_quat(), "STEP"),
        (head, "scale", t, np.tile([1.0, 1.0000156, 0.99999], (frames, 1)), "LINEAR"),
        (leg, "rotation", t, np.concatenate([
            np.stack([np.zeros((frames, 4)), (Rotation.from_euler("x", 25 * wave[:, None], degrees=True)
                                              * Rotation.from_quat(_quat("z", 180))).as_quat(),
                      np.zeros((frames, 4))], axis=1).reshape(-1, 4)]), "CUBICSPLINE"),
        (shin, "rotation", t, Rotation.from_euler("x", 40 + 20 * wave[:, None], degrees=True).as_quat(), "LINEAR"),
    ])
    return b


def world_positions(doc: dict, blob: bytes, names: list[str], frame_times) -> np.ndarray:
    """Every named node's world position at the given key times, by plain 4x4 matrices (independent of motionrep)."""
    nodes = doc["nodes"]
    parent = {c: i for i, n in enumerate(nodes) for c in n.get("children", [])}

    def values(acc_index):
        acc = doc["accessors"][acc_index]
        view = doc["bufferViews"][acc["bufferView"]]
        width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}[acc["type"]]
        return np.frombuffer(blob, "<f4", acc["count"] * width, view["byteOffset"]).reshape(-1, width)

    tracks = {}
    for anim in doc["animations"]:
        for ch in anim["channels"]:
            s = anim["samplers"][ch["sampler"]]
            out = values(s["output"])
            if s["interpolation"] == "CUBICSPLINE":
                out = out[1::3]
            tracks[(ch["target"]["node"], ch["target"]["path"])] = (values(s["input"])[:, 0], out)

    def local(i, time):
        n = nodes[i]
        trs = {"translation": n.get("translation", [0, 0, 0]), "rotation": n.get("rotation", [0, 0, 0, 1]),
               "scale": n.get("scale", [1, 1, 1])}
        for path in trs:
            if (i, path) in tracks:
                keys, vals = tracks[(i, path)]
                k = np.searchsorted(keys, time + 1e-6) - 1
                trs[path] = vals[max(k, 0)]  # every test time is a key time or after a constant's last key
        m = np.eye(4)
        m[:3, :3] = Rotation.from_quat(trs["rotation"]).as_matrix() * np.asarray(trs["scale"])
        m[:3, 3] = trs["translation"]
        return m

    out = np.zeros((len(frame_times), len(names), 3))
    for f, time in enumerate(frame_times):
        for k, name in enumerate(names):
            i = next(i for i, n in enumerate(nodes) if n.get("name") == name)
            m = local(i, time)
            while i in parent:
                i = parent[i]
                m = local(i, time) @ m
            out[f, k] = m[:3, 3]
    return out


def test_blender_like_file(tmp_path):
    b = blender_like()
    path = tmp_path / "rig.glb"
    path.write_bytes(b.glb())
    motion = read(path)
    sk = motion.skeleton
    assert sk.names == ("Hips", "Spine", "Head", "Upper Leg.L", "Lower_Leg_")  # mesh node left out
    assert sk.units == "m" and motion.fps == 24.0 and motion.num_frames == 12
    assert sk.position_axes[0] == "XYZ" and not sk.translated_joints.size
    want = world_positions(b.doc, b.blob, ["Hips", "Spine", "Head", "Upper Leg.L", "Lower{Leg}"],
                           np.arange(12) / 24.0)
    got = global_positions(motion)
    # the file's values are float32 and the head's scale noise is averaged: 1e-6 of the height is the promise
    assert np.abs(got - want).max() < 1e-6 * character_height(sk)
    # the rest pose (zero rotations) is the file's rest pose: the legs hang down, the head is above the hips
    rest = global_positions(Motion(sk, 24.0, sk.offsets[:1], np.tile([0, 0, 0, 1.0], (1, sk.num_joints, 1))))[0]
    assert rest[2, 1] > rest[0, 1] > rest[4, 1]
    assert 0.5 < character_height(sk) < 1.0  # metres
    write(motion, tmp_path / "rig.bvh")  # and on to BVH


def test_sparse_keyframes_are_sampled_at_a_frame_rate(tmp_path):
    b = Builder()
    root = b.node(name="root", children=[1])
    b.node(name="arm", translation=[0, 1, 0], children=[2])
    b.node(name="hand", translation=[0, 1, 0])
    b.animation("Wave", [(1, "rotation", [0.0, 0.5, 1.25], [_quat("z", a) for a in (0, 90, 0)], "LINEAR"),
                         (root, "translation", [0.0, 1.25], [[0, 0, 0], [1, 0, 0]], "LINEAR")])
    path = tmp_path / "keys.gltf"
    doc = dict(b.doc, buffers=[{"byteLength": len(b.blob),
                                "uri": "data:application/octet-stream;base64," + base64.b64encode(b.blob).decode()}])
    path.write_text(json.dumps(doc))
    motion = read(path)
    assert motion.fps == 24.0 and motion.num_frames == 31  # 0.5 and 1.25 s are frames 12 and 30 at 24 fps
    pos = global_positions(motion)
    assert np.allclose(pos[12, 2], [0.4 - 1, 1, 0], atol=1e-6)  # at 0.5 s the arm points along -x, root at 0.4
    assert np.allclose(pos[30, 2], [1, 2, 0], atol=1e-6)


def test_several_animations_are_clips(tmp_path):
    b = Builder()
    b.node(name="root", children=[1])
    b.node(name="arm", translation=[0, 1, 0], children=[2])
    b.node(name="hand", translation=[0, 1, 0])
    for name, angle in (("Idle", 10), ("Run", 80), ("Run", 40)):
        b.animation(name, [(1, "rotation", [0.0, 1 / 30], [_quat("z", 0), _quat("z", angle)], "LINEAR")])
    path = tmp_path / "clips.glb"
    path.write_bytes(b.glb())
    assert list_clips(path) == ["Idle", "Run", "Run.001"]
    with pytest.raises(GLTFFormatError, match="3 animations; choose one with clip=NAME.*Idle, Run, Run.001"):
        read(path)
    with pytest.raises(GLTFFormatError, match="no animation named 'Walk'"):
        read(path, clip="Walk")
    names = [name for name, _ in read_clips(path)]
    assert names == ["Idle", "Run", "Run.001"]
    run = read(path, "Run.001")  # the animated arm and the plain node under it; the static root folded in
    assert run.skeleton.names == ("arm", "hand")
    last = global_positions(run)[-1, 1]
    assert np.allclose(last, [-math.sin(math.radians(40)), 1 + math.cos(math.radians(40)), 0], atol=1e-6)


def test_unnamed_animations_per_joint_are_one_clip(tmp_path):
    b = Builder()
    b.node(children=[1], matrix=[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 2, 0, 0, 1])  # COLLADA2GLTF: matrices
    b.node(translation=[0, 1, 0], children=[2])
    b.node(translation=[0, 1, 0])
    t = [0.0, 1 / 30, 2 / 30]
    b.animation(None, [(1, "rotation", t, [_quat("z", a) for a in (0, 10, 20)], "LINEAR")])
    b.animation(None, [(2, "rotation", t, [_quat("z", a) for a in (0, 5, 10)], "LINEAR")])
    path = tmp_path / "collada.glb"
    path.write_bytes(b.glb())
    assert list_clips(path) == ["animation"]
    motion = read(path)
    assert motion.skeleton.names == ("node1", "node2") and motion.num_frames == 3  # the static top folded in
    assert np.allclose(global_positions(motion)[0, 1], [2, 2, 0], atol=1e-6)


# ---------------------------------------------------------------------------------------------------------------
# hostile and broken files: one line naming the file, nothing fetched, nothing huge allocated
# ---------------------------------------------------------------------------------------------------------------
@pytest.fixture
def good() -> tuple[dict, bytes]:
    return split_glb(gltf_bytes(synthetic_motion(humanoid_skeleton(), frames=8), up="y"))


def _refused(tmp_path, data: bytes, needle: str, name: str = "bad.glb") -> None:
    path = tmp_path / name
    path.write_bytes(data)
    with pytest.raises(GLTFFormatError) as info:
        read(path)
    message = str(info.value)
    assert message.startswith(str(path)) and "\n" not in message and needle in message, message


def _mutated(good, change) -> bytes:
    doc, blob = json.loads(json.dumps(good[0])), good[1]
    blob = change(doc, blob) or blob
    return join_glb(doc, blob)


def test_glb_framing(tmp_path, good):
    data = join_glb(*good)
    _refused(tmp_path, data[:-8], "GLB header says")
    _refused(tmp_path, struct.pack("<4sII", b"glTF", 2, 18) + b"\x00" * 6, "truncated GLB chunk header")
    _refused(tmp_path, b"glTF\x02\x00", "truncated GLB file")
    _refused(tmp_path, struct.pack("<4sII", b"glTF", 2, 20) + b"\xff\xff\xff\x7fJSON", "past the end")
    _refused(tmp_path, struct.pack("<4sII", b"glTF", 1, 12), "version 1")
    broken = bytearray(data)
    struct.pack_into("<I", broken, 12, 10 ** 9)
    _refused(tmp_path, bytes(broken), "past the end of the file")
    _refused(tmp_path, b"\x00\x01binary junk", "not a glTF file")
    _refused(tmp_path, b"{\"nodes\": []}", "no 'asset'", name="x.gltf")
    _refused(tmp_path, b"[" * 100000, "invalid JSON", name="deep.gltf")
    _refused(tmp_path, json.dumps({"asset": {"version": "1.0"}}).encode(), "version '1.0'", name="old.gltf")


@pytest.mark.parametrize("uri, needle", [
    ("http://example.invalid/x.bin", "never fetches a URI"),
    ("../secret.bin", "never fetches a URI"),
    ("/etc/passwd", "never fetches a URI"),
    ("file:///etc/passwd", "never fetches a URI"),
    ("sub%2F..%2Fsecret.bin", "never fetches a URI"),
    (".hidden.bin", "never fetches a URI"),
    ("missing.bin", "missing"),
])
def test_external_uris_are_not_followed(tmp_path, good, uri, needle):
    doc, blob = good
    doc = json.loads(json.dumps(doc))
    doc["buffers"][0]["uri"] = uri
    (tmp_path / "secret.bin").write_bytes(blob)
    path = tmp_path / "sub" / "x.gltf"
    path.parent.mkdir()
    path.write_text(json.dumps(doc))
    with pytest.raises(GLTFFormatError, match=needle):
        read(path)


def test_a_buffer_beside_the_gltf_file_is_read(tmp_path, good):
    doc, blob = good
    doc = json.loads(json.dumps(doc))
    doc["buffers"][0]["uri"] = "walk%20data.bin"
    (tmp_path / "walk data.bin").write_bytes(blob)
    (tmp_path / "walk.gltf").write_text(json.dumps(doc))
    assert read(tmp_path / "walk.gltf").num_frames == 8


def test_links_out_of_the_folder_are_refused(tmp_path, good):
    doc, blob = good
    doc = json.loads(json.dumps(doc))
    doc["buffers"][0]["uri"] = "data.bin"
    (tmp_path / "elsewhere.bin").write_bytes(blob)
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "data.bin").symlink_to(tmp_path / "elsewhere.bin")
    (tmp_path / "sub" / "x.gltf").write_text(json.dumps(doc))
    with pytest.raises(GLTFFormatError, match="not a regular file beside"):
        read(tmp_path / "sub" / "x.gltf")


def _set(path: list, value):
    def change(doc, blob):
        target = doc
        for key in path[:-1]:
            target = target[key]
        target[path[-1]] = value
    return change


@pytest.mark.parametrize("change, needle", [
    (_set(["accessors", 1, "count"], 2 ** 31 - 1), "need"),
    (_set(["accessors", 1, "byteOffset"], 10 ** 9), "need"),
    (_set(["bufferViews", 1, "byteLength"], 10 ** 9), "past the end of its buffer"),
    (_set(["bufferViews", 0, "byteStride"], 2), "byteStride"),
    (_set(["accessors", 1, "componentType"], 5130), "component type"),
    (_set(["accessors", 1, "type"], "MAT4"), "has type"),
    (_set(["accessors", 1, "sparse"], {"count": 1}), "sparse"),
    (_set(["accessors", 1, "bufferView"], 99), "does not exist"),
    (_set(["animations", 0, "channels", 0, "target", "node"], 999), "does not exist"),
    (_set(["animations", 0, "samplers", 0, "interpolation"], "BEZIER"), "unknown interpolation"),
    (_set(["nodes", 1, "children"], [1]), "not another node"),
    (_set(["nodes", 2, "children"], [1]), "two parents"),
    (_set(["nodes", 3, "scale"], [1, 2, 1]), "not a positive uniform scale"),
    (_set(["nodes", 3, "translation"], ["a", 0, 0]), "list of 3 numbers"),
    (_set(["nodes", 3, "translation"], [1, 2]), "list of 3 numbers"),
    (_set(["extensionsRequired"], ["KHR_future_compression"]), "KHR_future_compression"),
    (_set(["buffers", 0, "byteLength"], 10 ** 12), "holds"),
    (_set(["nodes", 0, "extras", "motionrep", "version"], 9), "newer than this motionrep reads"),
    (_set(["animations"], []), "no animation"),
])
def test_malformed_documents(tmp_path, good, change, needle):
    _refused(tmp_path, _mutated(good, change), needle)


def test_cycles_non_finite_values_and_time_bombs(tmp_path, good):
    def cycle(doc, blob):
        doc["nodes"][0]["children"] = [1]
        doc["nodes"][1]["children"] = doc["nodes"][1].get("children", []) + [0]
    _refused(tmp_path, _mutated(good, cycle), "cycle")

    def nan(doc, blob):
        view = doc["bufferViews"][doc["accessors"][1]["bufferView"]]
        start = view["byteOffset"] + doc["accessors"][1].get("byteOffset", 0)
        return blob[:start] + struct.pack("<f", float("nan")) + blob[start + 4:]
    _refused(tmp_path, _mutated(good, nan), "not finite")

    def far_key(doc, blob):  # two keys a hundred years apart at a high rate: refused, not allocated
        doc["animations"][0]["extras"] = {}
        times = doc["accessors"][0]
        view = doc["bufferViews"][times["bufferView"]]
        end = view["byteOffset"] + 4 * (times["count"] - 1)
        return blob[:end] + struct.pack("<f", 3.0e9) + blob[end + 4:]
    _refused(tmp_path, _mutated(good, far_key), "too sparse or uneven")

    def backwards(doc, blob):
        times = doc["accessors"][0]
        view = doc["bufferViews"][times["bufferView"]]
        return blob[:view["byteOffset"]] + struct.pack("<f", 5.0) + blob[view["byteOffset"] + 4:]
    _refused(tmp_path, _mutated(good, backwards), "key times decrease")


def test_animated_scale_is_refused(tmp_path):
    b = Builder()
    b.node(name="root", children=[1])
    b.node(name="arm", translation=[0, 1, 0])
    b.animation("Grow", [(1, "scale", [0.0, 1 / 30], [[1, 1, 1], [2, 2, 2]], "LINEAR"),
                         (1, "rotation", [0.0, 1 / 30], [_quat("z", 0)] * 2, "LINEAR")])
    _refused(tmp_path, b.glb(), "animated or non-uniform scale")


def test_missing_file(tmp_path):
    with pytest.raises(GLTFFormatError, match="no such file"):
        read(tmp_path / "nothing.glb")


def test_features_cannot_go_to_gltf(tmp_path):
    from motionrep.io import features_from_motion, write_features

    features = features_from_motion(synthetic_motion(humanoid_skeleton(), frames=3), "euler")
    with pytest.raises(GLTFFormatError, match="hold motions, not features"):
        write_features(features, tmp_path / "x.glb")


def test_write_options_are_checked(tmp_path):
    from motionrep.errors import ValidationError

    motion = synthetic_motion(humanoid_skeleton(), frames=3)
    with pytest.raises(ValidationError, match="scale"):
        write(motion, tmp_path / "x.glb", scale=-1)
    with pytest.raises(ValidationError, match="up"):
        write(motion, tmp_path / "x.glb", up="x")
    assert not list(tmp_path.iterdir())


def test_skeleton_keeps_several_end_sites_per_joint(tmp_path):
    sk = Skeleton(names=("root", "hand"), parents=[-1, 0], offsets=[[0, 0, 0], [0, 1, 0]],
                  end_site_parents=[1, 1, 0], end_site_offsets=[[0.1, 0, 0], [-0.1, 0, 0], [0, -1, 0]])
    motion = synthetic_motion(sk, frames=4)
    write(motion, tmp_path / "e.glb")
    doc, _ = split_glb((tmp_path / "e.glb").read_bytes())
    assert [n["name"] for n in doc["nodes"][3:]] == ["hand_end1", "hand_end2", "root_end"]
    assert read(tmp_path / "e.glb").skeleton == motion.skeleton


# ---------------------------------------------------------------------------------------------------------------
# Blender: a file Blender exported reads as Blender poses it, and Blender opens what motionrep writes
# ---------------------------------------------------------------------------------------------------------------
DATA = Path(__file__).parent / "data"


def _z_up_to_y_up(p) -> np.ndarray:
    p = np.asarray(p, dtype=np.float64)
    return np.stack([p[..., 0], p[..., 2], -p[..., 1]], axis=-1)


def test_blender_export_reads_as_blender_poses_it():
    """tests/data/blender_rig.glb: Blender 3.4's exporter with its defaults (made by make_blender_rig.py): an
    armature object moved, turned and scaled, bones with rest rotations, a skinned mesh, two actions."""
    expected = json.loads((DATA / "blender_rig.json").read_text())
    path = DATA / "blender_rig.glb"
    assert list_clips(path) == ["Hold", "Wave"]
    motion = read(path, clip="Wave")
    assert motion.skeleton.names == ("Hips", "Spine", "Head", "Arm.L", "Leg.L", "Leg.R")
    assert motion.fps == 30 and motion.num_frames == 31 and motion.skeleton.units == "m"
    pos = global_positions(motion)
    for frame, heads in expected["heads_z_up"].items():
        want = _z_up_to_y_up([heads[n] for n in motion.skeleton.names])
        assert np.abs(pos[int(frame), :len(want)] - want).max() < 1e-6  # metres; Blender works in float32
    hold = read(path, clip="Hold")
    assert hold.num_frames == 31 and np.ptp(global_positions(hold), axis=0).max() < 1e-6  # a held pose


BLENDER_IMPORT = '''
import bpy, json, sys
path, frames = sys.argv[-2], [int(f) for f in sys.argv[-1].split(",")]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=path)
arm = [o for o in bpy.data.objects if o.type == "ARMATURE"][0]
heads = {}
for f in frames:
    bpy.context.scene.frame_set(f)
    heads[f] = {b.name: list(arm.matrix_world @ b.head) for b in arm.pose.bones}
print("RESULT" + json.dumps({"bones": len(arm.data.bones), "actions": [a.name for a in bpy.data.actions],
                             "heads": heads}))
'''


@pytest.mark.skipif(not __import__("shutil").which("blender"), reason="Blender is not installed")
def test_blender_opens_what_motionrep_writes(tmp_path):
    import subprocess

    motion = synthetic_motion(humanoid_skeleton(), frames=49, fps=24.0)  # Blender's scene rate: frames match
    path = tmp_path / "walk.glb"
    write(motion, path)
    script = tmp_path / "import.py"
    script.write_text(BLENDER_IMPORT)
    run = subprocess.run(["blender", "-b", "--factory-startup", "--python", str(script), "--", str(path),
                          "0,24,48"], capture_output=True, text=True, timeout=300)
    result = json.loads(run.stdout.split("RESULT", 1)[1].splitlines()[0])
    assert result["bones"] == motion.num_joints + motion.skeleton.num_end_sites
    assert result["actions"] and "walk" in result["actions"][0]
    pos = global_positions(motion) * 0.01  # humanoid_skeleton is in cm: written at 0.01 m per unit
    for frame, heads in result["heads"].items():
        got = _z_up_to_y_up([heads[n] for n in motion.skeleton.names])
        # Blender poses in float32, composing matrices: 1e-5 of the height
        assert np.abs(got - pos[int(frame), :motion.num_joints]).max() < 1e-5 * 0.01 * character_height(
            motion.skeleton)


# ---------------------------------------------------------------------------------------------------------------
# on the command line
# ---------------------------------------------------------------------------------------------------------------
def test_command_line_converts_evaluates_and_describes_gltf(tmp_path):


    def run(*args):
        return run_cli_caught(*args)

    write(synthetic_motion(humanoid_skeleton(), frames=30), tmp_path / "walk.bvh")
    r = run("convert", tmp_path / "walk.bvh", tmp_path / "walk.glb")
    assert r.exit_code == 0, r.output
    r = run("evaluate", tmp_path / "walk.bvh", tmp_path / "walk.glb", "--json")
    assert r.exit_code == 0, r.output
    assert json.loads(r.output)["max_error_percent"] < 1e-4
    # a glTF file of several animations: --clip picks one, info lists them
    path = DATA / "blender_rig.glb"
    r = run("convert", path, tmp_path / "wave.bvh", "--clip", "Wave")
    assert r.exit_code == 0, r.output
    assert read(tmp_path / "wave.bvh").num_frames == 31
    r = run("convert", path, tmp_path / "x.bvh")
    assert r.exit_code == 2 and "use --clip NAME" in r.output
    r = run("info", path, "--json")
    assert r.exit_code == 0, r.output
    info = json.loads(r.output)
    assert info["format"] == "gltf" and [c["name"] for c in info["clips"]] == ["Hold", "Wave"]
    r = run("convert", path, tmp_path / "both")  # a directory: one file per animation
    assert r.exit_code == 0, r.output
    assert sorted(p.name for p in (tmp_path / "both").iterdir()) == ["Hold.bvh", "Wave.bvh"]
