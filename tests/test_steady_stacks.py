"""Issue 38, part 1 (nothing unpushed moves): the build's steadying pass (``physics.support.steady_stacks``)
on meshes made here. A rounded object gets a flat foot where it rests, a box stacked forward of the box under it
is brought over that box's top, the cheapest way for the photo's camera, and a stepped top is made flat under
what stands on it. The simulated effect is measured by ``bench general`` and tests/test_gallery_rest.py."""

from __future__ import annotations

import numpy as np
import trimesh

from physomni_usd.geometry.resting import steady_margin
from physomni_usd.physics.support import (FOOT_FRACTION, SEAT_DEPTH, _outside, _top_under, flat_foot, overhang,
                                          raise_top, steady_stacks)


def _box(size, centre):
    m = trimesh.creation.box(size)
    m.apply_translation(centre)
    return trimesh.Trimesh(m.vertices, m.faces)


def test_a_ball_gets_a_flat_foot_and_a_box_keeps_its_own():
    ball = trimesh.creation.icosphere(subdivisions=3, radius=0.035)
    ball.apply_translation([0, 0, 0.035])
    pts, cut = flat_foot(ball.vertices)
    assert 0 < cut <= 0.05 * 0.07
    assert abs(pts[:, 2].min()) < 1e-9  # it rests where it did
    foot = pts[pts[:, 2] <= 1e-6, :2]
    from scipy.spatial import ConvexHull
    assert np.sqrt(ConvexHull(foot).volume / np.pi) >= FOOT_FRACTION * 0.035 * 0.9
    box = _box((0.1, 0.06, 0.04), (0, 0, 0.02))
    same, cut = flat_foot(box.vertices)
    assert cut == 0 and np.array_equal(same, box.vertices)


def test_a_box_stacked_forward_of_its_support_is_brought_over_it_along_the_line_of_sight():
    lower = _box((0.2, 0.08, 0.2), (0, 0, 0.1))
    upper = _box((0.12, 0.05, 0.2), (0, -0.06, 0.3))  # 6 cm nearer the camera: its centre beyond the top
    eye = np.array([0.0, -2.0, 0.3])  # level view from the front: depth is what the photo cannot show
    com = upper.center_mass
    top = _top_under(lower.vertices, 0.2, 0.01)
    assert _outside(top, com[:2]) > 0
    verts, done = steady_stacks([lower.vertices, upper.vertices], [lower.faces, upper.faces], {1: (0, "on")}, eye)
    moved = verts[1].mean(axis=0) - upper.vertices.mean(axis=0)
    new_com = com + moved
    assert _outside(top, new_com[:2]) <= -0.009, done
    assert abs(moved[0]) < 0.1 * abs(moved[1]) and abs(moved[2]) < 1e-9, moved  # along the sight (y), level
    assert np.array_equal(verts[0], lower.vertices)


def test_a_stepped_top_is_made_flat_under_the_foot_only():
    lower = _box((0.2, 0.08, 0.2), (0, 0, 0.1))
    v = lower.vertices.copy()
    v[(v[:, 0] > 0) & (v[:, 2] > 0.19), 2] = 0.19  # the right half of the top 1 cm lower: a step
    foot = np.array([[-0.05, -0.03], [0.08, -0.03], [0.08, 0.03], [-0.05, 0.03]])
    raised = raise_top(v, foot, 0.2)
    assert raised[:, 2].max() == 0.2
    assert np.all(raised[np.abs(raised[:, 0]) > 0.09, 2] <= v[np.abs(v[:, 0]) > 0.09, 2] + 1e-12)  # beyond: kept
    assert overhang(np.column_stack([foot, np.full(4, 0.2)]), np.array([0.0, 0.0, 0.3])) <= 0


def _ball(z, x=0.0):
    b = trimesh.creation.icosphere(subdivisions=3, radius=0.035)
    b.apply_translation([x, 0, z])
    return b


def test_a_ball_on_a_ball_stands_over_its_crown_on_flat_faces_of_both():
    """A pile read as a column: balanced dome on dome, the solver's first tremor rolls the upper one off. It is
    brought over the lower one's crown, both are cut flat where they meet, and it rests on that face."""
    below, held = _ball(0.035), _ball(0.105, x=0.006)
    verts, done = steady_stacks([below.vertices, held.vertices], [below.faces, held.faces], {1: (0, "on")}, None)
    crowned = [d for d in done if "crown_cut_m" in d]
    assert [d["object"] for d in crowned] == [1], done
    top, foot = float(verts[0][:, 2].max()), float(verts[1][:, 2].min())
    assert abs(foot - top) < 1e-9  # resting on the face, neither floating nor sunk
    assert top < float(below.vertices[:, 2].max()) - 1e-3  # the lower one's crown was cut
    r = np.ptp(verts[1][:, :2], axis=0).min() / 2
    sole = verts[1][verts[1][:, 2] <= foot + 1e-9, :2]
    crown = verts[0][verts[0][:, 2] >= top - 1e-9, :2]
    assert np.ptp(sole, axis=0).min() > 0.3 * r and np.ptp(crown, axis=0).min() > 0.3 * r  # faces, not points
    com = trimesh.Trimesh(verts[1], held.faces).center_mass
    assert _outside(crown, com[:2]) <= -steady_margin(sole), com  # well inside the face, its weight on it
    assert np.allclose(verts[1][:, :2], held.vertices[:, :2])  # held there: not moved off where the photo shows it


def test_a_ball_beside_a_crown_is_seated_on_a_wider_face_rather_than_carried_onto_the_crown():
    """A fruit of a pile's hollow read as on one fruit, 2.5 cm beside its crown across the line of sight: carried
    onto the crown its image moved half its width off its outline. The crown is cut deeper under it (hidden by
    it) into a face wide enough to hold it nearer where it stands; its image moves least, and it holds."""
    below, held = _ball(0.035), _ball(0.095, x=0.025)
    eye = np.array([0.0, -0.6, 0.3])  # looking along +y: x is across the line of sight
    verts, done = steady_stacks([below.vertices, held.vertices], [below.faces, held.faces], {1: (0, "on")}, eye)
    seated = [d for d in done if d.get("object") == 1 and "crown_cut_m" in d]
    assert seated, done
    moved = float(np.linalg.norm(verts[1][:, :2].mean(0) - held.vertices[:, :2].mean(0)))
    drop = float(held.vertices[:, 2].max() - verts[1][:, 2].max())
    assert moved + drop < 0.016, (moved, drop)  # onto the crown: 25 mm sideways
    top, foot = float(verts[0][:, 2].max()), float(verts[1][:, 2].min())
    assert abs(foot - top) < 1e-9
    assert seated[0]["crown_cut_m"] <= SEAT_DEPTH * 0.07 + 1e-4  # hidden under it, a few mm
    sole = verts[1][verts[1][:, 2] <= foot + 1e-9, :2]
    crown = verts[0][verts[0][:, 2] >= top - 1e-9, :2]
    com = trimesh.Trimesh(verts[1], held.faces).center_mass
    assert _outside(crown, com[:2]) <= -steady_margin(sole) + 1e-6 and _outside(sole, com[:2]) < 0, com


def test_a_heavy_ball_seated_off_the_crown_of_a_light_one_keeps_the_pair_over_the_light_one_s_foot():
    """A lemon read as on a smaller orange, 15 mm off its axis: seated there on a wide cut of the orange's crown,
    it held, but the two together leaned past the orange's narrow foot; the orange tipped and both fell 21 cm.
    It is brought only as near its place as leaves the pair's centre of mass (by volume) over that foot."""
    below = trimesh.creation.icosphere(subdivisions=3, radius=0.03)
    below.apply_translation([0, 0, 0.03])
    held = trimesh.creation.icosphere(subdivisions=3, radius=0.045)
    held.apply_translation([0.02, 0, 0.03 + np.sqrt(0.075 ** 2 - 0.02 ** 2)])
    eye = np.array([0.0, -0.6, 0.3])  # looking along +y: x is across the line of sight
    verts, done = steady_stacks([below.vertices, held.vertices], [below.faces, held.faces], {1: (0, "on")}, eye)
    assert [d for d in done if d.get("object") == 1 and "crown_cut_m" in d], done
    low = float(verts[0][:, 2].min())
    foot = verts[0][verts[0][:, 2] <= low + 1e-6, :2]
    solids = [trimesh.Trimesh(v, f) for v, f in zip(verts, [below.faces, held.faces])]
    pair = np.average([s.center_mass for s in solids], axis=0, weights=[s.volume for s in solids])
    assert _outside(foot, pair[:2]) <= -steady_margin(foot) + 1e-6, (pair, done)
    top, sole = float(verts[0][:, 2].max()), float(verts[1][:, 2].min())
    assert abs(sole - top) < 1e-9  # still resting on the cut face
    crown = verts[0][verts[0][:, 2] >= top - 1e-9, :2]
    assert _outside(crown, solids[1].center_mass[:2]) < 0
    # brought no farther than that: not carried onto the crown's middle, 20 mm across the sight
    assert float(verts[1][:, 0].mean() - held.vertices[:, 0].mean()) > -0.018, done


def test_a_ball_on_a_rim_keeps_its_round_foot():
    """An orange in a bowl's mouth rests on the rim by its roundness: flattened there, it fell 24 cm."""
    ring = trimesh.creation.annulus(r_min=0.03, r_max=0.036, height=0.05)
    ring.apply_translation([0, 0, 0.025])
    held = _ball(0.05 + np.sqrt(0.035 ** 2 - 0.033 ** 2))
    verts, done = steady_stacks([ring.vertices, held.vertices], [ring.faces, held.faces], {1: (0, "on")}, None)
    assert not [d for d in done if d["object"] == 1], done
    assert np.array_equal(verts[1], held.vertices)


def test_a_stack_is_steadied_by_the_load_each_object_carries_not_by_its_own_centre():
    # each alone is over the top under it by more than the margin, but the middle box with the tall one on
    # it overhangs the bottom box's back edge: unpushed, the two fall off together
    bottom = _box((0.2, 0.10, 0.03), (0, 0, 0.015))
    middle = _box((0.2, 0.10, 0.03), (0, 0.035, 0.045))
    top = _box((0.2, 0.06, 0.10), (0, 0.06, 0.11))
    supports = {1: (0, "on"), 2: (1, "on")}
    meshes = [bottom, middle, top]
    region = _top_under(bottom.vertices, 0.03, 0.01)
    assert _outside(region, middle.center_mass[:2]) < -0.01
    assert _outside(_top_under(middle.vertices, 0.06, 0.01), top.center_mass[:2]) < -0.01
    w = np.array([middle.volume, top.volume])
    load = np.average([middle.center_mass, top.center_mass], axis=0, weights=w)
    assert _outside(region, load[:2]) > 0  # the pair's centre beyond the bottom box's top
    eye = np.array([0.0, -2.0, 0.1])  # level, from the front: the depth the photo hardly shows
    verts, done = steady_stacks([m.vertices for m in meshes], [m.faces for m in meshes], supports, eye)
    moved = [verts[k].mean(axis=0) - meshes[k].vertices.mean(axis=0) for k in range(3)]
    assert np.allclose(moved[1], moved[2]), moved  # the top box goes with the one under it
    assert _outside(region, (load + moved[1])[:2]) <= -0.009, done
    assert abs(moved[1][2]) < 1e-9 and abs(moved[1][0]) < 0.25 * abs(moved[1][1])  # level, along the sight (a grid step across)
    assert np.array_equal(verts[0], bottom.vertices)


def test_a_slanted_sole_is_made_level_where_it_holds_the_centre_of_mass():
    """A lifted box whose foot follows a slanted outline edge stands on one end with its centre of mass beyond
    it and tips until the other end touches; its sole, flattened the least height that holds that centre, stands."""
    box = trimesh.creation.box(extents=(0.2, 0.05, 0.12))
    box = box.subdivide().subdivide()
    v = box.vertices + [0, 0, 0.06]
    bottom = v[:, 2] < 1e-9
    v[bottom, 2] = 0.008 * (v[bottom, 0] + 0.1) / 0.2  # 8 mm higher at the right end
    com = trimesh.Trimesh(v, box.faces).center_mass
    assert overhang(v[v[:, 2] <= 1e-3], com) > 0  # on its left end only
    verts, done = steady_stacks([v], [box.faces], {}, None)
    levelled = [d for d in done if "level_sole_m" in d]
    assert levelled and 0 < levelled[0]["level_sole_m"] <= 0.008, done
    sole = verts[0][verts[0][:, 2] <= 1e-9]
    assert overhang(sole, com) < -0.005 and float(verts[0][:, 2].min()) == 0.0
    moved = verts[0][~bottom] - v[~bottom]  # the rest only as its foot's cut lowered the whole (flat_foot)
    assert np.allclose(moved[:, :2], 0) and np.ptp(moved[:, 2]) < 1e-9


def test_a_cut_that_leaves_a_round_thing_thinner_than_round_is_told_from_one_that_does_not():
    import trimesh

    from physomni_usd.physics.support import _thinned

    ball = trimesh.creation.icosphere(subdivisions=3, radius=0.04).vertices
    shaved = ball.copy()
    shaved[:, 2] = np.maximum(shaved[:, 2], -0.04 + 0.003)  # a 3 mm sole: still round
    flattened = ball.copy()
    flattened[:, 2] = np.maximum(flattened[:, 2], -0.04 + 0.02)  # a quarter of its depth gone
    assert not _thinned(ball, shaved)
    assert _thinned(ball, flattened)
    slab = ball * np.array([1.0, 1.0, 0.5])  # thin to start with: a cut does not make it so
    cut = slab.copy()
    cut[:, 2] = np.maximum(cut[:, 2], -0.015)
    assert not _thinned(slab, cut)


def test_a_ball_on_a_bowl_s_inner_floor_gets_a_flat_foot_and_one_on_a_crate_s_top_does_not():
    """On a bowl's flat inner floor a ball wanders with nothing pushing it (5 cm in 2 s), and the walls stop a
    pushed one anyway: walled in, it gets the foot it gets on the ground. On a crate's open top it keeps its
    round foot, so that a pushed ball rolls (tests/test_studio_pushes.py)."""
    from physomni_usd.lift.rim import vessel_frame
    from physomni_usd.lift.vessel import vessel_mesh

    bowl = vessel_mesh(np.array([0.0, 0.0]), 0.063, 0.084, 0.057)
    floor = vessel_frame(bowl.vertices)["floor_z"]
    in_bowl = _ball(floor + 0.035, x=0.01)
    verts, done = steady_stacks([bowl.vertices, in_bowl.vertices], [bowl.faces, in_bowl.faces], {1: (0, "on")}, None)
    assert [d["object"] for d in done if "flat_foot_m" in d] == [1], done
    sole = verts[1][verts[1][:, 2] <= verts[1][:, 2].min() + 1e-9, :2]
    assert np.ptp(sole, axis=0).min() > FOOT_FRACTION * 0.035  # a face, not a point
    assert abs(float(verts[1][:, 2].min()) - floor) < 1e-9  # where it stood
    crate = _box((0.3, 0.3, 0.2), (0, 0, 0.1))
    on_top = _ball(0.2 + 0.035)
    verts, done = steady_stacks([crate.vertices, on_top.vertices], [crate.faces, on_top.faces], {1: (0, "on")}, None)
    assert not [d for d in done if d["object"] == 1], done


def _slanted_slab_on_a_book():
    """A cup lifted as a slab (6.9 cm wide, 2.6 cm deep, 9.5 cm tall) whose foot follows its outline's slanted
    lower edge, 8 mm higher at its right end, standing by its left end on a book (241611/038): its centre of
    mass lies 17 mm beyond the 2 mm it touches with, and 10 mm of contact band take in its whole foot."""
    book = _box((0.24, 0.17, 0.03), (0.0, 0.0, 0.015))
    slab = trimesh.creation.box(extents=(0.069, 0.0256, 0.095)).subdivide().subdivide()
    v = slab.vertices + [0.0, 0.0, 0.03 + 0.0475]
    bottom = v[:, 2] < 0.03 + 1e-9
    v[bottom, 2] = 0.03 + 0.008 * (v[bottom, 0] + 0.0345) / 0.069
    return book, trimesh.Trimesh(v, slab.faces, process=False)


def _settled(tmp_path, book_verts, book_faces, cup_verts, cup_faces):
    from physomni_usd.bench.scenes import BenchObject, write_bench_shot
    from physomni_usd.physics.settle import settle_shot
    from physomni_usd.usd import layers

    wood = {"density": 700.0, "restitution": 0.2, "dynamic_friction": 0.45, "static_friction": 0.5}
    shot = write_bench_shot(tmp_path, [BenchObject("book", trimesh.Trimesh(book_verts, book_faces), "rigid", wood),
                                       BenchObject("cup", trimesh.Trimesh(cup_verts, cup_faces), "rigid", wood)])
    return settle_shot(layers.open_shot(shot, mute_sim=True), 2.0).motions


def test_a_stacked_slab_on_a_slanted_foot_gets_a_level_sole_and_stays(tmp_path):
    """Judged on its 10 mm contact band the slab stands; on what touches it does not: left as lifted, it rocks
    onto its foot's far end (turned over 5°). Levelled as an object on the ground is, it stands still for 2 s
    with nothing pushing it."""
    book, slab = _slanted_slab_on_a_book()
    com = slab.center_mass
    assert overhang(slab.vertices, com) < -0.005  # the contact band reads it standing
    low = slab.vertices[:, 2].min()
    assert overhang(slab.vertices[slab.vertices[:, 2] <= low + 0.002], com) > 0.01  # what touches does not hold it
    verts, done = steady_stacks([book.vertices, slab.vertices], [book.faces, slab.faces], {1: (0, "on")}, None)
    assert [d["object"] for d in done if "level_sole_m" in d] == [1], done
    assert float(verts[1][:, 2].min()) == low and np.array_equal(verts[0], book.vertices)
    levelled = _settled(tmp_path / "levelled", verts[0], book.faces, verts[1], slab.faces)
    for name in ("book", "cup"):
        m = levelled[name]
        assert np.linalg.norm(m.translation) < 0.01 and m.turned_deg < 1.0, (name, m)
    as_lifted = _settled(tmp_path / "lifted", book.vertices, book.faces, slab.vertices, slab.faces)
    assert as_lifted["cup"].turned_deg > 5.0, as_lifted["cup"]


def _wedge(deg):
    """A 30 x 20 cm block whose top, 10 cm up in its middle, rises ``deg`` towards +x; and that top's height."""
    t = np.tan(np.radians(deg))
    w = trimesh.creation.box((0.3, 0.2, 0.1)).subdivide().subdivide()
    v = w.vertices + [0.0, 0.0, 0.05]
    top = v[:, 2] > 0.099
    v[top, 2] = 0.1 + t * v[top, 0]
    return trimesh.Trimesh(v, w.faces, process=False), lambda p: p[:, 2] - (0.1 + t * p[:, 0])


def test_a_box_flush_on_a_slanted_top_stands_on_its_whole_sole_and_does_not_sink_into_it():
    """Its real contact is measured from the top under it, not from its own lowest point: all its sole touches.
    Judged from its lowest point it touched along one edge, got a 4.2 mm level sole and started that deep in
    the top."""
    wedge, gap = _wedge(4.0)
    box = trimesh.creation.box((0.08, 0.06, 0.08)).subdivide().subdivide()
    box.apply_transform(trimesh.transformations.rotation_matrix(np.radians(4.0), [0, -1, 0]))
    box.apply_translation([0.0, 0.0, 0.2])
    box.apply_translation([0.0, 0.0, -gap(box.vertices).min()])
    verts, done = steady_stacks([wedge.vertices, box.vertices], [wedge.faces, box.faces], {1: (0, "on")},
                                np.array([0.0, -1.0, 0.3]))
    assert not [d for d in done if "level_sole_m" in d or "unsteady_m" in d], done
    assert float(gap(verts[1]).min()) > -1e-6, done


def test_a_level_sole_that_would_sink_into_a_slanted_top_is_refused_and_recorded():
    """The slab's foot rises 11.6 % to the right, the top under it 7 %: it touches at its left end, its centre
    of mass not the margin inside that. Flattened to its lowest point its right end would sink 4.8 mm into the
    top (a start overlap); it is left as it is and recorded. (What the later pass does with a slab on a ridge,
    a seat cut in the top, is not this test's.)"""
    wedge, gap = _wedge(4.0)
    _, slab = _slanted_slab_on_a_book()
    v = slab.vertices + [0.0, 0.0, 0.2]
    v[:, 2] -= gap(v).min()
    verts, done = steady_stacks([wedge.vertices, v], [wedge.faces, slab.faces], {1: (0, "on")}, None)
    assert not [d for d in done if "level_sole_m" in d] and [d["object"] for d in done if "unsteady_m" in d] == [1]


def test_the_contact_over_a_top_does_not_change_with_how_finely_the_object_is_meshed():
    """A box whose centre of mass is 12 mm inside a book's edge stands (the margin is 10 mm), on its 8 corners
    or subdivided twice; 4 mm inside, it is brought the same 6 mm in either way. The contact over the top was
    the box's vertices over it: subdivided, the nearest row lay a grid step inside the edge and it moved 2.5 mm."""
    book = _box((0.24, 0.17, 0.03), (0.0, 0.0, 0.015))
    shifts = {}
    for inside in (0.012, 0.004):
        for sub in (0, 2):
            box = _box((0.08, 0.06, 0.08), (0.12 - inside, 0.0, 0.07))
            for _ in range(sub):
                box = box.subdivide()
            verts, done = steady_stacks([book.vertices, box.vertices], [book.faces, box.faces], {1: (0, "on")},
                                        np.array([0.0, -1.0, 0.4]))
            shifts[inside, sub] = float(np.linalg.norm((verts[1] - box.vertices)[0, :2]))
    assert shifts[0.012, 0] == shifts[0.012, 2] == 0.0, shifts
    assert 0.005 < shifts[0.004, 0] and abs(shifts[0.004, 0] - shifts[0.004, 2]) < 1e-3, shifts


def test_a_load_much_heavier_than_a_light_supporter_keeps_a_wider_margin():
    """A cup-sized box six times its book's mass, 12 mm inside the book's top, is brought further in only where
    its label's density says so: the light book leans under it (241611/054's cup slid off at 10 mm)."""
    book = _box((0.2, 0.14, 0.02), (0.0, 0.0, 0.01))
    cup = _box((0.1, 0.1, 0.1), (0.1 - 0.012, 0.0, 0.07))
    eye = np.array([0.0, -1.0, 0.4])
    for labels, moved in ((None, False), (["book", "cup"], True)):
        verts, done = steady_stacks([book.vertices, cup.vertices], [book.faces, cup.faces], {1: (0, "on")}, eye,
                                    labels)
        assert bool([d for d in done if d.get("shift_m", 0) > 0.001]) == moved, (labels, done)


def test_the_margin_of_a_thin_foot_does_not_change_as_it_turns():
    """A 20 x 2 cm foot keeps its centre of mass a quarter of its width inside, 5 mm, however it is turned: on
    its extent along x and y, turned 45° it was read as 14 mm wide and kept the full 10 mm."""
    strip = np.array([[0.0, 0.0], [0.2, 0.0], [0.2, 0.02], [0.0, 0.02]])
    for deg in (0.0, 30.0, 45.0):
        r = np.radians(deg)
        turned = strip @ np.array([[np.cos(r), -np.sin(r)], [np.sin(r), np.cos(r)]]).T
        assert abs(steady_margin(turned) - 0.005) < 1e-9, deg


def _tall_slab_on_a_narrow_foot():
    """A bowl squashed to a slab 9 cm wide, 16.6 mm deep and 92 mm tall to make room for a ball beside it
    (587774/046), on a book: its sole rises 4 mm over its right half, so it touches with its left half only, its
    centre of mass 4.8 mm inside that, more than a quarter of the foot's 16.6 mm width (4.2 mm)."""
    book = _box((0.24, 0.17, 0.03), (0.0, 0.0, 0.015))
    side = [(-0.045, 0.0), (0.0045, 0.0), (0.045, 0.004), (0.045, 0.092), (-0.045, 0.092)]
    hull = trimesh.convex.convex_hull(np.array([(x, y, 0.03 + z) for x, z in side for y in (-0.0083, 0.0083)]))
    return book, trimesh.Trimesh(hull.vertices, hull.faces)


def test_a_tall_slab_on_a_narrow_foot_is_kept_steady_against_a_tilt_not_only_by_its_width(tmp_path):
    """The width rule passed it, and in its scene it tipped (at 5.3°) and fell 15 cm: its centre of mass 46 mm
    up needs more than 4.8 mm to hold. Judged by the tilt it must bear, its sole is levelled, and it stands still
    for 2 s."""
    book, slab = _tall_slab_on_a_narrow_foot()
    com = slab.center_mass
    low = float(slab.vertices[:, 2].min())
    touch = slab.vertices[slab.vertices[:, 2] <= low + 0.002]
    assert -0.0049 < overhang(touch, com) < -0.0047 and steady_margin(touch[:, :2]) < 0.0045
    verts, done = steady_stacks([book.vertices, slab.vertices], [book.faces, slab.faces], {1: (0, "on")}, None)
    assert [d["object"] for d in done if "level_sole_m" in d] == [1], done
    levelled = _settled(tmp_path, verts[0], book.faces, verts[1], slab.faces)
    for name in ("book", "cup"):
        m = levelled[name]
        assert np.linalg.norm(m.translation) < 0.01 and m.turned_deg < 1.0, (name, m)
