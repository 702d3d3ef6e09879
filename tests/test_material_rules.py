"""Material rules that hold in one place: the solver settings estimate falls back to, and particles and
tetrahedra that fill an object's volume even when its mesh has holes."""

from __future__ import annotations

import shutil

import numpy as np
import trimesh
from pxr import Sdf

from physomni_usd.physics.cloth import voxel_tets
from physomni_usd.physics.mpm import points_inside, sample_inside
from physomni_usd.physics.stability import DEFAULT_ITERATIONS, DEFAULT_SUBSTEPS

from .conftest import cli


def test_estimate_falls_back_to_the_simulators_own_step_defaults(tmp_path, shot):
    folder = tmp_path / "shot"
    shutil.copytree(shot["dir"], folder)
    layer = Sdf.Layer.FindOrOpen(str(folder / "physics.usda"))
    scene = layer.GetPrimAtPath("/World/PhysicsScene")
    for name in ("physomni:substeps", "physomni:iterations"):
        scene.RemoveProperty(scene.properties[name])
    layer.Save()
    cli("estimate", folder / "shot.usda", check=True)
    written = Sdf.Layer.OpenAsAnonymous(str(folder / "physics.usda"))  # what estimate wrote, not sim's record
    scene = written.GetPrimAtPath("/World/PhysicsScene")
    assert scene.properties["physomni:substeps"].default == DEFAULT_SUBSTEPS
    assert scene.properties["physomni:iterations"].default == DEFAULT_ITERATIONS


def _holed_ball():
    ball = trimesh.creation.icosphere(3, 0.5)
    return ball, trimesh.Trimesh(ball.vertices, ball.faces[12:], process=False)


def test_particles_fill_a_holed_mesh_not_its_bounding_box():
    ball, holed = _holed_ball()
    assert not holed.is_watertight
    h = 0.05
    pts = sample_inside(holed, h)
    # its volume's worth of particles (the bounding box holds 1.9 times as many), all inside the ball
    assert abs(len(pts) - ball.volume / h ** 3) < 0.05 * ball.volume / h ** 3
    assert np.linalg.norm(pts, axis=1).max() < 0.5 + 0.2 * h
    probe = np.random.default_rng(1).uniform(-0.6, 0.6, (3000, 3))
    assert (points_inside(holed, probe) == ball.contains(probe)).mean() > 0.99


def test_soft_body_tetrahedra_fill_a_holed_mesh():
    ball, holed = _holed_ball()
    verts, tets = voxel_tets(holed, 0.1)
    a, b, c, d = (verts[tets[:, k]] for k in range(4))
    vol = np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a).sum() / 6
    assert abs(vol - ball.volume) / ball.volume < 0.25


def test_citrus_fruit_get_the_fruit_material_not_the_default():
    # a lemon took the default row (200 kg/m³, a fifth of the orange beside it) in generated fruit piles
    from physomni_usd.materials.defaults import DEFAULT, rigid_material

    for label in ("lemon", "lime", "lemons"):
        assert rigid_material(label) == rigid_material("orange") != DEFAULT, label
