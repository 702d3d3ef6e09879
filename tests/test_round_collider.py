"""Issue 38, part 1 (nothing unpushed moves): a ball collides as a sphere about its centre of mass
(``physics.round``), so a lifted fruit resting on the ground stays, where on its tessellated hull it rocked."""

from __future__ import annotations

import numpy as np

from physomni_usd.bench.scenes import BenchObject, write_bench_shot
from physomni_usd.physics.round import inscribed_radius
from physomni_usd.physics.settle import settle_shot
from physomni_usd.usd import layers

FRUIT = {"density": 950.0, "restitution": 0.2, "dynamic_friction": 0.45, "static_friction": 0.5}


def _apple():
    """A lifted apple as the build writes it: a tessellated ball a little taller than wide, standing on a
    small flat foot (235726/005's: 6.4 cm wide, 7.3 cm tall)."""
    import trimesh

    m = trimesh.creation.icosphere(subdivisions=3, radius=0.0322)
    v = m.vertices * [1.0, 1.0, 1.132]
    low = v[:, 2].min()
    v[v[:, 2] < low + 0.0025, 2] = low
    v[:, 2] -= low
    return trimesh.Trimesh(v, m.faces, process=False)


def _settle(tmp_path, shape):
    mesh = _apple()
    shot = write_bench_shot(tmp_path, [BenchObject("apple", mesh, "rigid", FRUIT, shape=shape)])
    return mesh, settle_shot(layers.open_shot(shot, mute_sim=True), 2.0).motions["apple"]


def test_a_ball_on_the_ground_neither_rocks_nor_rolls(tmp_path):
    mesh, m = _settle(tmp_path, "sphere")
    assert m.turned_deg < 0.05, m
    assert np.abs(m.translation[:2]).max() < 1e-4, m
    # it sinks by what its hull is taller than its inscribed sphere about the centre of mass, and no more
    drop = mesh.center_mass[2] - inscribed_radius(mesh.vertices, mesh.center_mass)
    assert -m.translation[2] <= drop + 5e-4, (m, drop)


def test_the_same_mesh_not_lifted_as_a_ball_keeps_its_hull(tmp_path):
    """The sphere is for what the lift made a ball: the same points lifted otherwise rest on their hull, which
    the solver rocks on its foot (the case a sphere mends)."""
    _, m = _settle(tmp_path, "extrude")
    assert m.turned_deg > 0.1 and -m.translation[2] < 1e-3, m


def test_the_inscribed_radius():
    import trimesh

    cube = trimesh.creation.box((0.2, 0.1, 0.4))
    assert abs(inscribed_radius(cube.vertices, np.zeros(3)) - 0.05) < 1e-9
    assert abs(inscribed_radius(cube.vertices, np.array([0.0, 0.02, 0.0])) - 0.03) < 1e-9
    assert inscribed_radius(cube.vertices, np.array([0.5, 0.0, 0.0])) < 0.0
