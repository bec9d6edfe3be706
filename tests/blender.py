"""Blender for the round-trip tests: run a script in ``blender -b --factory-startup`` with a timeout, or skip.

``pytest.skip`` says why when ``blender`` is not on PATH (CI installs Debian's, as the viewer's test installs
Chromium).  :data:`ROUND_TRIPS` is what the tests run inside Blender: import a file, export glTF.

Two things Debian's Blender 3.4 needs on a Python 3.11 system: its glTF importer imports numpy (the system
``python3-numpy``), and its BVH importer opens files with mode ``'rU'``, which Python 3.11 removed: the BVH
script replaces ``builtins.open`` by one that drops the ``U`` before the importer runs.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

#: Longest a Blender run may take, in seconds, before the test fails.
TIMEOUT = 300

#: What the tests run inside Blender: jobs given after ``--``, each ``gltf SRC OUT FPS`` (a motionrep .glb ->
#: Blender's glTF importer -> its glTF exporter, the scene at the clip's rate, so that import and export keep
#: every frame) or ``bvh SRC OUT`` (a BVH -> Blender's BVH importer -> its glTF exporter), the scene emptied
#: before each, so that one Blender start serves several round trips.
ROUND_TRIPS = """
import builtins, sys, bpy
_open = builtins.open
def _open_without_U(file, mode="r", *args, **kwargs):  # Python 3.11 removed 'U'; Blender 3.4's BVH importer uses it
    return _open(file, mode.replace("U", "") if isinstance(mode, str) else mode, *args, **kwargs)
builtins.open = _open_without_U

def empty():
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)
    for a in list(bpy.data.actions):
        bpy.data.actions.remove(a)
    for a in list(bpy.data.armatures):
        bpy.data.armatures.remove(a)

def export(out, frame_range):
    bpy.ops.export_scene.gltf(filepath=out, export_format="GLB", export_animations=True,
                              export_force_sampling=True, export_frame_range=frame_range)

def gltf(src, out, fps):
    empty()
    scene = bpy.context.scene
    scene.render.fps = max(1, round(float(fps)))
    scene.render.fps_base = scene.render.fps / float(fps)
    bpy.ops.import_scene.gltf(filepath=src)
    export(out, False)

def bvh(src, out):
    empty()
    bpy.ops.import_anim.bvh(filepath=src, update_scene_fps=True, update_scene_duration=True)
    export(out, True)

jobs = sys.argv[sys.argv.index("--") + 1:]
while jobs:
    if jobs[0] == "gltf":
        gltf(*jobs[1:4]); jobs = jobs[4:]
    elif jobs[0] == "bvh":
        bvh(*jobs[1:3]); jobs = jobs[3:]
    else:
        raise SystemExit(f"unknown job {jobs[0]!r}")
"""


def blender_path() -> str:
    """The ``blender`` on PATH, or a pytest skip saying that it is missing."""
    path = shutil.which("blender")
    if path is None:
        pytest.skip("blender is not on PATH (CI installs Debian's blender and python3-numpy for these tests)")
    return path


def run_blender(script: str, *args: str | Path, timeout: float = TIMEOUT) -> subprocess.CompletedProcess:
    """Run ``script`` (Python source) in ``blender -b --factory-startup --python-expr`` with ``args`` after
    ``--``; fails the test (with Blender's output) when it exits non-zero or leaves a Python error."""
    cmd = [blender_path(), "-b", "--factory-startup", "--python-exit-code", "1", "--python-expr", script, "--",
           *map(str, args)]
    try:
        run = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        pytest.fail(f"blender took more than {timeout:g} s")
    if run.returncode != 0 or "Traceback (most recent call last)" in run.stderr:
        pytest.fail(f"blender failed (exit {run.returncode}):\n{run.stdout[-3000:]}\n{run.stderr[-3000:]}")
    return run
