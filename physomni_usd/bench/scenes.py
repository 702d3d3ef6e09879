"""Shots written straight from meshes — no photo, no lifting — for benchmarks that need exact
geometry (a 5 mm wall, a 1 mm cube) and exact materials; and a way to measure one in a fresh
interpreter, as a user's ``physomni-usd simulate`` runs."""

from __future__ import annotations

import pathlib
from dataclasses import dataclass, field

import cv2
import numpy as np

from ..geometry.camera import PinholeCamera
from ..materials.catalog import check_params
from ..materials.defaults import GROUND_MATERIAL
from ..physics.stability import DEFAULT_ITERATIONS, DEFAULT_SUBSTEPS
from ..usd import layers
from ..usd.author import PhysicsObject, SceneObject, write_physics_layer, write_scene_layer


#: Edge (m) and density (kg/m³) of the boxes of the box scenes.
BOX = 0.2
BOX_DENSITY = 500.0


@dataclass
class BenchObject:
    name: str
    mesh: object  # trimesh.Trimesh in world coordinates
    material: str = "rigid"
    params: dict = field(default_factory=dict)
    velocity: tuple | None = None
    fixed: bool = False
    #: the lifted shape the scene records ("vessel": an open vessel, collided as convex pieces)
    shape: str = "extrude"


def box(name: str, centre) -> BenchObject:
    """A rigid :data:`BOX` cube of :data:`BOX_DENSITY` centred at ``centre`` (m)."""
    import trimesh

    mesh = trimesh.creation.box((BOX, BOX, BOX))
    mesh.apply_translation(centre)
    return BenchObject(name, mesh, "rigid", {"density": BOX_DENSITY})


def falling_boxes(n: int) -> list[BenchObject]:
    """``n`` boxes dropped from 0.3 m up (each 5 cm higher than the one before), five to a row 0.4 m
    apart: the preview bench's rows and ``bench physics``' ten objects."""
    return [box(f"box_{i}", ((i % 5) * 0.4 - 0.8, (i // 5) * 0.4, 0.3 + 0.05 * i)) for i in range(n)]


def boxes_at_rest(n: int = 10) -> list[BenchObject]:
    """``n`` boxes standing on the ground five to a row, 0.4 m apart: ``bench peer``'s case against Genesis."""
    return [box(f"box_{i}", ((i % 5) * 0.4 - 0.8, (i // 5) * 0.4, BOX / 2)) for i in range(n)]


def write_bench_shot(folder: pathlib.Path, objects: list[BenchObject], fps: float = 30.0, forces=(),
                     substeps: int = DEFAULT_SUBSTEPS,
                     iterations: int = DEFAULT_ITERATIONS) -> pathlib.Path:
    """A complete shot folder (scene, physics, edits, sim, shot layers) holding ``objects``; returns shot.usda.
    The camera stands 1 m up, 4 m back from the origin, looking at it."""
    folder = pathlib.Path(folder)
    (folder / "textures").mkdir(parents=True, exist_ok=True)
    grey = np.full((8, 8, 4), 160, np.uint8)
    cv2.imwrite(str(folder / "textures" / "plate.png"), grey[..., :3])
    cv2.imwrite(str(folder / "textures" / "object.png"), grey)
    camera = PinholeCamera(320, 240, 50.0, 10.0, (0.0, -4.0, 1.0))
    scene, physics = [], []
    for i, o in enumerate(objects):
        centre = o.mesh.bounds.mean(axis=0)
        local = np.asarray(o.mesh.vertices, float) - centre
        scene.append(SceneObject(o.name, o.name, i, local, np.asarray(o.mesh.faces), np.asarray(o.mesh.vertex_normals),
                                 np.full((len(local), 2), 0.5), centre, "./textures/object.png", o.shape))
        physics.append(PhysicsObject(o.name, o.material, check_params(o.material, o.params), "user",
                                     velocity=o.velocity, fixed=o.fixed))
    write_scene_layer(folder / layers.SCENE, fps=fps, image_size=(320, 240), camera=camera,
                      plate="./textures/plate.png", objects=scene, ground_size=200.0)
    write_physics_layer(folder / layers.PHYSICS, folder / layers.SCENE, fps=fps, objects=physics,
                        ground=GROUND_MATERIAL, solver="xpbd", substeps=substeps, iterations=iterations,
                        forces=forces)
    layers.reset_sim_layer(folder, fps)
    layers.ensure_edits_layer(folder, fps)
    return layers.write_shot_layer(folder, fps)


def in_fresh_interpreter(module: str, function: str, **kwargs) -> dict:
    """``module.function(**kwargs)`` run in a new Python process (so that nothing this process holds —
    memory, loaded kernels, a large heap — counts), its JSON-able result returned; on failure
    ``{"error": last line of its stderr}``."""
    import json
    import subprocess
    import sys

    code = (f"import json\nfrom {module} import {function}\n"
            f"print('RESULT ' + json.dumps({function}(**json.loads({json.dumps(json.dumps(kwargs))}))))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    line = next((x for x in proc.stdout.splitlines() if x.startswith("RESULT ")), None)
    if line is None:
        return {"error": (proc.stderr.strip().splitlines() or ["no output"])[-1]}
    return json.loads(line[len("RESULT "):])
