"""FBX in: Blender's FBX export of a BVH file read back by joint name (FK within 1e-4 % of the height), ASCII FBX
with rotation orders and pre-rotations checked against the FBX transform written out by hand, clips (anim
stacks), and malformed files (one line naming the file, exit 1, nothing written)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from motionrep import Motion, Skeleton, character_height, global_positions
from motionrep.errors import FBXFormatError
from motionrep.io import list_clips, read, read_bvh, write, write_bvh
from motionrep.model.kinematics import point_names
from motionrep.model.synthetic import synthetic_motion

from blender import run_blender
from helpers import SHARED_DATA, convert_fails_naming, real_params, run_cli_caught

pytest.importorskip("ufbx")

DATA = Path(__file__).resolve().parent / "data"
FBX = DATA / "blender_walk.fbx"
SCRIPT = DATA / "make_blender_fbx.py"
BLENDER = shutil.which("blender")
needs_blender = pytest.mark.skipif(BLENDER is None, reason="Blender is not installed (Debian: apt-get install blender)")

#: The promise of issue 23 for Blender's FBX export: every joint within 1e-4 % of the height (Blender poses in
#: float32: its exports land 2e-5 % .. 6e-5 % away, measured).
FBX_TOLERANCE = 1e-6


def walk_skeleton() -> Skeleton:
    """Seven joints, a different rotation order on each, end sites: small enough for a small FBX file."""
    orders = ("ZXY", "XYZ", "YZX", "ZYX", "YXZ", "XZY", "ZXY")
    names = ("Hips", "Spine", "Head", "LeftArm", "LeftForeArm", "RightUpLeg", "RightLeg")
    parents = np.array([-1, 0, 1, 1, 3, 0, 5])
    offsets = np.array([[0, 95, 0], [0, 20, 0], [0, 30, 2], [10, 25, 0], [25, 0, 0], [-9, -5, 0], [0, -42, 0]],
                       dtype=float)
    channels = tuple((("Xposition", "Yposition", "Zposition") if j == 0 else ()) + tuple(f"{a}rotation" for a in o)
                     for j, o in enumerate(orders))
    return Skeleton(names=names, parents=parents, offsets=offsets, channels=channels,
                    end_site_parents=np.array([2, 4, 6]), end_site_offsets=np.array([[0, 10.0, 0], [24.0, 0, 0],
                                                                                     [0, -40.0, 10.0]]), units="cm")


def walk_bvh(path: Path) -> Motion:
    """Write the BVH that tests/data/blender_walk.fbx was made from (deterministic) and read it back."""
    write_bvh(synthetic_motion(walk_skeleton(), frames=12, fps=24.0, seed=5, cycles=1.0), path)
    return read_bvh(path)


def by_name_error(reference: Motion, candidate: Motion) -> tuple[float, int]:
    """Largest distance between the reference's and the candidate's joints of the same name, as a fraction of the
    reference's height, and how many joints were compared; every reference joint must be in the candidate and
    the frame counts must agree (end sites are not compared: Blender turns them into bone tails)."""
    assert reference.num_frames == candidate.num_frames
    names = list(point_names(candidate.skeleton))
    index = [names.index(n) for n in reference.skeleton.names]
    a = global_positions(reference)[:, :reference.num_joints]
    b = global_positions(candidate)[:, index]
    return float(np.abs(a - b).max() / character_height(reference.skeleton)), len(index)


def blender_fbx(bvh: Path, fbx: Path, pose: Path | None = None) -> None:
    """make_blender_fbx.py in Blender (tests/blender.py's runner: a timeout, a failure with Blender's output)."""
    run_blender(SCRIPT.read_text(encoding="utf-8"), bvh, fbx, *([pose] if pose is not None else []), timeout=1200)
    assert fbx.is_file()


def blender_pose_error(reference: Motion, pose: Path) -> float:
    """Blender's own pose of the imported BVH (make_blender_fbx.py's POSE.json, float32) against the BVH, as a
    fraction of the height: the floor under any file Blender exports."""
    frames = json.loads(pose.read_text())
    assert len(frames) == reference.num_frames
    names = [n for n in reference.skeleton.names if n in frames[0]]
    index = [reference.skeleton.names.index(n) for n in names]
    heads = np.array([[frame[n] for n in names] for frame in frames])
    error = np.abs(global_positions(reference)[:, index] - heads).max()
    return float(error / character_height(reference.skeleton))


def test_blender_fbx_reads_as_the_bvh_it_came_from(tmp_path):
    """tests/data/blender_walk.fbx is Blender 3.4's export (make_blender_fbx.py) of walk_bvh: every joint, found
    by name, within 1e-4 % of the height on every frame, at the BVH's frame rate."""
    bvh = walk_bvh(tmp_path / "walk.bvh")
    motion = read(FBX)
    assert set(motion.skeleton.names) == set(bvh.skeleton.names)
    assert motion.fps == pytest.approx(24.0) and motion.num_frames == 12
    error, compared = by_name_error(bvh, motion)
    assert compared == 7 and error < FBX_TOLERANCE, error
    assert motion.skeleton.units == "m"  # Blender's unit (FBX_SCALE_UNITS: one BVH unit = one metre)
    assert list_clips(FBX) == ["Scene"]
    assert FBX.stat().st_size < 100_000


def test_fbx_through_bvh_and_back(tmp_path):
    """What motionrep reads from an FBX file it writes as BVH (the file's rotation order as channel order) and
    reads back with the same FK (BVH's 6 decimals: 1e-6 of the height)."""
    motion = read(FBX)
    write(motion, tmp_path / "out.bvh")
    back = read(tmp_path / "out.bvh")
    assert back.skeleton.names == motion.skeleton.names
    error = np.abs(global_positions(back) - global_positions(motion)).max() / character_height(motion.skeleton)
    assert error < 1e-6


@needs_blender
def test_make_blender_fbx_makes_the_test_file(tmp_path):
    """make_blender_fbx.py gives, again, a file that reads as tests/data/blender_walk.fbx."""
    bvh = walk_bvh(tmp_path / "walk.bvh")
    blender_fbx(tmp_path / "walk.bvh", tmp_path / "walk.fbx")
    again = read(tmp_path / "walk.fbx")
    error, _ = by_name_error(bvh, again)
    assert error < FBX_TOLERANCE
    # Blender works in float32: the file made now and the one kept agree within its rounding, not bit for bit
    assert np.abs(global_positions(again) - global_positions(read(FBX))).max() < 1e-4


@pytest.mark.realdata
@pytest.mark.slow
@needs_blender
@pytest.mark.parametrize("path", real_params())
def test_blender_fbx_export_of_real_clips(path, tmp_path):
    """Blender's FBX export of every real clip reads back, joint by joint by name, within 1e-4 % of the height of
    the source BVH (issue 23's target) -- or, where Blender's own float32 pose of the imported BVH already misses
    it (BVHFiles.jl's Example.bvh: 2.9e-4 %), within 1e-4 % of the height beyond Blender's own error: what is
    measured is then motionrep's reading, not Blender's arithmetic."""
    fbx, pose = tmp_path / "clip.fbx", tmp_path / "pose.json"
    blender_fbx(path, fbx, pose)
    reference = read_bvh(path)
    error, compared = by_name_error(reference, read(fbx))
    floor = blender_pose_error(reference, pose)
    where = f"{path.relative_to(SHARED_DATA)}: {100 * error:.3g} % (Blender's own pose: {100 * floor:.3g} %)"
    assert compared == reference.num_joints
    assert error < FBX_TOLERANCE or error < floor + FBX_TOLERANCE, where


# ASCII FBX written here: a chain whose nodes have rotation orders, pre- and post-rotations, an armature node
# above the top bone, two anim stacks; the expected FK is the FBX transform written out independently with scipy
# (R = PreRotation * Euler(RotationOrder) * PostRotation^-1, PreRotation and PostRotation in XYZ order).

KTIME = 46186158000  # FBX ticks per second
ORDER_NAMES = ("XYZ", "XZY", "YZX", "YXZ", "ZXY", "ZYX")


def fbx_matrix(angles, order: str) -> np.ndarray:
    """FBX's Euler rotation: turn about the first axis of ``order`` first, in the parent's frame (extrinsic)."""
    values = [angles["XYZ".index(a)] for a in order]
    return Rotation.from_euler(order.lower(), values, degrees=True).as_matrix()


CHAIN = [  # name, parent, translation, rotation order, pre-rotation, post-rotation
    ("Armature", None, (5.0, 0.0, -3.0), 0, (-90.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
    ("Pelvis", "Armature", (0.0, 0.0, 90.0), 4, (10.0, 20.0, 30.0), (0.0, 0.0, 0.0)),
    ("Chest", "Pelvis", (0.0, 30.0, 0.0), 2, (0.0, 0.0, 45.0), (5.0, -10.0, 0.0)),
    ("Neck", "Chest", (0.0, 25.0, 1.0), 5, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
    ("Arm", "Chest", (12.0, 20.0, 0.0), 3, (0.0, 90.0, 0.0), (0.0, 0.0, 0.0)),
]


def chain_angles(stack: int, frames: int) -> dict[str, np.ndarray]:
    t = np.arange(frames)[:, None]
    return {name: (stack + 1) * 20.0 * np.sin(0.3 * t + np.array([k, 2 * k + 1, 3 * k + 2]))
            for k, (name, *_rest) in enumerate(CHAIN) if name != "Armature"}


def ascii_fbx(frames: int = 10, fps: int = 30, stacks: int = 2) -> str:
    """An ASCII FBX 7.4 file of CHAIN, Y up, centimetres, animated rotations (and the pelvis' translation)."""
    ids = {name: 1000 + k for k, (name, *_rest) in enumerate(CHAIN)}
    objects, links = [], []
    for name, parent, t, order, pre, post in CHAIN:
        kind = "Null" if name == "Armature" else "LimbNode"
        objects.append(f'''	Model: {ids[name]}, "Model::{name}", "{kind}" {{
		Version: 232
		Properties70:  {{
			P: "RotationOrder", "enum", "", "",{order}
			P: "RotationActive", "bool", "", "",1
			P: "PreRotation", "Vector3D", "Vector", "",{pre[0]},{pre[1]},{pre[2]}
			P: "PostRotation", "Vector3D", "Vector", "",{post[0]},{post[1]},{post[2]}
			P: "Lcl Translation", "Lcl Translation", "", "A",{t[0]},{t[1]},{t[2]}
		}}
	}}''')
        if kind == "LimbNode":
            objects.append(f'''	NodeAttribute: {ids[name] + 500}, "NodeAttribute::{name}", "LimbNode" {{
		TypeFlags: "Skeleton"
	}}''')
            links.append(f'	C: "OO",{ids[name] + 500},{ids[name]}')
        links.append(f'	C: "OO",{ids[name]},{ids[parent] if parent else 0}')
    times = ",".join(str(k * KTIME // fps) for k in range(frames))
    next_id = 5000
    for s in range(stacks):
        angles = chain_angles(s, frames)
        stack, layer = next_id, next_id + 1
        next_id += 2
        objects.append(f'''	AnimationStack: {stack}, "AnimStack::Take{s + 1}", "" {{
		Properties70:  {{
			P: "LocalStart", "KTime", "Time", "",0
			P: "LocalStop", "KTime", "Time", "",{(frames - 1) * KTIME // fps}
		}}
	}}
	AnimationLayer: {layer}, "AnimLayer::Base{s}", "" {{
	}}''')
        links.append(f'	C: "OO",{layer},{stack}')
        curves = [(name, "Lcl Rotation", angles[name]) for name in angles]
        curves.append(("Pelvis", "Lcl Translation", np.stack([np.linspace(0, 9, frames), np.full(frames, 90.0) +
                                                             np.sin(np.arange(frames)), np.zeros(frames)], 1)))
        for name, prop, values in curves:
            node = next_id
            next_id += 1
            objects.append(f'''	AnimationCurveNode: {node}, "AnimCurveNode::{prop[4]}", "" {{
	}}''')
            links.append(f'	C: "OO",{node},{layer}')
            links.append(f'	C: "OP",{node},{ids[name]}, "{prop}"')
            for axis in range(3):
                curve = next_id
                next_id += 1
                keys = ",".join(repr(float(v)) for v in values[:, axis])
                objects.append(f'''	AnimationCurve: {curve}, "AnimCurve::", "" {{
		Default: 0
		KeyVer: 4009
		KeyTime: *{frames} {{
			a: {times}
		}}
		KeyValueFloat: *{frames} {{
			a: {keys}
		}}
		KeyAttrFlags: *1 {{
			a: 24836
		}}
		KeyAttrDataFloat: *4 {{
			a: 0,0,218434821,0
		}}
		KeyAttrRefCount: *1 {{
			a: {frames}
		}}
	}}''')
                links.append(f'	C: "OP",{curve},{node}, "d|{"XYZ"[axis]}"')
    return "\n".join([
        "; FBX 7.4.0 project file",
        "FBXHeaderExtension:  {", "	FBXHeaderVersion: 1003", "	FBXVersion: 7400", "}",
        "GlobalSettings:  {", "	Version: 1000", "	Properties70:  {",
        '		P: "UpAxis", "int", "Integer", "",1', '		P: "UpAxisSign", "int", "Integer", "",1',
        '		P: "FrontAxis", "int", "Integer", "",2', '		P: "FrontAxisSign", "int", "Integer", "",1',
        '		P: "CoordAxis", "int", "Integer", "",0', '		P: "CoordAxisSign", "int", "Integer", "",1',
        '		P: "UnitScaleFactor", "double", "Number", "",1', '		P: "TimeMode", "enum", "", "",6',
        "	}", "}",
        "Objects:  {", *objects, "}",
        "Connections:  {", *links, "}", ""])


def expected_chain_positions(stack: int, frames: int) -> dict[str, np.ndarray]:
    """World positions of CHAIN's nodes per frame, from the FBX transform written out with scipy (ufbx reads an
    ASCII file's keys as the decimals written, not rounded to float32)."""
    angles = chain_angles(stack, frames)
    pelvis_t = np.stack([np.linspace(0, 9, frames), np.full(frames, 90.0) + np.sin(np.arange(frames)),
                         np.zeros(frames)], 1)
    out = {}
    for f in range(frames):
        world: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        for name, parent, t, order, pre, post in CHAIN:
            euler = angles[name][f] if name in angles else (0.0, 0.0, 0.0)
            R = fbx_matrix(pre, "XYZ") @ fbx_matrix(euler, ORDER_NAMES[order]) @ fbx_matrix(post, "XYZ").T
            T = pelvis_t[f] if name == "Pelvis" else np.array(t)
            if parent is None:
                world[name] = (R, T)
            else:
                PR, PT = world[parent]
                world[name] = (PR @ R, PT + PR @ T)
            out.setdefault(name, np.empty((frames, 3)))[f] = world[name][1]
    return out


def test_ascii_fbx_rotation_orders_and_pre_rotations(tmp_path):
    """ASCII FBX 7.4: rotation orders, pre- and post-rotations and an armature node above the top bone give the
    positions FBX's transform gives (within 1e-9 of the height: two float64 computations of the same
    products)."""
    path = tmp_path / "chain.fbx"
    path.write_text(ascii_fbx())
    assert list_clips(path) == ["Take1", "Take2"]
    with pytest.raises(FBXFormatError, match="2 anim stacks; choose one with clip=NAME"):
        read(path)
    for s, clip in enumerate(("Take1", "Take2")):
        motion = read(path, clip=clip)
        assert motion.skeleton.names == ("Pelvis", "Chest", "Neck", "Arm")  # the Null above is folded in
        assert motion.fps == 30.0 and motion.num_frames == 10 and motion.skeleton.units == "cm"  # UnitScaleFactor 1
        # FBX order ZXY turns about Z, then X, then Y: R = Ry Rx Rz, motionrep's (intrinsic) "YXZ"
        assert motion.skeleton.rotation_orders == ("YXZ", "XZY", "XYZ", "ZXY")
        want = expected_chain_positions(s, 10)
        got = global_positions(motion)
        height = character_height(motion.skeleton)
        for k, name in enumerate(motion.skeleton.names):
            assert np.abs(got[:, k] - want[name]).max() < 1e-9 * height, name
    with pytest.raises(FBXFormatError, match="no anim stack 'Walk'"):
        read(path, clip="Walk")


def test_cli_converts_fbx(tmp_path):

    path = tmp_path / "chain.fbx"
    path.write_text(ascii_fbx())
    out = tmp_path / "take2.bvh"
    result = run_cli_caught("convert", str(path), str(out), "--clip", "Take2")
    assert result.exit_code == 0, result.output
    assert np.abs(global_positions(read(out)) - global_positions(read(path, clip="Take2"))).max() < 1e-4
    result = run_cli_caught("convert", str(out), str(tmp_path / "x.fbx"))
    assert result.exit_code == 2 and "does not write it" in result.output
    with pytest.raises(FBXFormatError, match="does not write"):
        write(read(out), tmp_path / "x.fbx")
    assert not (tmp_path / "x.fbx").exists()


def malformed_cases() -> dict[str, bytes]:
    good = FBX.read_bytes()
    text = ascii_fbx(stacks=1)
    return {
        "truncated binary": good[: len(good) // 3],
        "binary header only": good[:27],
        "garbage": bytes(np.random.default_rng(0).integers(0, 256, 4000, dtype=np.uint8)),
        "empty": b"",
        "text that is not FBX": b"hello, world\n" * 10,
        "truncated ASCII": text[: len(text) // 2].encode(),
        "no skeleton": text.replace('"LimbNode"', '"Null"').encode(),
        "scaled joint": text.replace('P: "RotationActive", "bool", "", "",1',
                                     'P: "RotationActive", "bool", "", "",1\n'
                                     '			P: "Lcl Scaling", "Lcl Scaling", "", "A",1,2,1', 2).encode(),
    }


MALFORMED = ("truncated binary", "binary header only", "garbage", "empty", "text that is not FBX", "truncated ASCII",
             "no skeleton", "scaled joint")


def test_malformed_cases_are_all_run():
    assert tuple(malformed_cases()) == MALFORMED


@pytest.mark.parametrize("case", MALFORMED)
def test_malformed_fbx(case, tmp_path):
    """A malformed FBX: FBXFormatError naming the file; from the command line one line, exit 1, no output."""
    src = tmp_path / "bad.fbx"
    src.write_bytes(malformed_cases()[case])
    with pytest.raises(FBXFormatError) as info:
        read(src)
    assert str(info.value).startswith(f"{src}: ") and "\n" not in str(info.value)
    out = tmp_path / "out.bvh"
    convert_fails_naming([src, out], src, out)
    assert list(tmp_path.iterdir()) == [src]


def test_missing_fbx(tmp_path):
    with pytest.raises(FBXFormatError, match="(?i)no such file"):
        read(tmp_path / "absent.fbx")


def test_without_ufbx_one_line_says_what_to_install(tmp_path, monkeypatch):
    """Without the fbx extra: FBXFormatError naming the file and the extra (ufbx is imported only to read FBX)."""
    import sys

    monkeypatch.setitem(sys.modules, "ufbx", None)  # import ufbx then raises ImportError
    with pytest.raises(FBXFormatError, match=r"motionrep\[fbx\]") as info:
        read(FBX)
    assert str(info.value).startswith(f"{FBX}: ")
