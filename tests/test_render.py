"""``motionrep render`` and :mod:`motionrep.present.render`: stick-figure GIFs and PNG filmstrips.

Everything is drawn on matplotlib's Agg canvas (no window, no pyplot).  Pictures are kept small and short so
the whole file runs in a few seconds.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("matplotlib")
Image = pytest.importorskip("PIL.Image")

from motionrep.present import render as rmod  # noqa: E402
from motionrep.present.render import draw as render_draw, frames as render_frames, scene as render_scene  # noqa: E402
from motionrep.present.render import strip as render_strip  # noqa: E402
from motionrep.errors import FormatError, MotionrepError, ValidationError  # noqa: E402
from motionrep.pipeline.evaluate import max_joint_error  # noqa: E402
from motionrep.io import read, write  # noqa: E402
from motionrep.model.kinematics import global_positions  # noqa: E402
from motionrep.model.rotations import axis_angle_to_quat, quat_multiply  # noqa: E402
from motionrep.model.synthetic import chain_skeleton, humanoid_skeleton, synthetic_motion  # noqa: E402

from helpers import SHARED_DATA, one_line_error, requires_shared, run_cli, run_cli_caught  # noqa: E402

FRAMES, FPS, BUMP_FRAME, JOINT = 40, 30.0, 23, "LeftForeArm"
SMALL = (240, 200)


run = run_cli  # helpers.run_cli: the one CLI runner of the tests


def _perturbed(motion, joint: str, frame: int, radians: float = 0.5):
    """``motion`` with one joint turned about its local Z, most at ``frame`` (a smooth bump)."""
    j = motion.skeleton.index(joint)
    t = np.arange(motion.num_frames)
    angle = radians * np.exp(-0.5 * ((t - frame) / 3.0) ** 2)
    turn = axis_angle_to_quat(np.stack([np.zeros_like(angle), np.zeros_like(angle), angle], axis=-1))
    rot = motion.rotations.copy()
    rot[:, j] = quat_multiply(rot[:, j], turn)
    return motion.replace(rotations=rot, euler_branch=None)


@pytest.fixture(scope="module")
def pair():
    ref = synthetic_motion(humanoid_skeleton(), frames=FRAMES, fps=FPS, seed=5)
    return ref, _perturbed(ref, JOINT, BUMP_FRAME)


@pytest.fixture
def files(tmp_path, pair):
    ref_path, cand_path = tmp_path / "ref.bvh", tmp_path / "cand.bvh"
    write(pair[0], ref_path)
    write(pair[1], cand_path)
    return ref_path, cand_path


def _colour_pixels(path: Path) -> dict[str, int]:
    """How many pixels are clearly red, clearly blue, and near black."""
    rgb = np.asarray(Image.open(path).convert("RGB")).astype(int)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    return {
        "red": int(np.sum((r > 180) & (g < 120) & (b < 120))),
        "blue": int(np.sum((b > 160) & (r < 90) & (g < 130))),
        "black": int(np.sum((r < 60) & (g < 60) & (b < 60))),
    }


def _one_line_error(result, code: int, *needles: str) -> str:
    return one_line_error(result, *needles, code=code)


def _no_output_left(directory: Path, name: str) -> None:
    assert not (directory / name).exists()
    assert not [p for p in directory.iterdir() if p.name.startswith(f".{name}.")], list(directory.iterdir())


# ---- the pictures -----------------------------------------------------------------------------------------------

def test_gif_has_the_expected_frames_rate_and_size(tmp_path, files):
    out = tmp_path / "cmp.gif"
    result = run("render", *files, "-o", out, "--size", "240x200")
    assert result.exit_code == 0, result.output
    assert f"wrote {out}" in result.output and f"{JOINT}/End Site" in result.output
    with Image.open(out) as im:
        assert im.format == "GIF"
        assert im.size == SMALL
        # 40 frames at 30 fps played in real time at 25 fps: frames at t = k / 25 s for t <= 39 / 30 s
        assert im.n_frames == int(np.floor(39 * 25 / 30)) + 1 == 33
        assert im.info["duration"] == 40  # ms: 25 fps
        im.seek(BUMP_FRAME * 25 // 30)
        middle = out.with_name("middle.png")
        im.convert("RGB").save(middle)
    pixels = _colour_pixels(middle)
    assert pixels["red"] > 50 and pixels["blue"] > 50 and pixels["black"] > 30, pixels


def test_gif_frames_follow_an_explicit_step_and_fps(tmp_path, pair):
    ref, cand = pair
    result = rmod.render(tmp_path / "s.gif", ref, cand, frames="4:30:3", fps=10, size=SMALL)
    assert result.frames == tuple(range(4, 30, 3))
    assert result.fps == 10
    with Image.open(result.path) as im:
        assert im.n_frames == len(result.frames)
        assert im.info["duration"] == 100


def test_png_filmstrip_size_colours_and_worst_frame(tmp_path, files):
    out = tmp_path / "strip.png"
    result = run("render", *files, "-o", out, "--count", "4", "--size", "640x400")
    assert result.exit_code == 0, result.output
    with Image.open(out) as im:
        assert im.format == "PNG"
        assert im.size == (640, 400)
    pixels = _colour_pixels(out)
    assert pixels["red"] > 200 and pixels["blue"] > 200 and pixels["black"] > 100, pixels
    assert "4 pictures" in result.output


def test_filmstrip_default_size_and_panels(tmp_path, pair):
    ref, cand = pair
    result = rmod.render(tmp_path / "d.png", ref, cand, count=6)
    assert len(result.frames) == 6
    assert BUMP_FRAME in result.frames  # the worst frame replaces the nearest evenly spaced one
    assert result.frames[0] == 0 and result.frames[-1] == FRAMES - 1
    with Image.open(result.path) as im:
        assert im.size == result.size
        assert 300 <= im.size[0] <= 2000 and 300 <= im.size[1] <= 2000


def test_worst_joint_is_the_perturbed_one_and_matches_the_shared_measure(tmp_path, pair):
    ref, cand = pair
    result = rmod.render(tmp_path / "w.png", ref, cand, count=2, size=(320, 200))
    report = result.error
    assert report.joint == f"{JOINT}/End Site"  # the forearm turned: its end site moved furthest
    assert report.frame == BUMP_FRAME
    shared = max_joint_error(ref, cand)
    assert (report.max_error, report.frame, report.joint) == (shared.max_error, shared.frame, shared.joint)
    assert "% of height" in rmod.describe_error(report) and JOINT in rmod.describe_error(report)


def test_reference_alone(tmp_path, pair):
    result = rmod.render(tmp_path / "one.png", pair[0], count=3, size=(400, 240))
    assert result.error is None and len(result.frames) == 3
    pixels = _colour_pixels(result.path)
    assert pixels["red"] > 100 and pixels["blue"] == 0


def test_candidate_at_another_rate_is_resampled_by_time(tmp_path, pair):
    ref = synthetic_motion(humanoid_skeleton(), frames=61, fps=60.0, seed=2, cycles=1.0)
    half = ref.frames(slice(0, None, 2)).replace(fps=30.0)  # same clip, every other frame, same last frame
    result = rmod.render(tmp_path / "h.png", ref, half, count=2, size=(320, 200))
    assert any("resampled" in note for note in result.notes)
    assert result.error.frame % 2 == 1  # the frames both clips share are exact
    held = half.frames(np.arange(61) // 2).replace(fps=60.0)  # each frame held twice instead
    assert result.error.max_error < 0.5 * max_joint_error(ref, held).max_error
    assert result.error.max_error_percent < 2
    short = ref.frames(slice(0, 20, 2)).replace(fps=FPS / 2)
    with pytest.raises(ValidationError, match="same time"):
        rmod.render(tmp_path / "x.png", ref, short)
    _no_output_left(tmp_path, "x.png")


def test_mrc_input(tmp_path, files):
    from motionrep.pipeline.compress import compress_file

    ref_path, _ = files
    mrc = tmp_path / "ref.mrc"
    compress_file(ref_path, mrc, "svd", max_error="5%")
    out = tmp_path / "mrc.png"
    result = run("render", ref_path, mrc, "-o", out, "--count", "2", "--size", "320x200")
    assert result.exit_code == 0, result.output
    assert Image.open(out).size == (320, 200)
    assert "worst joint" in result.output


# ---- errors: one line, exit code, nothing written ----------------------------------------------------------------

@pytest.mark.parametrize("bad", ["abc", "1:2:0", "1:5:-1", "1:2:3:4", "a:b"])
def test_malformed_frames_is_a_usage_error(tmp_path, files, bad):
    result = run("render", *files, "-o", tmp_path / "x.gif", "--frames", bad)
    assert result.exit_code == 2, result.output
    assert "--frames" in result.output
    _no_output_left(tmp_path, "x.gif")


@pytest.mark.parametrize("empty", ["100:", "10:5", "-1:-3"])
def test_frames_selecting_nothing(tmp_path, files, empty):
    result = run("render", *files, "-o", tmp_path / "x.png", "--frames", empty)
    _one_line_error(result, 1, "selects no frames", f"{FRAMES}", "ref.bvh")
    _no_output_left(tmp_path, "x.png")


def test_parse_frames_is_python_slicing():
    assert rmod.parse_frames("3:9") == slice(3, 9, None)
    assert rmod.parse_frames(":9:2") == slice(None, 9, 2)
    assert rmod.parse_frames("-5:") == slice(-5, None, None)
    assert rmod.parse_frames("7") == slice(7, 8)
    assert rmod.parse_frames("-1") == slice(-1, None)
    idx, exact = render_frames.select_frames("-5:", 40, "clip")
    assert idx.tolist() == [35, 36, 37, 38, 39] and not exact


def test_mismatched_skeletons(tmp_path, files):
    other = tmp_path / "chain.bvh"
    write(synthetic_motion(chain_skeleton(4), frames=FRAMES, fps=FPS), other)
    result = run("render", files[0], other, "-o", tmp_path / "x.gif")
    _one_line_error(result, 1, "do not share a skeleton", "ref.bvh", "chain.bvh")
    _no_output_left(tmp_path, "x.gif")


def test_same_rate_different_length_is_refused(pair):
    ref, cand = pair
    with pytest.raises(ValidationError, match="40 frames .* 30"):
        rmod.align_candidate(ref, cand.frames(slice(0, 30)), "a", "b")


def test_mp4_without_ffmpeg(tmp_path, files, monkeypatch):
    from matplotlib import animation

    monkeypatch.setattr(animation.writers, "is_available", lambda name: False)
    result = run("render", *files, "-o", tmp_path / "x.mp4")
    _one_line_error(result, 1, "ffmpeg", ".gif", "x.mp4")
    _no_output_left(tmp_path, "x.mp4")


def test_unknown_output_suffix(tmp_path, files):
    result = run("render", *files, "-o", tmp_path / "x.jpg")
    assert result.exit_code == 2 and ".gif" in result.output
    with pytest.raises(FormatError, match="x.jpg"):
        rmod.check_output(tmp_path / "x.jpg")


def test_bad_rate_and_size(tmp_path, files, pair):
    result = run("render", *files, "-o", tmp_path / "x.gif", "--fps", "60")
    _one_line_error(result, 1, "50 fps")
    result = run("render", *files, "-o", tmp_path / "x.gif", "--size", "12x12")
    assert result.exit_code == 2 and "--size" in result.output
    with pytest.raises(ValidationError):
        rmod.render(tmp_path / "x.gif", *pair, fps=0)
    _no_output_left(tmp_path, "x.gif")


def test_missing_matplotlib_is_one_clear_error(tmp_path, pair, monkeypatch):
    monkeypatch.setitem(sys.modules, "matplotlib.backends.backend_agg", None)  # import fails
    with pytest.raises(MotionrepError, match=r"matplotlib.*pip install matplotlib"):
        rmod.render(tmp_path / "x.png", *pair)
    _no_output_left(tmp_path, "x.png")


def test_failure_while_drawing_leaves_no_file(tmp_path, pair, monkeypatch):
    def boom(self, frame):
        raise RuntimeError("drawing failed")

    monkeypatch.setattr(render_draw.Panel, "show", boom)
    with pytest.raises(RuntimeError):
        rmod.render(tmp_path / "x.gif", *pair, size=SMALL)
    _no_output_left(tmp_path, "x.gif")


# ---- frame choice, camera and up axis -------------------------------------------------------------------------

def test_long_clip_stays_within_max_frames_in_real_time():
    selected = np.arange(2242)
    shown, rate, notes = render_frames.animation_frames(selected, False, 120.0, None, 150, ".gif")
    assert shown.size <= 150 and notes
    assert 100 / rate == round(100 / rate)  # a whole number of centiseconds per frame
    assert abs(shown.size / rate - 2242 / 120) < 2 / rate  # plays as long as the clip
    assert np.all(np.diff(shown) > 0)
    shown, rate, notes = render_frames.animation_frames(np.arange(344), False, 120.0, None, 150, ".gif")
    assert rate == 25 and shown.size == 72 and not notes
    with pytest.raises(ValidationError, match="more than max_frames=150: use a larger step or raise max_frames"):
        render_frames.animation_frames(np.arange(0, 400, 2), True, 120.0, None, 150, ".gif")


def test_up_axis_detection(pair):
    pos = global_positions(pair[0])
    assert rmod.detect_up_axis(pos) == "y"
    z_up = np.stack([pos[..., 0], -pos[..., 2], pos[..., 1]], axis=-1)  # the same clip turned Z-up
    assert rmod.detect_up_axis(z_up) == "z"
    assert rmod.detect_up_axis(z_up[:1]) == "z"  # one frame: decided by the body's extent


def test_equal_scale_in_screen_space(pair):
    """The fixed orthographic camera draws every bone at most its length, the same scale in every frame."""
    ref = pair[0]
    pos = global_positions(ref)
    bones = rmod.bone_segments(ref)
    scene = render_scene.build_scene(pos, None, bones, "y", np.arange(ref.num_frames), 170.0, ref.fps)
    true = np.linalg.norm(pos[:, bones[:, 0]] - pos[:, bones[:, 1]], axis=-1)
    drawn = np.linalg.norm(scene.ref[:, bones[:, 0]] - scene.ref[:, bones[:, 1]], axis=-1)
    assert np.all(drawn <= true + 1e-9)
    # some bone in some frame lies almost in the picture plane and keeps its whole length
    assert np.max(drawn / true) > 0.98
    assert scene.aspect > 0


# ---- what a new user noticed (issue 16) -------------------------------------------------------------------------

@pytest.mark.parametrize("worst", [0, 1, 13, 118, 298, 299])
@pytest.mark.parametrize("kind", [".gif", ".mp4"])
def test_the_worst_frame_is_always_among_the_frames_shown(worst, kind):
    """30 fps shown at 25 fps (and a 300-frame clip at 150 --max-frames) skips frames: never the worst one."""
    shown, rate, notes = render_frames.animation_frames(np.arange(300), False, 30.0, None, 150, kind, worst)
    assert worst in shown and len(shown) <= 150 and list(shown) == sorted(set(shown.tolist()))
    assert 0 < rate < 30.0 and not any("worst" in n for n in notes)


def test_the_worst_frame_is_in_the_animation_written(tmp_path):
    """The same end to end, through the GIF written (one case: rendering 150 frames takes seconds)."""
    worst = 13
    ref = synthetic_motion(humanoid_skeleton(), frames=300, fps=30.0, seed=2)
    cand = _perturbed(ref, JOINT, worst, radians=0.8)
    result = rmod.render(tmp_path / "w.gif", ref, cand, size=SMALL)
    assert result.error.frame == worst and worst in result.frames
    assert len(result.frames) <= 150 and list(result.frames) == sorted(set(result.frames))
    with Image.open(result.path) as im:
        assert im.n_frames == len(result.frames)


def test_an_explicit_selection_says_when_it_leaves_out_the_worst_frame(tmp_path, pair):
    ref, cand = pair
    result = rmod.render(tmp_path / "s.gif", ref, cand, frames="0:40:10", size=SMALL)
    assert result.frames == (0, 10, 20, 30)
    assert any(f"worst frame, {BUMP_FRAME}" in n for n in result.notes)


def test_default_animation_is_screen_sized_and_follows_a_long_walk(tmp_path):
    ref = synthetic_motion(humanoid_skeleton(), frames=150, fps=30.0, seed=1)
    travel = ref.root_translation.copy()
    travel[:, 2] += np.linspace(0, 1200, 150)  # 12 m: several body heights across the screen
    ref = ref.replace(root_translation=travel)
    cand = _perturbed(ref, JOINT, 70)
    result = rmod.render(tmp_path / "walk.gif", ref, cand, max_frames=20)
    w, h = result.size
    assert w >= 640 and h >= 600
    with Image.open(result.path) as im:
        for k in (0, im.n_frames - 1):
            im.seek(k)
            frame = np.asarray(im.convert("RGB")).astype(int)
            body = frame[: int(h * 0.7)]  # above the error panel
            red = (body[..., 0] > 180) & (body[..., 1] < 120) & (body[..., 2] < 120)
            rows = np.nonzero(red.any(axis=1))[0]
            assert rows.size and rows[-1] - rows[0] > 250, "the figure is not drawn large"  # pixels tall
            cols = np.nonzero(red.any(axis=0))[0]
            assert 0.2 * w < cols.mean() < 0.8 * w  # followed: in the middle at the start and at the end


def test_colours_stay_apart_where_the_skeletons_overlap(tmp_path, pair):
    ref = pair[0]
    result = rmod.render(tmp_path / "same.png", ref, ref, count=2, size=(640, 520))
    rgb = np.asarray(Image.open(result.path).convert("RGB")).astype(int)
    red = np.array([0xD6, 0x27, 0x28])
    blue = np.array([0x1F, 0x5F, 0xD6])
    near = lambda c, tol=40: int((np.abs(rgb - c).max(axis=-1) <= tol).sum())  # noqa: E731
    purple = (red + blue) // 2
    assert near(red) > 300 and near(blue) > 300
    assert near(purple, 30) < 0.05 * (near(red) + near(blue))  # no blend of the two where they coincide


def test_error_panel_and_units_in_the_title(tmp_path, pair):
    ref, cand = pair
    result = rmod.render(tmp_path / "p.png", ref, cand, count=3, size=(720, 560), bound=2.0)
    rgb = np.asarray(Image.open(result.path).convert("RGB")).astype(int)
    bottom = rgb[int(0.75 * rgb.shape[0]):]
    dashed_bound = (np.abs(bottom - [0xB0, 0, 0]).max(axis=-1) <= 40).sum()
    curve = (np.abs(bottom - [0x1F, 0x5F, 0xD6]).max(axis=-1) <= 40).sum()
    assert dashed_bound > 50 and curve > 50
    assert "lengths in cm" in render_draw.headline_text(("a", "b"), True, None, "cm")
    assert "lengths in file units" in render_draw.headline_text(("a", "b"), True, None, None)


def test_no_bone_that_is_not_in_the_skeleton():
    """A root whose OFFSET is far from the origin, a root-motion node under it (as in Bandai Namco files: the
    hips translated by position channels), end sites: only real links are drawn, never one to the origin."""
    from motionrep import Skeleton

    six = ("Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation")
    sk = Skeleton(names=("joint_Root", "Hips", "Spine", "Head"), parents=[-1, 0, 1, 2],
                  offsets=[[300.0, 0, -200], [0.8, 94, -452], [0, 15, 0], [0, 20, 0]], channels=(six,) * 4,
                  end_site_parents=[3], end_site_offsets=[[0, 10, 0]])
    motion = synthetic_motion(sk, frames=30, fps=30.0)
    jt = np.array(motion.joint_translations)
    jt[:, 1:] = sk.offsets[2:]  # spine and head: rigid bones (constant translations)
    jt[:, 0] = sk.offsets[1] + np.linspace(0, 40, 30)[:, None]  # the hips move: a translation, not a bone
    motion = motion.replace(joint_translations=jt)
    assert rmod.bone_segments(motion).tolist() == [[1, 2], [2, 3], [3, 4]]
    rigid = motion.replace(joint_translations=np.broadcast_to(sk.offsets[1:], jt.shape))
    assert rmod.bone_segments(rigid).tolist() == [[0, 1], [1, 2], [2, 3], [3, 4]]
    chain = synthetic_motion(chain_skeleton(4), frames=5)
    assert rmod.bone_segments(chain).tolist() == [[0, 1], [1, 2], [2, 3]] + [
        [int(p), 4 + e] for e, p in enumerate(chain.skeleton.end_site_parents)]


# ---- real data ----------------------------------------------------------------------------------------------------

@requires_shared
@pytest.mark.realdata
def test_real_walk_filmstrip(tmp_path):
    walk = SHARED_DATA / "cmu" / "bvh-matlab" / "walk.bvh"
    ref = read(walk)
    cand = _perturbed(ref, "RightForeArm", 200, radians=0.6)
    result = rmod.render(tmp_path / "walk.png", ref, cand, names=("walk.bvh", "noisy.bvh"), count=4,
                         size=(800, 420))
    assert result.up == "y"
    assert result.error.joint.startswith("RightHand") or result.error.joint.startswith("RightFore")
    assert abs(result.error.frame - 200) <= 3 and result.error.frame in result.frames
    pixels = _colour_pixels(result.path)
    assert pixels["red"] > 100 and pixels["blue"] > 100, pixels


# ---- issue 26: each frame's worst joint, the zoomed worst joint, no empty cell, progress --------------------------
def _two_bumps(ref):
    """A candidate whose worst joint is LeftForeArm's around frame 8 and RightUpLeg's around frame 30."""
    return _perturbed(_perturbed(ref, "LeftForeArm", 8, radians=0.6), "RightUpLeg", 30, radians=0.5)


def test_each_frame_circles_its_own_worst_joint(pair):
    from matplotlib.figure import Figure

    ref = pair[0]
    cand = _two_bumps(ref)
    ref_pos, cand_pos = global_positions(ref), global_positions(cand)
    dist = np.linalg.norm(ref_pos - cand_pos, axis=-1)
    points = dist.argmax(axis=1)
    assert points[8] != points[30]  # the two bumps are on different joints
    bones = rmod.bone_segments(ref)
    scene = render_scene.build_scene(ref_pos, cand_pos, bones, "y", np.arange(ref.num_frames), 170.0, ref.fps)
    from motionrep.pipeline.evaluate import Evaluator
    from motionrep.model.kinematics import point_names

    error = Evaluator(ref).positions_error(cand_pos)
    worst = render_scene.Worst(error, list(point_names(ref.skeleton)).index(error.joint))
    fig = Figure(figsize=(3, 3))
    panel = render_draw.Panel(fig.add_axes((0, 0, 1, 1)), scene, worst, 1.0, 8.0, points=points)
    for f in (8, 30):
        panel.show(f)
        p = int(points[f])
        want = (scene.ref[f, p] + scene.cand[f, p]) / 2 - scene.shift[f]
        x, y = panel.ring.get_data()
        assert np.allclose([x[0], y[0]], want), f


def test_worst_joint_zoomed_in_filmstrip_and_animation(tmp_path, pair, monkeypatch):
    insets = []
    original = render_draw.zoom_inset

    def spy(fig, rect, scene, worst, *args, **kwargs):
        ax = original(fig, rect, scene, worst, *args, **kwargs)
        insets.append((ax, scene, worst))
        return ax

    monkeypatch.setattr(render_draw, "zoom_inset", spy)  # the animation's
    monkeypatch.setattr(render_strip, "zoom_inset", spy)  # the filmstrip's
    ref, cand = pair
    for name in ("strip.png", "anim.gif"):
        insets.clear()
        result = rmod.render(tmp_path / name, ref, cand, frames="0:40" if name.endswith("png") else "0:12")
        assert len(insets) == 1, name
        ax, scene, worst = insets[0]
        assert worst.frame == result.error.frame == BUMP_FRAME and worst.name == result.error.joint
        f, p = worst.frame, worst.point
        mid = (scene.ref[f, p] + scene.cand[f, p]) / 2 - scene.shift[f]
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        assert x0 < mid[0] < x1 and y0 < mid[1] < y1  # centred on the worst joint
        zoom = (scene.ylim[1] - scene.ylim[0]) / (y1 - y0)
        assert zoom > 3, zoom  # and zoomed in
        assert any("zoom x" in t.get_text() and worst.name in t.get_text() for t in ax.texts)


@pytest.mark.parametrize("count, with_candidate", [(8, True), (8, False), (7, True), (5, False), (12, True)])
def test_no_empty_cell_in_a_filmstrip(tmp_path, pair, monkeypatch, count, with_candidate):
    """Every row of pictures is filled across: the last cell (the zoom, or the last picture) spans the rest."""
    boxes = []
    original_panel = render_draw.Panel.__init__

    def record(self, ax, *args, **kwargs):
        original_panel(self, ax, *args, **kwargs)
        boxes.append(ax.get_position())

    monkeypatch.setattr(render_draw.Panel, "__init__", record)
    ref, cand = pair
    result = rmod.render(tmp_path / "s.png", ref, cand if with_candidate else None, count=count)
    assert len(result.frames) == count
    # Panels: one per picture, and one in the zoomed cell (which is a bit inset in its cell)
    assert len(boxes) == count + int(with_candidate)
    rows: dict[float, float] = {}
    for b in boxes:
        rows.setdefault(round(b.y1, 2), 0.0)
        rows[round(b.y1, 2)] += b.width
    assert len(rows) >= 1
    for top, width in rows.items():
        assert width > 0.94, (top, width, count, with_candidate)


def test_progress_reaches_the_end(tmp_path, pair):
    ref, cand = pair
    for name in ("p.gif", "p.png"):
        calls = []
        result = rmod.render(tmp_path / name, ref, cand, frames="0:10" if name.endswith("gif") else None,
                             progress=lambda done, total: calls.append((done, total)))
        total = len(result.frames) + 1  # each picture, then writing the file
        assert [c[0] for c in calls] == list(range(1, total + 1)) and {c[1] for c in calls} == {total}


def test_progress_bar_only_on_a_terminal(tmp_path, files, monkeypatch):
    import io

    from motionrep.cli import render as cli_render

    ref_path, cand_path = files
    r = run_cli_caught("render", str(ref_path), str(cand_path), "-o", str(tmp_path / "a.gif"),
                                 "--frames", "0:6")
    assert r.exit_code == 0 and "drawing" not in r.output  # not a terminal: no bar

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    term = Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    with cli_render._Bar("drawing a.gif") as bar:
        for done in range(1, 4):
            bar(done, 3)
    text = term.getvalue()
    assert "drawing a.gif" in text and "3/3" in text


def test_the_animation_inset_goes_where_the_figure_passes_least():
    from matplotlib.figure import Figure

    def scene_with(points):
        pts = np.array(points, dtype=float)[None]  # one frame, (1, P, 2)
        return render_scene.Scene(ref=pts, cand=pts.copy(), ref_shadow=pts, bones=np.zeros((0, 2), int),
                                  floor=np.zeros((0, 2, 2)), xlim=(0.0, 1.0), ylim=(0.0, 1.0),
                                  shift=np.zeros((1, 2)))

    ax = Figure().add_axes((0, 0, 1, 1))
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    frames = np.array([0])
    assert render_draw.inset_corner(ax, scene_with([[0.5, 0.5]]), frames, 0.3, 0.3) == (1, 1)  # upper right
    assert render_draw.inset_corner(ax, scene_with([[0.9, 0.9]]), frames, 0.3, 0.3) == (0, 1)
    assert render_draw.inset_corner(ax, scene_with([[0.9, 0.9], [0.1, 0.9]]), frames, 0.3, 0.3) == (1, 0)
