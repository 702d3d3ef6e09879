"""How a lifted rigid object rests on what is under it, in the terms both the build's placement
(``align``: whether a pile's hollow holds a fruit) and the simulator's steadying (``physics.support``) judge
it by: its contact band, the margin its centre of mass keeps inside a top, the cap a rounded foot loses, and
the centre of mass of its solid. Metres; points (N, 3), world, z up."""

from __future__ import annotations

import numpy as np

from ..settings import REAL_CONTACT

#: Points within this of the lowest (m, or this fraction of its height if larger) are its contact.
CONTACT_BAND = 0.01
#: A stacked object's centre of mass is brought this far (m, or this fraction of its footprint's smaller side
#: if less) inside the top of what holds it: on the edge, the solver's rocking tips it.
STEADY_MARGIN = 0.01
#: The flattened cap of a rounded foot is at most this fraction of the object's height (an orange: 2-3 mm).
FOOT_CUT = 0.05


def contact_band(points: np.ndarray) -> float:
    """How far above its lowest point (m) a point of ``points`` (N, 3) is still in its contact:
    :data:`CONTACT_BAND`, or that fraction of its height where larger."""
    return max(CONTACT_BAND, CONTACT_BAND * float(np.ptp(points[:, 2])))


def real_contact(points: np.ndarray, top: np.ndarray | None = None) -> np.ndarray:
    """(K, 2): where ``points`` (N, 3) touch what they rest on, seen from above: those within
    :data:`~physomni_usd.settings.REAL_CONTACT` of the lowest, and where ``top`` (M, 2, the top of what holds it
    seen from above) is given, only those over its convex hull (a foot past a book's edge touches nothing)."""
    from scipy.spatial import ConvexHull, QhullError

    pts = np.asarray(points, float)
    feet = np.unique(np.round(pts[pts[:, 2] <= float(pts[:, 2].min()) + REAL_CONTACT, :2], 6), axis=0)
    if top is not None and len(feet):
        try:
            eq = ConvexHull(np.asarray(top, float)).equations
        except (QhullError, ValueError):
            return feet[:0]
        feet = feet[(feet @ eq[:, :2].T + eq[:, 2]).max(axis=1) <= 1e-9]
    return feet


def steady_margin(foot: np.ndarray) -> float:
    """How far (m) inside a top a centre of mass over ``foot`` (M, 2, its contact's points seen from above) is
    kept: :data:`STEADY_MARGIN`, or a quarter of the foot's smaller side where less."""
    return min(STEADY_MARGIN, 0.25 * float(np.ptp(foot, axis=0).min()) if len(foot) > 1 else STEADY_MARGIN)


def solid(points: np.ndarray, faces: np.ndarray):
    """The object as a trimesh solid: its own mesh where watertight with volume, else its convex hull."""
    import trimesh

    mesh = trimesh.Trimesh(points, faces, process=False)
    return mesh if mesh.is_watertight and mesh.volume > 0 else mesh.convex_hull


def solid_com(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """The centre of mass (3,) of :func:`solid` at one density."""
    return np.asarray(solid(points, faces).center_mass, float)
