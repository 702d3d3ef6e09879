"""Issue 38, part 1 (nothing unpushed moves): a rounded object the build stood on a flat foot
(``physics.support.flat_foot``) keeps that foot in the collider Newton makes of it. Newton simplifies each
convex hull to ``physics.assembly.MAX_HULL_VERTICES``; a lifted sphere's hull has more than 256 vertices, and
cut to 256 it kept a few of the foot's, its centre of mass on the edge of what was left: a lemon alone on a
table rolled 25 mm (bench general seed 279413 scene 1)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.spatial import ConvexHull

from physomni_usd.physics.assembly import MAX_HULL_VERTICES
from physomni_usd.physics.support import FOOT_FRACTION, flat_foot


@pytest.mark.parametrize("stretch", [(1.0, 1.0, 1.0), (1.15, 1.0, 0.95), (1.0, 0.9, 1.1)])
def test_the_simulated_hull_of_a_flat_footed_fruit_keeps_its_foot(stretch):
    """A lemon-sized sphere as the lift makes them (642 vertices; stretched, a lemon's, an egg's), given its flat
    foot: the hull Newton builds from it has a foot whose inside holds the centre of mass by most of the
    foot's radius, as the mesh's own foot does."""
    import newton

    ball = trimesh.creation.icosphere(subdivisions=3, radius=0.035)
    ball.apply_scale(stretch)
    ball.apply_translation((0.0, 0.0, -ball.vertices[:, 2].min()))
    assert len(ball.convex_hull.vertices) > 256
    pts, cut = flat_foot(ball.vertices)
    assert cut > 0
    com = trimesh.Trimesh(pts, ball.faces, process=False).center_mass
    hull = newton.Mesh(pts.astype(np.float32), ball.faces.ravel().astype(np.int32),
                       maxhullvert=MAX_HULL_VERTICES).compute_convex_hull()
    v = np.asarray(hull.vertices, float)
    foot = v[v[:, 2] <= v[:, 2].min() + 1e-4, :2]
    assert len(foot) >= 3, len(foot)
    eq = ConvexHull(foot).equations
    inside = -float((eq[:, :2] @ com[:2] + eq[:, 2]).max())  # > 0: the centre of mass is over the foot
    half = 0.5 * float(np.ptp(pts[:, :2], axis=0).min())
    assert inside >= 0.5 * FOOT_FRACTION * half, (inside, len(foot))
