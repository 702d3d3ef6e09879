"""Blender opens a shot headless: the objects as textured meshes with UVs, the camera playing its move.

Blender's Python module (bpy, the ``[dcc]`` extra) pins numpy<2, so it lives in an environment of its own:
``PHYSOMNI_BLENDER_PYTHON`` names that Python (``.ci/run`` makes one); without it, this Python is used if
it has bpy.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import pytest
from pxr import Usd

from .conftest import cli

SCRIPT = r"""
import json, sys
import bpy

bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.wm.usd_import(filepath=sys.argv[1])
scene = bpy.context.scene
cams = [o for o in scene.objects if o.type == "CAMERA"]
meshes = [o for o in scene.objects if o.type == "MESH"]
out = {"cameras": len(cams), "frame_start": scene.frame_start, "frame_end": scene.frame_end, "meshes": {}}
if cams:
    spots = []
    for f in (scene.frame_start, scene.frame_end):
        scene.frame_set(f)
        spots.append(list(cams[0].matrix_world.translation))
    out["camera_positions"] = spots
for o in meshes:
    images = [n.image.filepath for s in o.material_slots if s.material and s.material.use_nodes
              for n in s.material.node_tree.nodes if n.type == "TEX_IMAGE" and n.image]
    out["meshes"][o.name] = {"uv_layers": len(o.data.uv_layers), "images": images}
print("RESULT " + json.dumps(out))
"""


def _blender_python() -> str | None:
    exe = os.environ.get("PHYSOMNI_BLENDER_PYTHON")
    if exe:
        return exe
    probe = subprocess.run([sys.executable, "-c", "import bpy"], capture_output=True)
    return sys.executable if probe.returncode == 0 else None


def test_blender_imports_the_shot_with_uvs_textures_and_the_camera_move(shot, tmp_path):
    exe = _blender_python()
    if exe is None:
        pytest.skip("bpy is not installed: pip install 'physomni-usd[dcc]' in an environment of its own and "
                    "set PHYSOMNI_BLENDER_PYTHON to its python")
    d = tmp_path / "shot"
    shutil.copytree(shot["dir"], d)
    cli("render", d / "shot.usda", "--camera", "orbit-left", "--max-size", "64", "-q", check=True)
    stage = Usd.Stage.Open(str(d / "shot.usda"))
    frames = int(stage.GetEndTimeCode() - stage.GetStartTimeCode()) + 1
    script = tmp_path / "open_in_blender.py"
    script.write_text(SCRIPT)
    proc = subprocess.run([exe, str(script), str(d / "shot.usda")], capture_output=True, text=True, timeout=300)
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")]
    assert proc.returncode == 0 and lines, proc.stderr[-2000:]
    got = json.loads(lines[-1][len("RESULT "):])
    assert got["cameras"] == 1 and got["frame_end"] - got["frame_start"] + 1 == frames
    start, end = got["camera_positions"]
    assert sum((a - b) ** 2 for a, b in zip(start, end)) ** 0.5 > 0.05  # the orbit plays in Blender
    objects = {k: v for k, v in got["meshes"].items() if k.startswith(("cup", "box"))}
    assert len(objects) == 2, got["meshes"]
    for name, m in objects.items():
        assert m["uv_layers"] >= 1 and any(name in img for img in m["images"]), (name, m)
