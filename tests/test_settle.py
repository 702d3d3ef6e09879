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


def _bowl_and_apple():
    """A 16 cm bowl 5.7 cm tall and, as the lift stood it, an apple on its front rim's edge, its centre over the
    mouth, seen from a camera in front and above."""
    from physomni_usd.lift.vessel import vessel_mesh

    bowl = vessel_mesh(np.array([0.0, 0.0]), 0.063, 0.084, 0.057)
    apple = trimesh.creation.icosphere(subdivisions=3, radius=0.034)
    apple.apply_translation([0.0, -0.066, 0.057 + 0.034])  # its lowest point at the rim's height
    eye = np.array([0.0, -0.45, 0.40])
    return bowl, apple, eye


def test_an_apple_held_over_a_bowl_s_mouth_goes_down_the_camera_s_rays_onto_its_inner_floor():
    from physomni_usd.lift.rim import vessel_frame

    bowl, apple, eye = _bowl_and_apple()
    verts, rise = settle_on_supports([bowl.vertices, apple.vertices], [bowl.faces, apple.faces],
                                     {1: (0, "contact")}, [True, False], eye)
    f = vessel_frame(bowl.vertices)
    assert abs(float(verts[1][:, 2].min()) - f["floor_z"]) < 1e-3  # on the inner floor, not the rim
    assert rise[1] < -0.04 and rise[0] == 0.0
    assert np.array_equal(verts[0], bowl.vertices)
    inside = trimesh.proximity.signed_distance(trimesh.Trimesh(verts[0], bowl.faces), verts[1])
    assert float(inside.max()) <= 5e-4  # clear of the wall it passed
    # its outline in the photo is kept: every vertex on the same ray from the camera
    a = (apple.vertices - eye) / np.linalg.norm(apple.vertices - eye, axis=1, keepdims=True)
    b = (verts[1] - eye) / np.linalg.norm(verts[1] - eye, axis=1, keepdims=True)
    assert float(np.abs(a - b).max()) < 1e-9
    # without the vessel flag or the camera it is left where it is (a plant on a pot's rim goes by lift.rim)
    for vessels, where in (([False, False], eye), ([True, False], None)):
        kept, _ = settle_on_supports([bowl.vertices, apple.vertices], [bowl.faces, apple.faces],
                                     {1: (0, "contact")}, vessels, where)
        assert np.array_equal(kept[1], apple.vertices)


def test_what_is_wider_than_a_vessel_s_mouth_is_not_put_into_it():
    from physomni_usd.align.support import into_vessel

    bowl, _, eye = _bowl_and_apple()
    melon = trimesh.creation.icosphere(subdivisions=3, radius=0.09)
    melon.apply_translation([0.0, 0.0, 0.057 + 0.09])
    assert into_vessel(melon.vertices, bowl.vertices, eye) is None
