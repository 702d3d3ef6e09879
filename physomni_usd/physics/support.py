"""Support a photo hides: a rigid object standing on the ground whose visible geometry cannot stand.

An object is lifted from the part of it the photo shows. Where the rest is hidden (a bench's far legs
behind a motorcycle) or its feet are seen at different heights (the near wheel of an angled motorcycle
lower in the frame than the far one), the lifted mesh touches the ground at one end only, its centre of
mass overhangs that contact, and it tips over by itself although the photo shows it at rest. Such an
object gets a second collision shape on its body: the convex hull of its points and their footprint on
the ground, without mass, so that it stands on its whole footprint; what it looks like, its mass and its
inertia stay those of the visible mesh."""

from __future__ import annotations

import numpy as np

from ..geometry.resting import (FOOT_CUT, contact_band, contact_over, hull_ring, real_contact, solid as _solid,
                                solid_com as _solid_com, steady_margin)
from ..settings import HEAVY_LOAD, HEAVY_LOAD_MARGIN

#: An object whose lowest point is within this of the ground (m, or this fraction of its size if larger)
#: stands on it.
ON_GROUND = 0.01
#: The centre of mass may be this far (m) outside the contact and still count as over it (a ball's
#: single contact point, a lying cylinder's contact line).
OVERHANG = 0.005


def _hull_out(feet: np.ndarray, c: np.ndarray) -> float:
    """Signed distance (m) of ``c`` (2,) outside the convex hull of ``feet`` (K, 2), ≤ 0 inside; inf where
    they span no area (fewer than three points, or a line)."""
    ring = hull_ring(feet)
    if not len(ring):
        return float("inf")
    e = np.roll(ring, -1, axis=0) - ring
    n = np.column_stack([e[:, 1], -e[:, 0]]) / np.maximum(np.linalg.norm(e, axis=1), 1e-18)[:, None]  # outward
    return float(np.einsum("kd,kd->k", np.asarray(c, float)[:2] - ring, n).max())


def overhang(points: np.ndarray, com: np.ndarray) -> float:
    """How far (m) the centre of mass ``com`` (3,) lies, seen from above, outside the convex hull of the
    lowest of ``points`` (N, 3, world, z up); ≤ 0 inside."""
    low = points[:, 2].min()
    band = contact_band(points)
    feet = np.unique(np.round(points[points[:, 2] <= low + band, :2], 6), axis=0)
    c = np.asarray(com, float)[:2]
    out = _hull_out(feet, c)
    if out < float("inf"):
        return out
    # a point or a line of contact: the distance to it
    a, b = feet[np.argmin(feet @ (feet[-1] - feet[0]))], feet[np.argmax(feet @ (feet[-1] - feet[0]))]
    ab = b - a
    s = np.clip((c - a) @ ab / max(ab @ ab, 1e-18), 0.0, 1.0)
    return float(np.linalg.norm(c - (a + s * ab)))


def needs_support(points: np.ndarray, faces: np.ndarray, ground_z: float) -> bool:
    """Whether an object (world ``points`` (N, 3), triangle ``faces`` (M, 3)) stands on the ground at
    ``ground_z`` with its centre of mass beyond its contact."""
    import trimesh

    size = float(np.ptp(points, axis=0).max())
    if abs(points[:, 2].min() - ground_z) > max(ON_GROUND, ON_GROUND * size):
        return False
    mesh = trimesh.Trimesh(points, faces, process=False)
    solid = mesh if mesh.is_watertight and mesh.volume > 0 else mesh.convex_hull
    return overhang(points, solid.center_mass) > OVERHANG


def body_frame(builder, b: int, wp) -> tuple[np.ndarray, np.ndarray]:
    """Body ``b``'s pose in ``builder`` (before ``finalize``): its origin (3,) and rotation (3, 3), world metres;
    a world point ``x`` is ``(x - origin) @ rotation`` in the body's frame."""
    pose = builder.body_q[b]
    origin = np.array([pose[0], pose[1], pose[2]], float)
    return origin, np.array(wp.quat_to_matrix(wp.quat(pose[3], pose[4], pose[5], pose[6])), float).reshape(3, 3)


def add_hidden_support(builder, objects, path_body: dict, ground_z: float, newton, wp) -> list[str]:
    """For each rigid object in ``objects`` that :func:`needs_support`, add a massless collision hull down
    to the ground to its body in ``builder`` (before ``finalize``), with the friction and restitution
    of its first shape. Returns the names of the objects supported."""
    import trimesh

    out = []
    for o in objects:
        b = path_body.get(o.path)
        if b is None or o.family != "rigid" or not needs_support(o.points, o.faces, ground_z):
            continue
        foot = o.points.copy()
        foot[:, 2] = ground_z
        hull = trimesh.convex.convex_hull(np.vstack([o.points, foot]))
        t, rot = body_frame(builder, b, wp)
        local = (hull.vertices - t) @ rot  # world → the body's frame
        cfg = newton.ModelBuilder.ShapeConfig()
        cfg.density = 0.0  # collision only: the visible mesh keeps the mass and the inertia
        shapes = builder.body_shapes.get(b) or []
        if shapes:
            cfg.mu = float(builder.shape_material_mu[shapes[0]])
            cfg.restitution = float(builder.shape_material_restitution[shapes[0]])
        builder.add_shape_convex_hull(b, mesh=newton.Mesh(local.astype(np.float32),
                                                          hull.faces.ravel().astype(np.int32)),
                                      cfg=cfg, label=f"{o.path}/hidden_support")
        out.append(o.name)
    return out




def _load_com(group, vertex_sets, faces) -> np.ndarray:
    """The centre of mass (3,) of the objects ``group`` (indices) together, each weighed by its volume: the
    materials are not estimated yet when the build steadies a stack, and one density is the least guess."""
    solids = [_solid(vertex_sets[k], faces[k]) for k in group]
    w = np.array([max(float(abs(s.volume)), 1e-12) for s in solids])
    return np.average([np.asarray(s.center_mass, float) for s in solids], axis=0, weights=w)


def _mass(group, vertex_sets, faces, labels) -> float:
    """The mass (kg) of the objects ``group`` (indices), their solids at their labels' table densities."""
    from ..materials.defaults import rigid_material

    return float(sum(_solid(vertex_sets[k], faces[k]).volume * rigid_material(labels[k]).density for k in group))


def _real_overhang(points: np.ndarray, com: np.ndarray, top: np.ndarray | None = None,
                   gap: np.ndarray | None = None) -> tuple[float, np.ndarray]:
    """How far (m) ``com`` lies, seen from above, outside ``points``' real contact
    (``geometry.resting.real_contact`` by ``gap``; cut by the convex hull of ``top`` where given,
    ``geometry.resting.contact_over``), ≤ 0 inside, and that contact (K, 2); inf where it spans no area (two
    points or a line): balanced there, the solver's first tremor tips it."""
    feet = real_contact(points, gap)
    if top is not None:
        feet = contact_over(feet, top)
    return _hull_out(feet, com), feet


def _stands(points: np.ndarray, com: np.ndarray, gap: np.ndarray | None = None) -> bool:
    """Whether ``points`` (N, 3), their centre of mass at ``com``, stand on their real contact (by ``gap``, as
    :func:`surface_gap` measures it over what holds them): that centre the steady margin inside it. The contact
    band reads a slanted foot as wide as its lowest centimetre; it stands only on what touches."""
    out, feet = _real_overhang(points, com, gap=gap)
    return out <= -steady_margin(feet, float(com[2]) - float(np.min(points[:, 2])))


def surface_gap(upper: np.ndarray, lower: np.ndarray, lower_faces: np.ndarray) -> np.ndarray:
    """(N,) m: how high each point of ``upper`` (N, 3) stands over the surface of ``lower`` (M, 3, triangle
    ``lower_faces``) straight under it (a ray cast down, as :func:`walled_in` does); over nothing of it, over
    the surface under the nearest point that is over it (the top goes on level past its edge); inf for points
    above ``upper``'s contact band, which touch nothing. A box flush on a 4° top touches with all its sole,
    not with the 2 mm over its lowest point, and levelled to that point it sank 4 mm into the top."""
    import trimesh

    pts = np.asarray(upper, float)
    gap = np.full(len(pts), np.inf)
    low = pts[:, 2] <= float(pts[:, 2].min()) + contact_band(pts)
    o = pts[low].copy()
    o[:, 2] = float(np.max(lower[:, 2])) + ON_FLOOR
    mesh = trimesh.Trimesh(lower, lower_faces, process=False)
    hits, ray, _ = mesh.ray.intersects_location(o, np.tile([0.0, 0.0, -1.0], (len(o), 1)))
    if not len(hits):
        gap[low] = pts[low, 2] - float(np.max(lower[:, 2]))
        return gap
    z = pts[low, 2]
    surf = np.full(len(o), -np.inf)
    # the highest hit not far above the point (a slight overlap still reads as resting on that face)
    keep = hits[:, 2] <= z[ray] + contact_band(pts)
    np.maximum.at(surf, ray[keep], hits[keep, 2])
    miss = ~np.isfinite(surf)
    if miss.all():
        np.maximum.at(surf, ray, hits[:, 2])
        miss = ~np.isfinite(surf)
    if miss.any():
        near = np.argmin(np.linalg.norm(o[miss, None, :2] - o[None, ~miss, :2], axis=2), axis=1)
        surf[miss] = surf[~miss][near]
    gap[low] = z - surf
    return gap


def _top_under(supporter: np.ndarray, base_z: float, band: float) -> np.ndarray:
    """(K, 2): the points of ``supporter`` seen from above at the height an object resting on it stands
    (within ``band`` under ``base_z``), or its highest points where none are that high (a domed top)."""
    z = supporter[:, 2]
    top = supporter[z >= min(base_z, z.max()) - band, :2]
    return np.unique(np.round(top, 6), axis=0)


def _outside(region: np.ndarray, c: np.ndarray) -> float:
    """Signed distance (m) of ``c`` (2,) outside the convex hull of ``region`` (K, 2); ≤ 0 inside."""
    probe = np.column_stack([region, np.zeros(len(region))])
    return overhang(probe, np.array([c[0], c[1], 0.0]))


#: The top of what holds a stacked object is raised to its base by at most this fraction of its own height.
RAISE_DEPTH = 0.08


def raise_top(supporter: np.ndarray, foot: np.ndarray, base_z: float) -> np.ndarray:
    """``supporter`` (N, 3) with its points under the convex hull of ``foot`` (K, 2, the base of what rests
    on it), below ``base_z`` by no more than :data:`RAISE_DEPTH` of its height, raised to ``base_z``. A lifted
    box's top follows its outline's upper edge, slanted or in steps; the box stacked on it stands on the
    highest point, its centre of mass beyond it, and slides or tips off. Flat under the foot, it stands as the
    photo shows; that part of the top is hidden from the camera by what stands on it."""
    from scipy.spatial import Delaunay, QhullError

    out = np.array(supporter, float)
    try:
        inside = Delaunay(np.unique(np.round(foot, 6), axis=0)).find_simplex(out[:, :2]) >= 0
    except (QhullError, ValueError):
        return out
    lift = inside & (out[:, 2] < base_z) & (out[:, 2] >= base_z - RAISE_DEPTH * float(np.ptp(out[:, 2])))
    out[lift, 2] = base_z
    return out


def _across_sight(moves: np.ndarray, at: np.ndarray, eye) -> np.ndarray:
    """(K,) metres: how much of each move (K, 3) of a point at ``at`` (3,) the photo sees, its part across the
    line of sight from ``eye`` (a move along it changes the image least; None: no eye, the whole move)."""
    ray = np.asarray(at, float) - np.asarray(eye, float) if eye is not None else np.zeros(3)
    ray = ray / max(float(np.linalg.norm(ray)), 1e-12)
    moves = np.atleast_2d(np.asarray(moves, float))
    return np.linalg.norm(moves - np.outer(moves @ ray, ray), axis=1)


def _cheapest_shift(region: np.ndarray, c: np.ndarray, margin: float, com: np.ndarray, eye,
                    allowed=None) -> np.ndarray:
    """The level shift (2,) of a centre of mass ``c`` into the convex hull of ``region`` by ``margin`` that moves
    its image least: a shift along the line of sight from ``eye`` costs nothing, across it all its length (so
    a level view forgives depth, a view from above forgives nothing). Only shifts ``allowed`` ((K, 2) → (K,)
    bool) allows count, where given. Where no point of the top is that far inside, its deepest point."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        eq = ConvexHull(region).equations
    except QhullError:
        return region.mean(axis=0) - c
    lo, hi = region.min(axis=0), region.max(axis=0)
    g = np.stack(np.meshgrid(np.linspace(lo[0], hi[0], 48), np.linspace(lo[1], hi[1], 48)), -1).reshape(-1, 2)
    depth = (g @ eq[:, :2].T + eq[:, 2]).max(axis=1)
    ok = depth <= -margin
    if allowed is not None and ok.any():
        ok[ok] = allowed(g[ok] - c)
    if not ok.any():
        return g[np.argmin(depth)] - c
    steps = g[ok] - c
    across = _across_sight(np.column_stack([steps, np.zeros(len(steps))]), com, eye)
    # a tenth of the length itself breaks ties: of the shifts the photo cannot tell apart, the shortest
    return steps[np.argmin(across + 0.1 * np.linalg.norm(steps, axis=1))]


def steady_stacks(vertex_sets, faces, supports: dict, eye=None, labels=None, held=frozenset()
                  ) -> tuple[list[np.ndarray], list[dict]]:
    """Vertex sets in which each object resting on another (``supports``: {upper: (lower, how)}) has its
    centre of mass over the supporter's top, and what was moved. A lifted object stands where its outline's
    foot is read, at a depth the photo hardly shows; a few centimetres too far forward of the box under it,
    its centre of mass overhangs that box's top and, with nothing pushing it, it tips off (a box on a stack of
    three fell 51 cm). What counts is the centre of mass of its load (:func:`_load_com`: it and all that rests
    on it). First the top under its foot is made flat at its base (:func:`raise_top`: hidden by
    it); where that centre still overhangs, it is shifted level, with whatever rests on it, by the shift
    into ``geometry.resting.STEADY_MARGIN`` inside that top that moves its image least (:func:`_cheapest_shift`): a few
    pixels, where a fall moves it off the frame. A rounded object on another's rounded top (no shift holds a dome
    on a dome) goes into a pile's hollow beside it where one holds it, else onto a seat cut in a crown under it,
    its supporter's or that of the rounded object under its centre of mass, whichever moves its image least
    (:func:`_dome_on_dome`, :func:`_least_seen_crown`); so does one whose centre of mass overhangs its own foot. Higher
    objects first. Before all that, every object standing on a point on the ground gets a flat foot
    (:func:`flat_foot`), what rests on it lowered with it (not one held by another object: an orange in a bowl's
    mouth, rounded, rests on its rim; flattened, it fell 24 cm; but one on a floor walled in by what holds it,
    :func:`walled_in`), and a sole that its centre of mass overhangs is levelled (:func:`level_sole`); so is the
    sole of an object on another that does not stand on what it touches (:func:`_stands`), unless that leaves it
    thinner than its outline allows (``metrics.geometry.thin_side``, by ``labels``, one per object, seen from
    ``eye``); a load :data:`~physomni_usd.settings.HEAVY_LOAD` times its supporter's mass (by ``labels``) keeps
    a wider margin. An object in ``held`` (held fixed where the photo shows it: on what no mask shows) stands on
    nothing the simulation moves, and its foot and sole are kept as built (a card held upright on a wall had its
    lowest edge cut 1-3 mm flat, a tenth of its photo outline). Whether an object stands, and how far inside a
    top its load is, are judged on its real contact
    (``geometry.resting.real_contact``): a slanted foot's contact band reads it held where it is not."""
    from ..align.support import riders  # the build's; simulate, which imports this module, needs none of align

    verts = [np.asarray(v, float).copy() for v in vertex_sets]
    done = []
    for i in sorted(range(len(verts)), key=lambda k: float(verts[k][:, 2].min())):
        if i in held:
            continue
        # on another object (an orange on a bowl's rim): what holds it is not flat. A foot on any level face of
        # another stopped a pushed ball read as standing on a crate's top (6 mm where it rolled,
        # tests/test_studio_pushes.py); in a hollow (a fruit on a bowl's inner floor) a ball on the flat floor
        # wanders 5 cm with nothing pushing it, where the walls around it stop a pushed one anyway
        on_top = i in supports and not walled_in(verts[i], verts[supports[i][0]], faces[supports[i][0]])
        if on_top:
            # ... but a slanted sole is levelled there too: a cup lifted as a slab on a book stood on its sole's
            # low end, its centre of mass 17 mm beyond it, and tipped at once (241611/038)
            j = supports[i][0]
            gap = surface_gap(verts[i], verts[j], faces[j])
            if _stands(verts[i], _solid_com(verts[i], faces[i]), gap):
                continue
        else:
            footed, cut = flat_foot(verts[i])
            if cut > 0 and _thinned(verts[i], footed):
                cut = 0.0  # as level_sole's: a round thing is not cut thinner than the build made it
            if cut > 0:
                verts[i] = footed
                for k in riders(i, supports)[1:]:
                    verts[k][:, 2] -= cut
                done.append({"object": i, "flat_foot_m": round(cut, 4)})
        soled, level = level_sole(verts[i], faces[i])  # a foot cut round its lowest point may not hold it
        if level > 0 and on_top:
            # levelled to its lowest point, a sole on a slanted top sinks into it where the top rises (a start
            # overlap the solver throws apart); there it is left as it is
            after = surface_gap(soled, verts[j], faces[j])
            refused = float(np.min(after)) < min(float(np.min(gap)), 0.0) - SOLE_DIP
            if not refused and labels is not None and eye is not None:
                from ..metrics.geometry import thin_side

                # a fruit slab-lifted on a book, deepened to just the depth its outline allows and tilted 22°,
                # came out of a 10 mm sole thinner than that (241611/008); the ground's soles and those in a
                # hollow (walled in) kept as they were measured
                refused = thin_side(soled, labels[i], eye) is not None and thin_side(verts[i], labels[i], eye) is None
            if refused:
                out, _ = _real_overhang(verts[i], _solid_com(verts[i], faces[i]), gap=gap)
                done.append({"object": i, "unsteady_m": round(min(out, 1.0), 4)})  # nothing here helps it
                level = 0.0
        if level > 0 and not _thinned(verts[i], soled):
            verts[i] = soled
            done.append({"object": i, "level_sole_m": round(level, 4)})
    # highest first: what an object carries is steady on it before the load of both is brought over the one
    # under them; a shift moves an object with its riders, so it never undoes one made above it
    for i in sorted(supports, key=lambda k: -float(verts[k][:, 2].min())):
        j = supports[i][0]
        pts = verts[i]
        low = float(pts[:, 2].min())
        band = contact_band(pts)
        gap = surface_gap(pts, verts[j], faces[j])
        if not _stands(pts, _solid_com(pts, faces[i]), gap) and _dome_on_dome(verts, faces, supports, i, j, eye,
                                                                             done):
            continue  # it cannot stand on its own foot, but on a seat cut in the crown under it
        # what tips it off its supporter is its load, itself and all it carries: a book over the lower book's
        # back edge by the one on it (each alone over the top under it) fell 16 cm with it
        com = _load_com(riders(i, supports), verts, faces)
        region = _top_under(verts[j], low, band)
        if len(region) < 3:
            continue
        foot = pts[pts[:, 2] <= low + band, :2]
        margin = steady_margin(foot)
        load = _mass(riders(i, supports), verts, faces, labels) if labels is not None else 0.0
        if labels is not None and load >= HEAVY_LOAD * _mass([j], verts, faces, labels):
            # a light supporter leans under a heavy load off its middle: a cup five times its book's mass, 10 mm
            # inside the book's top, tilted it 0.9° and slid off (241611/054), where one four times its book's
            # stood 14 mm inside (046)
            margin *= HEAVY_LOAD_MARGIN
        c = com[:2]
        # an object standing on an area of itself is held by the part of it over the top, not by the top: a
        # cup over a book's hidden far edge, its centre of mass 10 mm inside the book's top, 5.7 mm inside its
        # bottom's vertices over it, crept and tipped off after 1 s (241611/054)
        touch = real_contact(pts, gap)
        area = len(hull_ring(touch)) > 0

        def short(d=np.zeros(2)) -> float:
            """How far (m) the load's centre, moved level by ``d``, lacks of its margin inside the top and inside
            the object's real contact over it (≤ 0: held)."""
            lack = _outside(region, c + d) + margin
            if area:
                over = contact_over(touch + d, region)
                held = _hull_out(over, c + d)
                if held < float("inf"):  # on a sliver over the top, what it touches there is the top's edge
                    lack = max(lack, held + steady_margin(over))
            return lack

        out = _outside(region, c)
        if short() <= 0:
            # balanced dome on dome: a pile's hollow beside it holds it as the photo shows it, else its crown
            if not (_rounded_pair(verts[i], verts[j])
                    and _into_hollow(verts, faces, supports, i, j, com, eye, margin, out, done)):
                _dome_on_dome(verts, faces, supports, i, j, eye, done)
            continue
        # held by several together (a pile's hollow): on one's top alone it balances on a dome. Its own
        # supporter's top alone holds it only as its real contact over that top does
        if _into_hollow(verts, faces, supports, i, j, com, eye, margin, out, done,
                        lambda move, on: list(on) != [j] or short(np.asarray(move, float)[:2]) <= 0):
            continue
        # a dome read as on one fruit of a pile may stand over another's crown: seated on the one under its
        # centre of mass it moves less than onto its own supporter's (a lemon carried 4.9 cm off its outline)
        below = _under(verts, supports, i, com, low + band)
        if _least_seen_crown(verts, faces, supports, i, [j] + ([below] if below not in (None, j) and
                                                              _rounded_pair(verts[i], verts[below]) else []),
                             eye, done):
            continue
        raised = raise_top(verts[j], foot, low)
        if not np.array_equal(raised, verts[j]):
            # free: the top under its foot is hidden from the camera by what stands on it
            verts[j] = raised
            region = _top_under(raised, low, band)
            if short() <= 0:
                done.append({"object": i, "on": j, "shift_m": 0.0, "raised_top": True})
                continue
        shift = _cheapest_shift(region, c, margin, com, eye)
        # no second shift for a contact over the top that ends short: the distance inside two convex polygons'
        # overlap is the lesser of those inside each, the shift brings the top's to the margin and the object's
        # own contact moves with it. What it still lacks is its foot's (recorded: no shift helps it)
        lack = short(shift)
        for k in riders(i, supports):
            verts[k][:, :2] += shift
        verts[j] = raise_top(verts[j], foot + shift, low)  # flat under where the foot now stands
        done.append({"object": i, "on": j, "shift_m": round(float(np.linalg.norm(shift)), 4),
                     "overhang_m": round(_outside(region, c), 4)}
                    | ({"short_m": round(lack, 4)} if lack > 0 else {}))
    return verts, done


#: What holds an object walls it in where it rises this fraction of the object's height above its lowest point
#: all around it (:func:`walled_in`) ...
WALL_RISE = 0.25
#: ... and its surface lies within this (m) straight under that point: it stands on a floor there.
ON_FLOOR = 0.002


def walled_in(upper: np.ndarray, lower: np.ndarray, lower_faces: np.ndarray) -> bool:
    """Whether ``upper`` (N, 3) stands on a floor of ``lower`` (M, 3, triangle ``lower_faces``) that rises round
    it: ``lower``'s surface is within :data:`ON_FLOOR` straight under ``upper``'s lowest point, and seen from
    above that point lies inside the convex hull of ``lower``'s points :data:`WALL_RISE` of ``upper``'s height
    above it (a fruit on a bowl's inner floor; not one on a crate's top, on a ring's edge, or on the side of a
    fruit under it)."""
    import trimesh

    low = upper[np.argmin(upper[:, 2])]
    high = lower[lower[:, 2] >= low[2] + WALL_RISE * float(np.ptp(upper[:, 2])), :2]
    if len(high) < 3 or _outside(high, low[:2]) >= 0.0:
        return False
    mesh = trimesh.Trimesh(lower, lower_faces, process=False)
    hits, _, _ = mesh.ray.intersects_location(np.array([[low[0], low[1], low[2] + ON_FLOOR]]),
                                              np.array([[0.0, 0.0, -1.0]]))
    return bool(len(hits)) and float(hits[:, 2].max()) >= low[2] - ON_FLOOR


#: A stacked object's sole is not levelled where that brings a point of it more than this (m) closer to the top
#: under it than its nearest point was (:func:`steady_stacks`).
SOLE_DIP = 1e-4

#: A rounded object on a rounded top is brought over that top's crown by at most this fraction of its own
#: smaller level width: farther, the photo shows it elsewhere, and it is left as it was.
CROWN_REACH = 0.5
#: ... and that crown may be cut down to a seat this fraction of the upper object's height deep (hidden under it):
#: a wider face holds a centre of mass off the crown, so the upper one moves less off where the photo shows it.
SEAT_DEPTH = 0.15


def _into_hollow(verts, faces, supports: dict, i: int, j: int, com, eye, margin: float, overhang: float,
                 done: list, holds=None) -> bool:
    """Object ``i`` (on ``j``) and what it carries moved into the hollow :func:`into_hollow` finds for it, if
    one holds it (and ``holds`` (move (3,), the objects it rests on) → bool agrees, where given); records it in
    ``done`` and returns whether it did."""
    from ..align.support import into_hollow, riders

    hollow = into_hollow(verts, faces, supports, i, com, eye, margin, min(float(v[:, 2].min()) for v in verts))
    if hollow is None or (holds is not None and not holds(*hollow)):
        return False
    move, on = hollow
    for k in riders(i, supports):
        verts[k] = verts[k] + move
    done.append({"object": i, "on": j, "into_hollow_m": round(float(np.linalg.norm(move)), 4),
                 "rests_on": on, "overhang_m": round(overhang, 4)})
    return True


def _least_seen_crown(verts, faces, supports: dict, i: int, lowers: list, eye, done: list) -> bool:
    """:func:`_dome_on_dome` of ``i`` on whichever of ``lowers`` moves its image least (its centre across the
    line of sight from ``eye``, and its drop); records it in ``done`` and returns whether one held it."""
    best = None
    for j in lowers:
        trial, log = [np.array(v, float) for v in verts], []
        if not _dome_on_dome(trial, faces, supports, i, j, eye, log):
            continue
        move = trial[i].mean(axis=0) - np.asarray(verts[i], float).mean(axis=0)
        seen = float(_across_sight(move, trial[i].mean(axis=0), eye)[0])
        if best is None or seen < best[0]:
            best = (seen, trial, log)
    if best is None:
        return False
    verts[:] = best[1]
    done.extend(best[2])
    return True


def _under(verts, supports: dict, i: int, com: np.ndarray, below_z: float) -> int | None:
    """The object, not ``i`` nor one it carries, with the highest top under ``i``'s centre of mass ``com``
    seen from above (its level bounds hold it) and no higher than ``below_z``; None where none."""
    from ..align.support import riders

    carried = set(riders(i, supports))
    best = None
    for k, v in enumerate(verts):
        lo, hi = v[:, :2].min(axis=0), v[:, :2].max(axis=0)
        if k in carried or (com[:2] < lo).any() or (com[:2] > hi).any() or float(v[:, 2].max()) > below_z:
            continue
        if best is None or float(v[:, 2].max()) > float(verts[best][:, 2].max()):
            best = k
    return best


def _rounded_pair(upper: np.ndarray, lower: np.ndarray) -> bool:
    """Whether ``upper`` (N, 3) stands on a rounded foot and ``lower`` (M, 3) has a rounded top (both as
    :func:`flat_foot` judges a foot)."""
    return flat_foot(upper)[1] > 0 and flat_foot(lower * np.array([1.0, 1.0, -1.0]))[1] > 0


def _dome_on_dome(verts, faces, supports: dict, i: int, j: int, eye, done: list) -> bool:
    """Object ``i`` (rounded foot: :func:`flat_foot` would cut it) resting on ``j`` alone whose top is rounded
    too (a lemon on a lemon, an apple on an orange, the photo's pile read as a column) stood over ``j``'s crown
    on flat faces of both: with no hollow to hold it, a dome on a dome balances on a point, and the solver's
    first tremor rolls it off (three piled fruit read as a column fell 43-63 cm). ``j``'s crown is cut flat,
    at least as deep as :func:`flat_foot` would cut it and at most :data:`SEAT_DEPTH` of ``i``'s height, and
    ``i``'s centre of mass moved level, with what rests on it, inside that face by the steady margin, the depth
    and the move together those the photo sees least (:func:`_seat`), where that move is within
    :data:`CROWN_REACH` of its width; then its foot is cut flat (as a fruit's on the ground) and it is lowered
    onto that face. Both cuts are millimetres of what each hides of the other. Records it in ``done`` and
    returns whether it did."""
    from ..align.support import riders

    pts = verts[i]
    if flat_foot(pts)[1] <= 0:
        return False  # a flat foot stands on a flat face of the crown raise_top makes
    mirrored = verts[j] * np.array([1.0, 1.0, -1.0])
    # the crown is cut as the lower one's own foot would be. Cut only as wide as the upper one's foot (what a
    # lemon on a 40 cm ball would want), a lemon on a lemon of a generated pile fell 29 cm (577351/059)
    topped, cut_j = flat_foot(mirrored)
    if cut_j <= 0:
        return False  # a flat top: steadied as any
    top = float(verts[j][:, 2].max())
    com = _load_com(riders(i, supports), verts, faces)
    _, sole_cut = flat_foot(pts)
    margin = steady_margin(pts[pts[:, 2] <= float(pts[:, 2].min()) + sole_cut, :2])
    seat = _seat(verts[j], top, cut_j, SEAT_DEPTH * float(np.ptp(pts[:, 2])), com, margin, eye,
                 _stands_under(verts, faces, supports, i, j))
    if seat is None:
        return False
    cut_j, shift = seat
    topped = np.array(verts[j], float)
    topped[:, 2] = np.minimum(topped[:, 2], top - cut_j)
    if float(np.linalg.norm(shift)) > CROWN_REACH * float(np.ptp(pts[:, :2], axis=0).min()):
        return False
    movers = riders(i, supports)
    for k in movers:
        verts[k][:, :2] += shift
    footed, cut_i = flat_foot(verts[i])
    if _thinned(verts[i], footed) or _thinned(verts[j], topped):
        for k in movers:
            verts[k][:, :2] -= shift
        return False  # a cut may not make a round thing thinner than the build made it (as level_sole's)
    footed[:, 2] += cut_i  # flat_foot lowers it by its cut; the drop onto the crown below says how far
    verts[j] = topped
    new_top = top - cut_j
    drop = float(footed[:, 2].min()) - new_top
    verts[i] = footed - np.array([0.0, 0.0, drop])
    for k in movers[1:]:
        verts[k][:, 2] -= drop
    done.append({"object": i, "on": j, "crown_shift_m": round(float(np.linalg.norm(shift)), 4),
                 "foot_cut_m": round(cut_i, 4), "crown_cut_m": round(cut_j, 4)})
    return True


#: Seat depths :func:`_seat` weighs between the crown's own cut and the deepest.
SEAT_STEPS = 8


def _seat(lower: np.ndarray, top: float, cut: float, deepest: float, com: np.ndarray, margin: float, eye,
          stands=None):
    """The depth (m) of ``lower``'s crown (its highest point at ``top``) cut flat, from ``cut`` down to
    ``deepest`` if deeper, and the level shift (2,) that brings the centre of mass ``com`` of what rests on it
    ``margin`` inside that face, of which the photo sees least: the shift across the line of sight from ``eye``
    and the drop of the deeper cut both move its image. A fruit seen in a pile's hollow, read as on one fruit
    beside its crown, was carried 2.5 cm sideways onto that crown, off its outline; seated on a face cut wider
    under it, it moves less. Only a shift that ``stands`` ((K, 2) → (K,) bool; :func:`_stands_under`) allows: a
    face wide enough to hold the load off the crown does not make what it is cut in stand under it. Where no
    allowed shift is found, over the middle of the crown's own cut. None where no face holds it."""
    depths = np.unique(np.linspace(cut, max(cut, deepest), SEAT_STEPS))
    best = crown = None

    def holds(shift) -> bool:
        return stands is None or bool(stands(np.asarray(shift, float)[None])[0])

    for depth in depths:
        face = np.unique(np.round(lower[lower[:, 2] >= top - depth - 1e-9, :2], 6), axis=0)
        if len(face) < 3:
            continue
        if crown is None:
            crown = (float(depth), face.mean(axis=0) - com[:2])
        still = np.zeros(2)
        shift = still if _outside(face, com[:2]) <= -margin and holds(still) else \
            _cheapest_shift(face, com[:2], margin, com, eye, stands)
        if _outside(face, com[:2] + shift) > -margin + 1e-9:
            shift = face.mean(axis=0) - com[:2]  # no point that deep: over the face's middle, as a crown's
        if not holds(shift):
            continue
        seen = float(_across_sight(np.array([shift[0], shift[1], cut - depth]), com, eye)[0])
        if best is None or seen < best[0] - 1e-6:
            best = (seen, float(depth), shift)
    return crown if best is None else best[1:]


def _stands_under(verts, faces, supports: dict, i: int, j: int):
    """A test (level shifts (K, 2) → (K,) bool) that every object in the column under ``i`` from ``j`` down
    still has its whole load, itself and all it carries, with ``i`` and its riders shifted level so, the steady
    margin inside its own foot. A lemon seated 15 mm off the axis of an orange standing on a foot 8 mm across
    brought the centre of mass of the two outside that foot: the orange tipped and both fell 21 cm. Weighed by volume,
    as :func:`_load_com`: the materials are not estimated yet. Only an object whose foot is its lowest point is judged
    (on the ground, walled in, or a dome on a dome, whose foot :func:`flat_foot` cuts there); one on a bowl's rim rests
    elsewhere."""
    from scipy.spatial import ConvexHull, QhullError

    from ..align.support import riders

    moved = riders(i, supports)
    vol = {}

    def weight(k):
        if k not in vol:
            s = _solid(verts[k], faces[k])
            vol[k] = (max(float(abs(s.volume)), 1e-12), np.asarray(s.center_mass, float)[:2])
        return vol[k]

    levels, k, seen = [], j, set(moved)
    while k is not None and k not in seen:
        seen.add(k)
        below = supports[k][0] if k in supports else None
        if below is None or walled_in(verts[k], verts[below], faces[below]) or _rounded_pair(verts[k], verts[below]):
            footed = flat_foot(verts[k])[0]
            foot = np.unique(np.round(footed[footed[:, 2] <= float(footed[:, 2].min()) + 1e-6, :2], 6), axis=0)
            try:
                eq = ConvexHull(foot).equations  # unit outward normals: a·x + b·y + d is the signed distance
            except (QhullError, ValueError):
                eq = None  # a line or a point: not a foot to judge by
            if eq is not None:
                load = sorted(set(riders(k, supports)) | set(moved))
                w = np.array([weight(m)[0] for m in load])
                c0 = np.average([weight(m)[1] for m in load], axis=0, weights=w)
                frac = float(sum(weight(m)[0] for m in moved) / w.sum())
                levels.append((eq, steady_margin(foot), c0, frac))
        k = below

    def stands(shifts: np.ndarray) -> np.ndarray:
        ok = np.ones(len(shifts), bool)
        for eq, margin, c0, frac in levels:
            c = c0 + frac * np.asarray(shifts, float)
            ok &= (c @ eq[:, :2].T + eq[:, 2]).max(axis=1) <= -margin
        return ok

    return stands


def _thinned(before: np.ndarray, after: np.ndarray) -> bool:
    """Whether cutting ``before`` (N, 3) to ``after`` took its thinnest side (of its oriented box) below
    :data:`~physomni_usd.metrics.geometry.ROUND_FRACTION` of its middle one where it was not below before: the
    build deepened every round object to that depth (``building``), and flattening its sole must not undo it.
    The build now judges by least widths (``metrics.geometry.thin_side``); this still by the oriented box,
    whose sides can be wider than those widths, so the two can disagree on a borderline solid."""
    import trimesh

    from ..metrics.geometry import ROUND_FRACTION, THIN_SLACK

    def ratio(points):
        try:
            extents = np.sort(trimesh.bounds.oriented_bounds(points, angle_digits=2)[1])
        except Exception:  # noqa: BLE001 — a degenerate set: judged by its axes
            extents = np.sort(np.ptp(points, axis=0))
        return float(extents[0] / max(extents[1], 1e-12))

    limit = ROUND_FRACTION * THIN_SLACK
    return ratio(after) < limit <= ratio(before)


def level_sole(points: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, float]:
    """``points`` (N, 3) of an object standing on a flat sole with the part of its underside the least height
    ``h`` above its lowest point that, flattened to that point's level, has its centre of mass
    :func:`~physomni_usd.geometry.resting.steady_margin` inside it, flattened so; returns them and ``h`` (0
    where its lowest points hold it already, or none within its contact band does). A lifted box's foot follows
    its outline's lower edge, slanted a few millimetres: it stands on one end, its centre of mass beyond that,
    and tips until the other end touches (a box of two turned 3.8° and moved 23 mm). Its contact band judges it
    standing; flat, it stands as judged."""
    pts = np.array(points, float)
    z = pts[:, 2]
    low = float(z.min())
    com = _solid_com(pts, faces)

    def holds(h: float) -> bool:
        sole = pts[z <= low + h, :2]
        if len(sole) < 3:
            return False
        probe = np.column_stack([sole, np.full(len(sole), low)])
        return overhang(probe, com) <= -steady_margin(sole, float(com[2]) - low)

    band = contact_band(pts)
    if holds(1e-4) or not holds(band):
        return pts, 0.0
    lo, hi = 1e-4, band
    for _ in range(20):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if holds(mid) else (mid, hi)
    pts[z <= low + hi, 2] = low
    return pts, hi


#: A rounded object standing on a point gets a flat contact this fraction of its smaller level half-width
#: across (radius): a lifted fruit touches the ground at one vertex and any neighbour's touch rolls it away,
#: where the real one rests on the patch its weight flattens.
FOOT_FRACTION = 0.3


def flat_foot(points: np.ndarray) -> tuple[np.ndarray, float]:
    """``points`` (N, 3) of an object resting on its lowest point with the cap under the height where its
    contact is :data:`FOOT_FRACTION` of its half-width across made flat, and lowered by that height so that it
    rests where it did; returns them and the cut (m, 0 when its foot was wide enough). A rounded base (a
    fruit, a ball, a bottle's rim) then stands; a flat one is left as it is."""
    from scipy.spatial import ConvexHull, QhullError

    pts = np.array(points, float)
    z = pts[:, 2]
    low, height = float(z.min()), float(np.ptp(z))
    half = 0.5 * float(np.ptp(pts[:, :2], axis=0).min())
    want = FOOT_FRACTION * half

    def radius(h: float) -> float:
        foot = pts[z <= low + h, :2]
        if len(foot) < 3:
            return 0.0
        try:
            return float(np.sqrt(ConvexHull(foot).volume / np.pi))  # a 2-d hull's volume is its area
        except QhullError:
            return 0.0

    if height <= 0 or radius(max(1e-4, 1e-3 * height)) >= want:
        return pts, 0.0
    lo, hi = 0.0, FOOT_CUT * height
    if radius(hi) < want:
        cut = hi
    else:
        for _ in range(20):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if radius(mid) < want else (lo, mid)
        cut = hi
    pts[:, 2] = np.maximum(z, low + cut) - cut
    return pts, cut
