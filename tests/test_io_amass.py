"""AMASS / SMPL-H in: a synthetic body model of SMPL-H's layout written here (licensed models are never shipped),
its regressed joints at the rest frame (1e-9), posed joints against SMPL's kinematic chain written out with scipy
(1e-9), a 2-minute 120 fps clip converted to BVH, and bad clips or body models (one line, exit 1, no output)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from motionrep import character_height, global_positions
from motionrep.errors import AMASSFormatError
from motionrep.io import read, write
from motionrep.io._amass import BODY_MODEL_ENV, SMPLH_JOINT_NAMES

from helpers import convert_fails_naming, run_cli_caught

#: SMPL-H's tree: 22 body joints, then five three-joint fingers on each wrist (left: 20, right: 21).
SMPLH_PARENTS = np.array([-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19]
                         + [p for wrist, first in ((20, 22), (21, 37))
                            for f in range(5) for p in (wrist, first + 3 * f, first + 3 * f + 1)])
BODY_JOINTS = np.array([  # metres, Y up: a T-posed body of SMPL's proportions
    [0, 0.9, 0], [0.08, 0.82, 0], [-0.08, 0.82, 0], [0, 1.0, -0.02], [0.1, 0.45, 0], [-0.1, 0.45, 0],
    [0, 1.13, 0], [0.09, 0.07, -0.03], [-0.09, 0.07, -0.03], [0, 1.18, 0.02], [0.11, 0.02, 0.1],
    [-0.11, 0.02, 0.1], [0, 1.4, 0], [0.07, 1.33, 0], [-0.07, 1.33, 0], [0, 1.5, 0.03], [0.17, 1.36, 0],
    [-0.17, 1.36, 0], [0.43, 1.36, -0.02], [-0.43, 1.36, -0.02], [0.68, 1.37, 0], [-0.68, 1.37, 0]])
VERTS_PER_JOINT = 4
BETAS = 16
#: A real (licensed) body model named by the environment, taken before the tests clear the variable.
REAL_MODEL = os.environ.get(BODY_MODEL_ENV) or None


def smplh_model(seed: int = 0) -> dict[str, np.ndarray]:
    """A body model with SMPL-H's keys and shapes for 52 joints: vertices around each joint, a regressor averaging
    them (rows summing to 1, as SMPL's), random shape directions; kintree_table as the real files store it
    (uint32 -1, 4294967295, for the root's parent)."""
    rng = np.random.default_rng(seed)
    joints = np.zeros((52, 3))
    joints[:22] = BODY_JOINTS
    for k in range(22, 52):  # fingers: 3 cm steps out of the wrist
        p = SMPLH_PARENTS[k]
        side = 1.0 if k < 37 else -1.0
        finger = ((k - 22) % 15) // 3
        joints[k] = joints[p] + ([side * 0.03, 0.0, 0.02 * (finger - 2)] if p in (20, 21) else [side * 0.03, 0, 0])
    V = 52 * VERTS_PER_JOINT
    template = np.repeat(joints, VERTS_PER_JOINT, axis=0) + rng.normal(0, 0.01, (V, 3))
    regressor = np.zeros((52, V))
    for k in range(52):
        w = rng.uniform(0.5, 1.5, VERTS_PER_JOINT)
        regressor[k, k * VERTS_PER_JOINT:(k + 1) * VERTS_PER_JOINT] = w / w.sum()
    kintree = np.stack([np.where(SMPLH_PARENTS < 0, 4294967295, SMPLH_PARENTS), np.arange(52)]).astype(np.int64)
    return {"v_template": template, "shapedirs": rng.normal(0, 0.01, (V, 3, BETAS)), "J_regressor": regressor,
            "kintree_table": kintree, "f": np.zeros((1, 3), np.int64), "posedirs": np.zeros((V, 3, 1))}


def amass_clip(frames: int = 30, fps: float = 120.0, seed: int = 1) -> dict[str, np.ndarray]:
    """An AMASS clip: frame 0 at rest with trans 0, then smooth random poses and travel."""
    rng = np.random.default_rng(seed)
    t = np.arange(frames)[:, None] / fps
    poses = 0.6 * np.sin(2 * np.pi * 0.7 * t + rng.uniform(0, 6, 156)) * rng.uniform(0, 1, 156)
    poses -= poses[:1]
    trans = np.concatenate([0.5 * t, 0.02 * np.sin(6 * t), 0.1 * t], axis=1)
    trans -= trans[:1]
    return {"poses": poses, "trans": trans, "betas": rng.normal(0, 1, BETAS), "gender": np.array("female"),
            "mocap_framerate": np.array(fps), "dmpls": np.zeros((frames, 8))}


def write_files(tmp_path: Path, clip: dict | None = None, model: dict | None = None) -> tuple[Path, Path]:
    np.savez(tmp_path / "model.npz", **(model or smplh_model()))
    np.savez(tmp_path / "clip.npz", **(clip or amass_clip()))
    return tmp_path / "clip.npz", tmp_path / "model.npz"


def smpl_posed_joints(model: dict, clip: dict) -> np.ndarray:
    """``(F, 52, 3)``: the body model's posed joints plus trans, SMPL's kinematic chain written out (shaped
    template, regressed joints, world transforms G_j = G_parent [R_j | J_j - J_parent])."""
    n = min(clip["betas"].size, model["shapedirs"].shape[2])
    shaped = model["v_template"] + model["shapedirs"][:, :, :n] @ clip["betas"][:n]
    J = model["J_regressor"] @ shaped
    F = clip["poses"].shape[0]
    R = Rotation.from_rotvec(clip["poses"].reshape(-1, 3)).as_matrix().reshape(F, 52, 3, 3)
    out = np.empty((F, 52, 3))
    G = np.empty((F, 52, 3, 3))
    for k in range(52):
        p = SMPLH_PARENTS[k]
        if p < 0:
            G[:, k], out[:, k] = R[:, k], J[k]
        else:
            G[:, k] = G[:, p] @ R[:, k]
            out[:, k] = out[:, p] + np.einsum("fij,j->fi", G[:, p], J[k] - J[p])
    return out + clip["trans"][:, None]


@pytest.fixture(autouse=True)
def no_model_in_the_environment(monkeypatch):
    """Each test sets the model it wants (the CLI's --body-model sets the variable: restored after each test)."""
    monkeypatch.setenv(BODY_MODEL_ENV, "")


def test_rest_frame_gives_the_regressed_joints(tmp_path):
    """Frame 0 (zero poses, zero trans): FK is J_regressor @ (v_template + shapedirs @ betas) within 1e-9 m."""
    clip, model = write_files(tmp_path)
    motion = read(clip, body_model=model)
    m, c = smplh_model(), amass_clip()
    want = m["J_regressor"] @ (m["v_template"] + m["shapedirs"] @ c["betas"])
    got = global_positions(motion)[0]
    assert np.abs(got - want).max() < 1e-9  # float64 sums in another order: rounding, not bits
    assert motion.skeleton.names == SMPLH_JOINT_NAMES and motion.skeleton.units == "m"
    assert motion.fps == 120.0 and motion.num_frames == 30
    assert (motion.skeleton.parents == SMPLH_PARENTS).all()


def test_posed_joints_are_the_body_models(tmp_path):
    """Every frame: the body model's posed joints plus trans, within 1e-9 m of SMPL's chain written out."""
    c, m = amass_clip(frames=50, seed=7), smplh_model(seed=3)
    clip, model = write_files(tmp_path, c, m)
    got = global_positions(read(clip, body_model=model))
    assert np.abs(got - smpl_posed_joints(m, c)).max() < 1e-9


def test_body_model_from_the_environment(tmp_path, monkeypatch):
    clip, model = write_files(tmp_path)
    with pytest.raises(AMASSFormatError, match="body_model=MODEL.npz"):
        read(clip)
    monkeypatch.setenv(BODY_MODEL_ENV, str(model))
    assert read(clip).num_joints == 52


def test_fewer_betas_in_the_model_and_other_rate_key(tmp_path):
    """A 10-beta model takes the first 10 betas (as SMPL's code does); AMASS's SMPL-X files spell the rate
    ``mocap_frame_rate``."""
    m = smplh_model()
    m["shapedirs"] = m["shapedirs"][:, :, :10]
    c = amass_clip()
    c["mocap_frame_rate"] = c.pop("mocap_framerate") * 0 + 60.0
    clip, model = write_files(tmp_path, c, m)
    motion = read(clip, body_model=model)
    assert motion.fps == 60.0
    assert np.abs(global_positions(motion) - smpl_posed_joints(m, c)).max() < 1e-9


def test_motionrep_npz_still_reads_as_motionrep(tmp_path):
    """motionrep's own NPZ is told from AMASS's by its keys."""
    clip, model = write_files(tmp_path)
    motion = read(clip, body_model=model)
    write(motion, tmp_path / "own.npz")
    back = read(tmp_path / "own.npz")
    assert np.array_equal(back.rotations, motion.rotations)


def test_cli_converts_two_minutes_at_120_fps_to_bvh(tmp_path):
    """A 2-minute 120 fps clip (14,400 frames) through `convert --body-model` to BVH: the BVH's FK is the body
    model's posed joints (BVH's shortest decimals read back: 1e-9 m).  Its time: benchmarks/amass.py."""

    c, m = amass_clip(frames=120 * 120, seed=2), smplh_model()
    clip, model = write_files(tmp_path, c, m)
    out = tmp_path / "clip.bvh"
    result = run_cli_caught("convert", str(clip), str(out), "--body-model", str(model))
    assert result.exit_code == 0, result.output
    back = read(out)
    assert back.num_frames == 14400 and back.fps == pytest.approx(120.0)
    # BVH lists joints depth first: SMPL-H's order is not, so the joints are matched by name
    index = [back.skeleton.names.index(n) for n in SMPLH_JOINT_NAMES]
    pos = global_positions(back)[:, index]
    assert np.abs(pos - smpl_posed_joints(m, c)).max() < 1e-9 * max(1.0, character_height(back.skeleton))


def _zip_member_truncated(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


BAD_CLIPS = {
    "poses of a 24-joint model": (lambda c, m: c.update(poses=c["poses"][:, :72]), "clip", "has 52 joints"),
    "trans of other length": (lambda c, m: c.update(trans=c["trans"][:-1]), "clip", "'trans'"),
    "no frame rate": (lambda c, m: c.pop("mocap_framerate"), "clip", "mocap_frame_rate"),
    "non-finite poses": (lambda c, m: c["poses"].__setitem__((3, 5), np.nan), "clip", "non-finite"),
    "text poses": (lambda c, m: c.update(poses=np.array(["a", "b"])), "clip", "numeric"),
    "pickled betas": (lambda c, m: c.update(betas=np.array([{"x": 1}], dtype=object)), "clip", "pickled"),
    "model without J_regressor": (lambda c, m: m.pop("J_regressor"), "model", "J_regressor"),
    "model regressor of other vertices": (lambda c, m: m.update(J_regressor=m["J_regressor"][:, :-4]), "model",
                                          "J_regressor"),
    "model tree out of order": (lambda c, m: m["kintree_table"].__setitem__((0, 5), 40), "model", "kintree_table"),
    "model with 24 joints": (lambda c, m: m.update(J_regressor=m["J_regressor"][:24],
                                                   kintree_table=m["kintree_table"][:, :24]), "clip", "24 joints"),
}


@pytest.mark.parametrize("case", list(BAD_CLIPS))
def test_bad_clip_or_body_model(case, tmp_path):
    """One line naming the file at fault (the clip or the body model), exit 1, nothing written."""
    change, culprit, words = BAD_CLIPS[case]
    c, m = amass_clip(), smplh_model()
    change(c, m)
    clip, model = write_files(tmp_path, c, m)
    named = clip if culprit == "clip" else model
    with pytest.raises(AMASSFormatError) as info:
        read(clip, body_model=model)
    assert str(info.value).startswith(f"{named}: ") and words in str(info.value), str(info.value)
    convert_fails_naming([clip, tmp_path / "out.bvh", "--body-model", model], named, tmp_path / "out.bvh")


@pytest.mark.parametrize("damage", ["truncated clip", "truncated model", "model not npz", "missing model"])
def test_damaged_files(damage, tmp_path):
    clip, model = write_files(tmp_path)
    named = clip if damage == "truncated clip" else model
    if damage == "truncated clip":
        _zip_member_truncated(clip)
    elif damage == "truncated model":
        _zip_member_truncated(model)
    elif damage == "model not npz":
        model.write_bytes(b"not a model\n")
    else:
        os.remove(model)
    convert_fails_naming([clip, tmp_path / "out.bvh", "--body-model", model], named, tmp_path / "out.bvh")


def test_no_body_model_on_the_command_line(tmp_path):

    clip, _ = write_files(tmp_path)
    out = tmp_path / "out.bvh"
    result = run_cli_caught("convert", str(clip), str(out))
    assert result.exit_code == 1 and f"Error: {clip}: is an AMASS clip" in result.output and "--body-model" in \
        result.output
    assert not out.exists()


@pytest.mark.skipif(not REAL_MODEL, reason=f"no real SMPL-H body model ({BODY_MODEL_ENV} unset; the licensed "
                    "files are never shipped)")
def test_real_body_model(tmp_path):
    """Where a licensed SMPL-H model is present (MOTIONREP_SMPLH_MODEL): a clip posed through it gives its posed
    joints (SMPL's chain written out) within 1e-9 m."""
    with np.load(REAL_MODEL) as m:
        model = {k: m[k] for k in ("v_template", "shapedirs", "J_regressor", "kintree_table")}
    c = amass_clip(frames=60)
    np.savez(tmp_path / "clip.npz", **c)
    motion = read(tmp_path / "clip.npz", body_model=REAL_MODEL)
    assert np.abs(global_positions(motion) - smpl_posed_joints(model, c)).max() < 1e-9


def test_other_commands_take_the_body_model(tmp_path):
    """`info` and `evaluate` read AMASS clips with --body-model too (the option every reading command has)."""

    clip, model = write_files(tmp_path)
    result = run_cli_caught("info", str(clip), "--body-model", str(model), "--json")
    assert result.exit_code == 0, result.output
    assert '"joints": 52' in result.output
    result = run_cli_caught("evaluate", str(clip), str(clip), "--body-model", str(model))
    assert result.exit_code == 0, result.output
