"""The overlap depths ``simulate`` reports after stepping (``Penetrations``, behind ``shot_checks``) against the
full computation they replace (``overlaps``: a trimesh signed distance for every pair whose boxes meet): the
same pairs at the same depths, on a small scene with a real overlap and a near miss of a convex pair (boxes)
and of a hollow one (a ring), over moving frames."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from pxr import Gf, Usd, UsdGeom

from physomni_usd.metrics.geometry import Penetrations, WorldMeshes, overlaps
from physomni_usd.physics.recording import shot_checks
from physomni_usd.usd.author import OBJECTS


def _mesh(stage, name, mesh, poses):
    """``mesh`` at ``poses``: frame -> (translation, (angle in degrees about z))."""
    prim = UsdGeom.Mesh.Define(stage, f"{OBJECTS}/{name}")
    prim.GetPointsAttr().Set([Gf.Vec3f(*map(float, p)) for p in mesh.vertices])
    prim.GetFaceVertexCountsAttr().Set([3] * len(mesh.faces))
    prim.GetFaceVertexIndicesAttr().Set([int(i) for i in mesh.faces.ravel()])
    move, turn = prim.AddTranslateOp(), prim.AddRotateZOp()
    for frame, (where, angle) in poses.items():
        move.Set(Gf.Vec3d(*where), Usd.TimeCode(frame))
        turn.Set(float(angle), Usd.TimeCode(frame))


@pytest.fixture(scope="module")
def stage():
    st = Usd.Stage.CreateInMemory()
    UsdGeom.Xform.Define(st, OBJECTS)
    box = trimesh.creation.box((0.2, 0.2, 0.2))
    ring = trimesh.creation.annulus(r_min=0.1, r_max=0.15, height=0.1)
    _mesh(st, "a", box, {0: ((0, 0, 0), 0), 1: ((0, 0, 0), 0)})
    # frame 1: a corner 2 cm past a's +x face and 1.3 cm short of its +y face, turned 10 degrees so that no
    # face is axis-aligned; 5 cm up, so that no vertex of either lies on the other's top or bottom
    _mesh(st, "b", box, {0: ((0.5, 0, 0), 0), 1: ((0.2 - 0.02 + 0.1 * (np.cos(np.radians(10)) + np.sin(np.radians(10))) - 0.1, 0, 0.05), 10)})
    # a near miss: turned 45 degrees off a's corner, its corners past a's sides (the boxes meet), 4 cm clear of a
    _mesh(st, "c", box, {0: ((-0.2, -0.2, 0), 45), 1: ((-0.2, -0.2, 0), 45)})
    _mesh(st, "ring", ring, {0: ((0, 1, 0), 0), 1: ((0, 1, 0), 0)})
    # in the ring's hole, clear of its wall: inside the ring's box and its hull, outside the ring itself
    _mesh(st, "peg", trimesh.creation.box((0.06, 0.06, 0.08)), {0: ((0, 1, 0), 0), 1: ((0, 1, 0), 0)})
    # through the ring's wall, about 1.5 cm deep in it at frame 1 (the wall is a polygon), clear of it at frame 0
    _mesh(st, "stick", trimesh.creation.box((0.05, 0.05, 0.05)),
          {0: ((0.3, 1, 0), 0), 1: ((-0.15 - 0.025 + 0.015, 1, 0), 0)})
    st.SetStartTimeCode(0)
    st.SetEndTimeCode(1)
    return st


def test_same_pairs_and_depths_as_the_full_computation(stage):
    meshes = WorldMeshes(stage)
    fast = Penetrations(meshes)
    for t in (0, 1):
        full = overlaps(meshes.at(t))
        got = fast.pairs(t)
        assert set(got) == set(full), t
        for pair, depth in full.items():
            assert got[pair] == pytest.approx(depth, abs=1e-9), (t, pair)
    got = fast.pairs(1)
    assert set(got) == {("a", "b"), ("ring", "stick")}
    assert 0.01 < got[("ring", "stick")] <= 0.015
    assert 0.012 < got[("a", "b")] < 0.02


def test_near_misses_pass_every_box_test(stage):
    """The near misses are what pruning by boxes cannot settle: c's box and the peg's meet a's and the
    ring's, and the peg lies inside the ring's hull, so only the meshes themselves say they do not overlap."""
    m = WorldMeshes(stage).at(1)
    for x, y in (("c", "a"), ("peg", "ring")):
        assert np.all(m[x].bounds[0] <= m[y].bounds[1]) and np.all(m[y].bounds[0] <= m[x].bounds[1])
    assert m["a"].contains(m["c"].vertices).sum() == 0
    assert m["ring"].convex_hull.contains(m["peg"].vertices).any()


def test_shot_checks_reports_the_deepest(stage):
    checks = shot_checks(stage, 2)
    assert checks["max_penetration_m"] == round(max(max(overlaps(WorldMeshes(stage).at(t)).values(), default=0)
                                                    for t in (0, 1)), 5)
    assert checks["max_penetration_m"] > 0.015


def test_one_mesh_overlaps_nothing():
    st = Usd.Stage.CreateInMemory()
    UsdGeom.Xform.Define(st, OBJECTS)
    _mesh(st, "a", trimesh.creation.box((0.2, 0.2, 0.2)), {0: ((0, 0, 0), 0)})
    assert Penetrations(WorldMeshes(st)).pairs(0) == {}
    assert shot_checks(st, 1)["max_penetration_m"] == 0
