"""Issue 38, part 1 (nothing unpushed moves), for piles: a fruit resting on three others at once. The build
lowers it into their hollow (``align.support.into_hollow`` through ``physics.support.steady_stacks``) instead of
shifting it onto one supporter's rounded top, where it balances on a dome and rolls off; the simulator iterates
a scene holding such a body more (``physics.stability.held_by_several``). The simulated effect is measured by
``bench general`` on generated piles."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import trimesh

from physomni_usd.physics.stability import PILE_ITERATIONS, PlanInputs, held_by_several, plan_steps
from physomni_usd.physics.support import _solid_com, steady_stacks


def _ball(r, centre):
    m = trimesh.creation.icosphere(subdivisions=3, radius=r)
    m.apply_translation(centre)
    return m


def _pile(gap=0.012, r=0.04):
    """Three balls on the ground in a triangle ``gap`` apart, a fourth over the hollow between them, off its
    middle, lowered until it first touches one: where a lifted fruit whose mask touches all three may stand
    before it is steadied."""
    d = (2 * r + gap) / np.sqrt(3)  # the triangle's circumradius
    lower = [_ball(r, [d * np.cos(a), d * np.sin(a), r]) for a in np.radians([90, 210, 330])]
    top = _ball(r, [0.0, d - 0.9 * r, 3 * r])
    lo, hi = 0.0, 3 * r
    for _ in range(25):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if max(trimesh.proximity.signed_distance(b, top.vertices - [0, 0, mid]).max() for b in lower) < 0 \
            else (lo, mid)
    top.apply_translation([0, 0, -lo])
    return lower + [top]


def test_a_fruit_on_the_side_of_one_of_three_is_lowered_into_their_hollow():
    balls = _pile()
    verts, faces = [b.vertices.copy() for b in balls], [b.faces for b in balls]
    eye = np.array([0.0, -1.0, 0.4])
    out, done = steady_stacks(verts, faces, {3: (0, "contact")}, eye)
    top = trimesh.Trimesh(out[3], faces[3])
    assert top.vertices[:, 2].min() < balls[3].vertices[:, 2].min() - 0.01, done  # it went down, not up a dome
    for k in range(3):  # it touches each of the three, and is in none
        d = trimesh.proximity.signed_distance(trimesh.Trimesh(out[k], faces[k]), out[3]).max()
        assert -0.004 < d < 0.001, (k, d, done)
    com = _solid_com(out[3], faces[3])
    centres = np.array([v.mean(axis=0) for v in out[:3]])
    assert np.linalg.norm(com[:2] - centres[:, :2].mean(axis=0)) < 0.01  # over the middle of the hollow
    assert any("into_hollow_m" in d for d in done)


def test_a_fruit_on_one_fruit_s_top_is_left_where_it_is():
    lower = _ball(0.04, [0, 0, 0.04])
    top = _ball(0.03, [0, 0, 0.08 + 0.03])
    verts, done = steady_stacks([lower.vertices, top.vertices], [lower.faces, top.faces], {1: (0, "contact")},
                                np.array([0.0, -1.0, 0.4]))
    # lowered with its supporter's flat foot only: no level shift, no hollow
    assert np.allclose(verts[1][:, :2], top.vertices[:, :2]), done
    assert not any("into_hollow_m" in d or "shift_m" in d for d in done), done


def _sim_objects(meshes, names):
    return [SimpleNamespace(family="rigid", fixed=False, points=np.asarray(m.vertices, float), faces=m.faces,
                            name=n, params={"density": 800.0, "restitution": 0.2}, trimesh=(lambda m=m: m),
                            prim=SimpleNamespace(GetAttribute=lambda name: None))  # nothing pushed
            for m, n in zip(meshes, names)]


def test_a_scene_holding_a_fruit_on_three_iterates_more_and_one_beside_another_does_not():
    balls = _pile()
    verts, done = steady_stacks([b.vertices for b in balls], [b.faces for b in balls], {3: (0, "contact")},
                                np.array([0.0, -1.0, 0.4]))
    piled = [trimesh.Trimesh(v, b.faces) for v, b in zip(verts, balls)]
    objects = _sim_objects(piled, ["a", "b", "c", "top"])
    assert held_by_several(objects) == ["top"]
    plan = plan_steps(PlanInputs(objects, 30.0, 8, base_iterations=2))
    assert plan.iterations >= PILE_ITERATIONS and plan.reasons["pile"]["held_by_several"] == ["top"]
    apart = _sim_objects(balls[:3], ["a", "b", "c"])  # on the ground side by side: no pile
    assert held_by_several(apart) == []
    assert plan_steps(PlanInputs(apart, 30.0, 8, base_iterations=2)).iterations == 2
