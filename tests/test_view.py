"""motionrep view: the self-contained HTML viewer, checked as text and in a real (headless) browser."""

from __future__ import annotations

import base64
import json
import re
import shutil
import time
from pathlib import Path

import numpy as np
import pytest

from motionrep import character_height, global_positions
from motionrep.pipeline.compress import decompress
from motionrep.errors import ValidationError
from motionrep.io import read, write
from motionrep.model.rotations import euler_to_quat, quat_multiply
from motionrep.model.synthetic import chain_skeleton, humanoid_skeleton, synthetic_motion
from motionrep.present.view import CANDIDATE_COLORS, REFERENCE_COLOR, ViewClip, view_html, write_view
from helpers import run_cli_caught


def perturbed(motion, joint: int, first: int, count: int, radians: float = 0.4):
    rot = np.array(motion.rotations)
    turn = euler_to_quat(np.array([[radians, 0.0, 0.0]]), "XYZ")
    rot[first:first + count, joint] = quat_multiply(rot[first:first + count, joint], turn)
    return motion.replace(rotations=rot)


def page_data(page: str) -> dict:
    text = re.search(r'<script type="application/json" id="motionrep-data">(.*?)</script>', page, re.S).group(1)
    return json.loads(text)


@pytest.fixture(scope="module")
def walk():
    reference = synthetic_motion(humanoid_skeleton(), frames=90, fps=30.0)
    return reference, perturbed(reference, 8, 60, 6)


# ---------------------------------------------------------------------------------------------------------------
# the page as text
# ---------------------------------------------------------------------------------------------------------------
def test_page_is_one_self_contained_file(tmp_path, walk):
    reference, candidate = walk
    result = write_view(tmp_path / "view.html", ViewClip(reference, "walk.bvh"),
                        [ViewClip(candidate, "walk.mrc", (("codec", "svd"),))], bound=3.0)
    page = (tmp_path / "view.html").read_text()
    assert result.bytes == len(page.encode()) and result.path == tmp_path / "view.html"
    assert not re.search(r"<(script|link|img|iframe)[^>]*\s(src|href)=", page)  # nothing loaded from elsewhere
    assert "Content-Security-Policy" in page and "default-src 'none'" in page
    assert "Copyright 2010-2026 Three.js Authors" in page  # the licence notice travels with three.js
    data = page_data(page)
    assert [c["label"] for c in data["clips"]] == ["walk.bvh", "walk.mrc"]
    assert data["clips"][0]["color"] == REFERENCE_COLOR and data["clips"][1]["color"] == CANDIDATE_COLORS[0]
    cand = data["clips"][1]
    assert cand["error"]["frame"] == result.worst_frame == result.errors[0].frame
    assert 60 <= result.worst_frame < 66 and len(cand["perFrame"]) == 90
    assert max(cand["perFrame"]) == pytest.approx(result.errors[0].max_error, rel=1e-5)
    assert cand["facts"] == [["codec", "svd"]]
    assert data["bound"] == 3.0 and data["boundText"].startswith("3 cm = ")


def test_embedded_clips_are_motionreps_gltf(tmp_path, walk):
    reference, candidate = walk
    page, _ = view_html(reference, [candidate], up="y")
    for clip, motion in zip(page_data(page)["clips"], (reference, candidate)):
        path = tmp_path / "clip.glb"
        path.write_bytes(base64.b64decode(clip["glb"]))
        back = read(path)
        assert np.abs(global_positions(back) - global_positions(motion)).max() < 1e-6 * character_height(
            motion.skeleton)


def test_text_from_files_cannot_break_out_of_the_page(walk):
    reference, candidate = walk
    label = "</script><script>alert(1)</script><!--"
    page, _ = view_html(ViewClip(reference, label), [ViewClip(candidate, "b", (("x", label),))], title=label)
    assert "<script>alert(1)" not in page and page.count("</script>") == 3
    data = page_data(page)
    assert data["clips"][0]["label"] == label and data["title"] == label


def test_candidate_at_another_rate_is_resampled(walk):
    reference, _ = walk
    coarse = synthetic_motion(humanoid_skeleton(), frames=46, fps=15.0)
    page, result = view_html(reference, [coarse])
    assert result.notes and "resampled" in result.notes[0]
    assert page_data(page)["clips"][1]["frames"] == 90


def test_refusals(walk):
    reference, candidate = walk
    with pytest.raises(ValidationError, match="do not share a skeleton"):
        view_html(reference, [synthetic_motion(chain_skeleton(5), frames=90, fps=30.0)])
    with pytest.raises(ValidationError, match="at most 6 candidates"):
        view_html(reference, [candidate] * 7)
    with pytest.raises(ValidationError, match="bound"):
        view_html(reference, [candidate], bound=-1.0)


# ---------------------------------------------------------------------------------------------------------------
# in a real browser: headless Chromium through its WebDriver (skipped where either is not installed)
# ---------------------------------------------------------------------------------------------------------------
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
CHROMEDRIVER = shutil.which("chromedriver")


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    if not (CHROMIUM and CHROMEDRIVER):
        pytest.skip("no Chromium and ChromeDriver installed (Debian: apt-get install chromium chromium-driver)")
    webdriver = pytest.importorskip("selenium.webdriver")
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync",
                 "--enable-unsafe-swiftshader", "--use-angle=swiftshader", "--window-size=1280,900",
                 f"--user-data-dir={tmp_path_factory.mktemp('chromium')}"):
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    yield driver
    driver.quit()


def open_page(driver, path: Path) -> None:
    driver.get_log("browser")  # forget what earlier pages said
    driver.get(path.resolve().as_uri())
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        state = driver.execute_script("const v = window.motionrepViewer; return v && [v.ready, v.failed];")
        if state and (state[0] or state[1]):
            assert state[1] is None, state[1]
            return
        time.sleep(0.2)
    raise AssertionError("the viewer did not get ready in 120 s")


def errors_logged(driver) -> list[str]:
    return [e["message"] for e in driver.get_log("browser") if e["level"] == "SEVERE"]


def colour_pixels(png: bytes, colour: str, tolerance: int = 40) -> int:
    from io import BytesIO

    from PIL import Image

    image = np.asarray(Image.open(BytesIO(png)).convert("RGB")).astype(int)
    want = np.array([int(colour[i:i + 2], 16) for i in (1, 3, 5)])
    return int((np.abs(image - want).max(axis=-1) <= tolerance).sum())


def test_viewer_in_a_browser(browser, tmp_path, walk):
    """Opens the page, checks the console, seeks to the worst frame, screenshots it and finds both skeletons; the
    candidate comes from a .glb file and three.js poses both clips as motionrep's FK does."""
    from selenium.webdriver.common.by import By

    reference, candidate = walk
    write(candidate, tmp_path / "decoded.glb")
    decoded = read(tmp_path / "decoded.glb")
    result = write_view(tmp_path / "view.html", ViewClip(reference, "walk.bvh"),
                        [ViewClip(decoded, "decoded.glb")], bound=2.0, up="y")
    open_page(browser, tmp_path / "view.html")
    assert errors_logged(browser) == []
    viewer = "return window.motionrepViewer"
    assert browser.execute_script(viewer + ".three") == "187"
    # three.js read the embedded .glb files: every joint and end site is a bone where motionrep's FK puts it
    height = character_height(reference.skeleton)
    for i, motion in enumerate((reference, decoded)):
        bones = browser.execute_script(viewer + f".positions({i})")
        assert len(bones) == motion.num_joints + motion.skeleton.num_end_sites
        assert np.abs(np.array(bones) - global_positions(motion)[0]).max() < 1e-5 * height  # float32 in WebGL
    browser.find_element(By.ID, "worst").click()
    assert browser.execute_script(viewer + ".frame()") == result.worst_frame
    hud = browser.find_element(By.ID, "hud").text
    assert f"frame {result.worst_frame} / 89" in hud
    bones = browser.execute_script(viewer + ".positions(1)")
    assert np.abs(np.array(bones) - global_positions(decoded)[result.worst_frame]).max() < 1e-5 * height
    png = browser.get_screenshot_as_png()
    (tmp_path / "worst.png").write_bytes(png)
    assert colour_pixels(png, REFERENCE_COLOR) > 150, "the reference skeleton is not on the screenshot"
    assert colour_pixels(png, CANDIDATE_COLORS[0]) > 150, "the decoded skeleton is not on the screenshot"
    # scrubbing with the keyboard and clicking on the curve move the frame
    browser.find_element(By.TAG_NAME, "body").send_keys("\ue012")  # arrow left
    assert browser.execute_script(viewer + ".frame()") == result.worst_frame - 1
    curve = browser.find_element(By.ID, "curve")
    from selenium.webdriver.common.action_chains import ActionChains

    ActionChains(browser).move_to_element_with_offset(curve, -curve.size["width"] // 2 + 64 + 1, 0).click().perform()
    assert browser.execute_script(viewer + ".frame()") == 0
    assert errors_logged(browser) == []


def test_viewer_of_one_clip_in_a_browser(browser, tmp_path):
    motion = synthetic_motion(humanoid_skeleton(), frames=20, fps=10.0)
    write_view(tmp_path / "one.html", motion)
    open_page(browser, tmp_path / "one.html")
    assert browser.execute_script("return window.motionrepViewer.frames") == 20
    from selenium.webdriver.common.by import By

    # nothing to magnify or colour, and no candidate's worst frame
    assert not browser.find_element(By.ID, "magnify").is_enabled()
    assert not browser.find_element(By.ID, "heat").is_enabled()
    assert not browser.find_element(By.ID, "worst").is_enabled()
    assert colour_pixels(browser.get_screenshot_as_png(), REFERENCE_COLOR) > 150
    assert errors_logged(browser) == []


# ---------------------------------------------------------------------------------------------------------------
# issue 26: labels by codec and path, magnification, per-joint error colours, worst frame per candidate, framing
# ---------------------------------------------------------------------------------------------------------------
def test_distinct_names_take_enough_of_the_path():
    from motionrep.present.view import distinct_names

    assert distinct_names(["x/svd/clip.mrc", "x/fourier/clip.mrc", "clip.bvh"]) == [
        "svd/clip.mrc", "fourier/clip.mrc", "clip.bvh"]
    assert distinct_names(["a/b/c.mrc", "d/b/c.mrc"]) == ["a/b/c.mrc", "d/b/c.mrc"]
    assert distinct_names(["/x/c.mrc", "/y/x/c.mrc"]) == ["/x/c.mrc", "y/x/c.mrc"]
    assert distinct_names(["c.mrc", "c.mrc"]) == ["c.mrc", "c.mrc"]  # the same path twice: nothing tells them apart


def test_facts_never_show_python_none(walk):
    reference, candidate = walk
    page, _ = view_html(reference, [ViewClip(candidate, "c.mrc", (("parameters", None), ("x", float("nan"))))])
    data = page_data(page)
    assert data["clips"][1]["facts"] == [["parameters", "-"], ["x", "-"]]
    assert "None" not in json.dumps(data)


def test_page_states_rate_and_one_duration(walk):
    reference, candidate = walk
    page, result = view_html(reference, [candidate])
    data = page_data(page)
    assert data["duration"] == 3.0 and data["durationText"] == "3 s"  # 90 frames at 30 fps: frames / fps
    assert data["clips"][0]["rateText"] == "30 fps (frame time 0.03333333 s)"
    assert result.worst_frames == (result.worst_frame,)


@pytest.fixture(scope="module")
def three_codecs(tmp_path_factory):
    """A clip and three .mrc files of it from three codecs, each named clip.mrc in its own folder."""


    root = tmp_path_factory.mktemp("codecs")
    reference = synthetic_motion(humanoid_skeleton(), frames=60, fps=30.0)
    write(reference, root / "clip.bvh")
    runs = {"svd": ["-p", "rank=3"], "naive-fourier": ["-p", "k=2", "-p", "iters=50"],
            "transform": ["-p", "step=2"]}
    paths = []
    for codec, params in runs.items():
        (root / codec).mkdir()
        out = root / codec / "clip.mrc"
        r = run_cli_caught("compress", str(root / "clip.bvh"), "-o", str(out), "--codec", codec,
                                     "--max-error", "none", *params)
        assert r.exit_code == 0, r.output
        paths.append(out)
    page = root / "view.html"
    r = run_cli_caught("view", str(root / "clip.bvh"), *map(str, paths), "-o", str(page))
    assert r.exit_code == 0, r.output
    return reference, paths, page


def test_three_codecs_are_labelled_apart(three_codecs):
    _, _, page = three_codecs
    text = page.read_text()
    data = page_data(text)
    names = [c["name"] for c in data["clips"][1:]]
    assert len(set(names)) == 3
    for name, codec in zip(names, ("svd", "naive-fourier", "transform")):
        assert name.startswith(f"{codec}/clip.mrc ({codec} "), name
    assert "rank=3" in names[0] and "K=2" in names[1]
    params = dict(data["clips"][2]["facts"])["codec"]  # info's facts, every figure
    assert "window=auto" in params and "k=2" in params  # a parameter left to the codec: auto, not None
    assert {"codec", "outcome", "features", "size", "payload", "ratios", "L-inf"} <= set(dict(data["clips"][2]["facts"]))
    assert "None" not in json.dumps(data) and "NaN" not in json.dumps(data)


def test_new_controls_in_a_browser(browser, three_codecs):
    """Three candidates from three codecs: labels differ in the legend, HUD and facts; the slider draws a candidate
    at reference + k x its offset; joints coloured by error; one worst-frame button per candidate; the character
    fills most of the view's height at start; no None, NaN or undefined on the page."""
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    reference, paths, page = three_codecs
    open_page(browser, page)
    assert errors_logged(browser) == []
    viewer = "return window.motionrepViewer"
    labels = browser.execute_script(viewer + ".labels()")
    assert len(set(labels)) == 4
    legend = browser.find_element(By.ID, "legend").text
    hud = browser.find_element(By.ID, "hud").text
    facts = browser.find_element(By.ID, "facts").text
    for label in labels[1:]:
        assert label in legend and label in hud and label in facts
    # one duration: the facts and the clock both say frames / fps (60 frames at 30 fps: 2 s)
    assert "60 at 30 fps (frame time 0.03333333 s), 2 s" in facts
    assert browser.find_element(By.ID, "clock").text == "frame 0 / 59, 0.000 s of 2 s"
    body = browser.find_element(By.TAG_NAME, "body").text
    for word in ("None", "NaN", "nan", "undefined", "null"):
        assert word not in body.split() and f"={word}" not in body, word

    # framing: at start the reference fills most of the view's height (NDC -1..1), all of it inside
    box = browser.execute_script(viewer + ".screenBox(0)")
    assert box[3] - box[1] > 1.3, box  # more than 65 % of the height
    assert -1 <= box[0] and box[2] <= 1 and -1 <= box[1] and box[3] <= 1, box

    # one worst-frame button per candidate, each going to its own candidate's worst frame
    worst = browser.execute_script(viewer + ".worstFrames")
    decoded = [decompress(p.read_bytes()) for p in paths]
    ref_pos = global_positions(reference)
    expected = [int(np.linalg.norm(global_positions(d) - ref_pos, axis=-1).max(axis=1).argmax()) for d in decoded]
    assert worst == expected
    for i, button in enumerate(("worst", "worst-2", "worst-3")):
        browser.find_element(By.ID, button).click()
        assert browser.execute_script(viewer + ".frame()") == worst[i]
        assert f"frame {worst[i]}" in browser.find_element(By.ID, button).text
        assert browser.execute_script(viewer + ".focus()") == i  # the marker and the curve's label follow it

    # the magnification slider: clicking it a quarter along sets k near 25; its keys change k; candidate i is
    # drawn at reference + k x (candidate - reference)
    height = character_height(reference.skeleton)
    slider = browser.find_element(By.ID, "magnify")
    ActionChains(browser).move_to_element_with_offset(slider, -slider.size["width"] // 4, 0).click().perform()
    k = browser.execute_script(viewer + ".magnification()")
    assert 10 < k < 50, k
    slider.send_keys(Keys.END)
    assert browser.execute_script(viewer + ".magnification()") == 100
    slider.send_keys(Keys.LEFT)
    k = browser.execute_script(viewer + ".magnification()")
    assert k == 99 and "x99" in browser.find_element(By.ID, "magnify-value").text
    f = browser.execute_script(viewer + ".frame()")
    ref_now = ref_pos[f]
    for i, d in enumerate(decoded, start=1):
        drawn = np.array(browser.execute_script(viewer + f".positions({i})"))
        true = np.array(browser.execute_script(viewer + f".truePositions({i})"))
        # float32 FK in WebGL, the offset then multiplied by 99: a tolerance of 99 x float32 noise
        assert np.abs(true - global_positions(d)[f]).max() < 1e-5 * height
        assert np.abs(drawn - (ref_now + k * (global_positions(d)[f] - ref_now))).max() < 99 * 1e-5 * height
        assert np.abs(drawn - ref_now).max() > 5 * np.abs(true - ref_now).max()  # it visibly moved
    assert "error drawn x99" in browser.find_element(By.ID, "hud").text
    slider.send_keys(Keys.HOME)
    assert browser.execute_script(viewer + ".magnification()") == 1
    assert np.allclose(browser.execute_script(viewer + ".positions(1)"),
                       browser.execute_script(viewer + ".truePositions(1)"))

    # per-joint error colours: the worst joint of the frame is the hottest, a joint without error keeps the colour
    browser.find_element(By.ID, "worst").click()
    errors = np.array(browser.execute_script(viewer + ".jointErrors(1)"))
    colours = browser.execute_script(viewer + ".jointColors(1)")
    data = page_data(page.read_text())
    cand = data["clips"][1]
    assert int(errors.argmax()) == cand["perFrameJoint"][worst[0]]
    scale = browser.execute_script(viewer + ".errorScale")
    assert scale == pytest.approx(max(c["error"]["max"] for c in data["clips"][1:]), rel=1e-9)

    def rgb(text):
        return np.array([int(text[j:j + 2], 16) for j in (1, 3, 5)])

    hot, own = rgb("#ffd400"), rgb(cand["color"])
    t = errors.max() / scale
    assert np.abs(rgb(colours[int(errors.argmax())]) - (own + (hot - own) * min(1.0, t))).max() <= 2
    if errors.min() < 1e-3 * scale:
        assert np.abs(rgb(colours[int(errors.argmin())]) - own).max() <= 2
    browser.find_element(By.ID, "heat").click()  # off: every joint in the candidate's colour
    assert set(browser.execute_script(viewer + ".jointColors(1)")) == {cand["color"]}
    assert errors_logged(browser) == []
