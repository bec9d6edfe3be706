"""Blender for the round-trip tests: run a script in ``blender -b --factory-startup`` with a timeout, or skip.

``pytest.skip`` says why when ``blender`` is not on PATH (CI installs Debian's, as the viewer's test installs
Chromium).  The scripts below are what the tests run inside Blender: import a file, export glTF.

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

#: The scene's frame rate set to the clip's (Blender keys animations in scene frames and exports at them), so
#: that import and export keep every frame: ``fps`` as an integer and a ``fps_base``.
_FPS = """
def set_fps(fps):
    scene = bpy.context.scene
    scene.render.fps = max(1, round(fps))
    scene.render.fps_base = scene.render.fps / fps
"""

#: motionrep .glb -> Blender's glTF importer -> Blender's glTF exporter.  Arguments: SRC OUT FPS.
GLTF_ROUND_TRIP = """
import sys, bpy
""" + _FPS + """
src, out, fps = sys.argv[sys.argv.index("--") + 1:][:3]
for o in list(bpy.data.objects):
    bpy.data.objects.remove(o)
set_fps(float(fps))
bpy.ops.import_scene.gltf(filepath=src)
actions = [a for a in bpy.data.actions]
start = min(int(a.frame_range[0]) for a in actions)
end = max(int(round(a.frame_range[1])) for a in actions)
bpy.context.scene.frame_start, bpy.context.scene.frame_end = start, end
bpy.ops.export_scene.gltf(filepath=out, export_format="GLB", export_animations=True, export_force_sampling=True,
                          export_frame_range=False)
"""

#: A BVH file -> Blender's BVH importer -> Blender's glTF exporter.  Arguments: SRC OUT.
BVH_TO_GLTF = """
import builtins, sys, bpy
_open = builtins.open
def _open_without_U(file, mode="r", *args, **kwargs):  # Python 3.11 removed 'U'; Blender 3.4's BVH importer uses it
    return _open(file, mode.replace("U", "") if isinstance(mode, str) else mode, *args, **kwargs)
builtins.open = _open_without_U
src, out = sys.argv[sys.argv.index("--") + 1:][:2]
for o in list(bpy.data.objects):
    bpy.data.objects.remove(o)
bpy.ops.import_anim.bvh(filepath=src, update_scene_fps=True, update_scene_duration=True)
bpy.ops.export_scene.gltf(filepath=out, export_format="GLB", export_animations=True, export_force_sampling=True,
                          export_frame_range=True)
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
