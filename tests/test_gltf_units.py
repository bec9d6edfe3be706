"""glTF at the right size: convert/decompress --scale and --units, the documented guess (a human 1-2.5 m tall,
one line saying what was assumed), and motionrep reading its own glTF back in the clip's own units."""

from __future__ import annotations

import json
import math
import struct

import numpy as np
import pytest

from helpers import real_params, run_cli_caught
from motionrep import Motion, Skeleton
from motionrep.errors import ValidationError
from motionrep.io import gltf_scale, read, read_bvh, write
from motionrep.model.kinematics import character_height


def _clip(height: float, units: str | None = None) -> Motion:
    """A 3-joint standing figure ``height`` units tall, 4 frames."""
    sk = Skeleton(("Hips", "Spine", "Head"), np.array([-1, 0, 1]),
                  np.array([[0, 0, 0], [0, 0.6, 0], [0, 0.4, 0]]) * height, units=units)
    F = 4
    return Motion(sk, 30.0, np.tile(sk.offsets[0], (F, 1)), np.tile([0, 0, 0, 1.0], (F, 3, 1)), np.zeros((F, 0, 3)))


def _armature_scale(path) -> float:
    data = path.read_bytes()
    n = struct.unpack("<I", data[12:16])[0]
    doc = json.loads(data[20:20 + n])
    arm = next(node for node in doc["nodes"] if "motionrep" in node.get("extras", {}))
    return arm["extras"]["motionrep"]["scale"]


@pytest.mark.parametrize("height, unit", [(1.75, "m"), (175.0, "cm"), (69.0, "in"), (1750.0, "mm")])
def test_the_guess_picks_the_unit_that_makes_a_human(height, unit):
    scale, note = gltf_scale(_clip(height))
    assert scale == {"m": 1.0, "cm": 0.01, "in": 0.0254, "mm": 0.001}[unit]
    assert note.startswith(f"assumed units {unit} ")


def test_the_guess_scales_to_1_8_m_when_no_unit_fits_and_stated_units_win():
    scale, note = gltf_scale(_clip(24.0))  # a CMU clip: 24 m in metres, 0.6 m in inches
    assert math.isclose(scale * 24.0, 1.8) and "no unit puts the character" in note
    assert gltf_scale(_clip(24.0, units="cm")) == (0.01, None)  # the file says: no guess, no note
    assert gltf_scale(_clip(24.0), units="in") == (0.0254, None)
    assert gltf_scale(_clip(24.0), scale=0.05) == (0.05, None)
    with pytest.raises(ValidationError, match="not both"):
        gltf_scale(_clip(24.0), scale=1.0, units="m")
    with pytest.raises(ValidationError, match="units must be one of"):
        gltf_scale(_clip(24.0), units="furlong")


def test_convert_units_scale_and_the_one_line_note(tmp_path):
    src = tmp_path / "walk.bvh"
    write(_clip(170.0), src)
    guessed = run_cli_caught("convert", str(src), str(tmp_path / "a.glb"))
    assert guessed.exit_code == 0, guessed.output
    notes = [line for line in guessed.stderr.splitlines() if line.startswith("note:")]
    assert len(notes) == 1 and "assumed units cm" in notes[0]
    assert _armature_scale(tmp_path / "a.glb") == 0.01
    given = run_cli_caught("convert", str(src), str(tmp_path / "b.glb"), "--units", "in")
    assert given.exit_code == 0 and "note:" not in given.stderr
    assert _armature_scale(tmp_path / "b.glb") == 0.0254
    run_cli_caught("convert", str(src), str(tmp_path / "c.glb"), "--scale", "0.5")
    assert _armature_scale(tmp_path / "c.glb") == 0.5
    for path in ("a.glb", "b.glb", "c.glb"):  # read back in the clip's own numbers, whatever the scale
        back = read(tmp_path / path)
        assert math.isclose(character_height(back.skeleton), 170.0, rel_tol=1e-12)
    for bad, message in ((["--units", "cm", "--scale", "1"], "not both"), (["--scale", "-1"], "positive"),):
        run = run_cli_caught("convert", str(src), str(tmp_path / "d.glb"), *bad)
        assert run.exit_code == 2 and message in run.output
        assert not (tmp_path / "d.glb").exists()
    run = run_cli_caught("convert", str(src), str(tmp_path / "d.npz"), "--units", "cm")
    assert run.exit_code == 2 and "applies only to glTF output" in run.output


def test_decompress_takes_the_same_options(tmp_path):
    src = tmp_path / "walk.bvh"
    write(_clip(170.0), src)
    assert run_cli_caught("compress", str(src), "-o", str(tmp_path / "w.mrc")).exit_code == 0
    run = run_cli_caught("decompress", str(tmp_path / "w.mrc"), "-o", str(tmp_path / "w.glb"), "--units",
                              "cm")
    assert run.exit_code == 0, run.output
    assert _armature_scale(tmp_path / "w.glb") == 0.01
    run = run_cli_caught("decompress", str(tmp_path / "w.mrc"), "-o", str(tmp_path / "g.glb"))
    assert "assumed units cm" in run.stderr and _armature_scale(tmp_path / "g.glb") == 0.01
    run = run_cli_caught("decompress", str(tmp_path / "w.mrc"), "-o", str(tmp_path / "w.bvh"), "--scale", "2")
    assert run.exit_code == 2 and "applies only to glTF output" in run.output


@pytest.mark.parametrize("path", real_params())
def test_every_real_clip_is_guessed_to_a_human_size(path):
    motion = read_bvh(path)
    scale, note = gltf_scale(motion)
    height = character_height(motion.skeleton) * scale
    assert 1.0 <= height <= 2.5, (path, height, note)
    assert note is not None  # BVH states no units: the note says what was assumed
