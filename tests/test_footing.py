"""With nothing pushed nothing tips (issue 38, part 1): a lifted solid whose centre of mass overhangs its lowest
points (a box seen across a corner, extruded, stands on an edge) has the least slice flattened off its bottom
(``align.support.stable_footing``) and is lowered by it; one that already stands is left as it is."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from physomni_usd.align.support import MAX_FOOT_CUT, _holds, stable_footing


def _prism(outline, depth=0.01, per_side=20) -> trimesh.Trimesh:
    """A closed prism of the polygon ``outline`` (k, 2) in the x-z plane, extruded ``depth`` along y, its
    outline sampled densely as a lifted silhouette's is."""
    pts = np.concatenate([a + (b - a) * t[:, None] for a, b in zip(outline, np.roll(outline, -1, 0))
                          for t in [np.linspace(0, 1, per_side, endpoint=False)]])
    k = len(pts)
    mid = pts.mean(0)
    v = np.vstack([np.c_[pts[:, 0], np.zeros(k), pts[:, 1]], np.c_[pts[:, 0], np.full(k, depth), pts[:, 1]],
                   [mid[0], 0.0, mid[1]], [mid[0], depth, mid[1]]])
    f = []
    for i in range(k):
        j = (i + 1) % k
        f += [[i, j, k + j], [i, k + j, k + i], [2 * k, j, i], [2 * k + 1, k + i, k + j]]
    m = trimesh.Trimesh(v, np.array(f), process=False)
    m.fix_normals()
    return m


def _stands(v, faces) -> bool:
    m = trimesh.Trimesh(v, faces, process=False)
    return _holds(v[v[:, 2] <= v[:, 2].min() + 1e-3][:, :2], m.center_mass[:2])


def test_a_prism_on_its_corner_edge_gets_a_flat_foot_and_stays_where_it_stood():
    m = _prism(np.array([(0.0, 0.0), (0.03, 0.01), (0.02, 0.03), (-0.005, 0.02)]))
    assert m.is_volume and not _stands(m.vertices, m.faces)
    v, cut = stable_footing(m.vertices, m.faces)
    assert 0 < cut <= MAX_FOOT_CUT * 0.03
    assert _stands(v, m.faces)
    assert v[:, 2].min() == pytest.approx(0.0, abs=1e-9)  # lowered by the slice: still on the ground
    assert np.ptp(v[:, :2], axis=0) == pytest.approx(np.ptp(m.vertices[:, :2], axis=0))


@pytest.mark.parametrize("shape", ["box", "ball"])
def test_what_already_stands_is_left_alone(shape):
    m = trimesh.creation.box((0.1, 0.06, 0.2)) if shape == "box" else trimesh.creation.icosphere(radius=0.04)
    m.apply_translation([0.0, 0.0, -m.bounds[0][2]])
    v, cut = stable_footing(m.vertices, m.faces)
    assert cut == 0.0 and np.array_equal(v, m.vertices)
