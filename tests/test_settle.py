"""An object that starts inside what holds it is raised onto it, with what rests on it; nothing else moves."""

from __future__ import annotations

import numpy as np
import trimesh

from physomni_usd.align.support import SETTLE_TOLERANCE_M, settle_on_supports, start_contacts


def _box(size, centre):
    m = trimesh.creation.box(size)
    m.apply_translation(centre)
    return m


def test_an_object_sunk_into_its_support_is_raised_with_what_rests_on_it():
    crate = _box((0.4, 0.4, 0.2), (0, 0, 0.1))  # top at 0.2
    book = _box((0.2, 0.15, 0.04), (0.05, 0, 0.2 + 0.02 - 0.006))  # 6 mm inside the crate
    cup = _box((0.06, 0.06, 0.08), (0.05, 0, 0.234 + 0.04))  # on the book's top (0.234)
    ball = _box((0.1, 0.1, 0.1), (0.6, 0, 0.05))  # on the ground beside them
    meshes = [crate, book, cup, ball]
    supports = {1: (0, "contact"), 2: (1, "contact")}
    verts, rise = settle_on_supports([m.vertices for m in meshes], [m.faces for m in meshes], supports)
    assert rise[0] == 0.0 and rise[3] == 0.0
    assert abs(rise[1] - 0.006) < 1e-6 and abs(rise[2] - 0.006) < 1e-6
    assert np.array_equal(verts[3], ball.vertices)
    starts = start_contacts(verts, [m.faces for m in meshes], supports, ["crate", "book", "cup", "ball"])
    assert [s["support"] for s in starts] == ["ground", "crate", "book", "ground"]
    assert all(s["overlap_m"] <= SETTLE_TOLERANCE_M for s in starts)
    assert abs(starts[1]["clearance_m"]) <= 1e-4 and abs(starts[2]["clearance_m"]) <= 1e-4


def test_an_object_resting_on_its_support_is_left_where_it_is():
    crate = _box((0.4, 0.4, 0.2), (0, 0, 0.1))
    book = _box((0.2, 0.15, 0.04), (0.05, 0, 0.22))
    verts, rise = settle_on_supports([crate.vertices, book.vertices], [crate.faces, book.faces],
                                     {1: (0, "contact")})
    assert rise == [0.0, 0.0] and np.array_equal(verts[1], book.vertices)
