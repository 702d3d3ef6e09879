"""Cloth (``pbd_cloth``) and soft bodies (``pbd_elastic``) as XPBD particles in the rigid model, so
they collide two-way with the rigid bodies and the ground through the same solver."""

from __future__ import annotations

import itertools
import math
import warnings
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..materials.catalog import CATALOG
from .mpm import points_inside

#: XPBD cloth: stiffness is the inverse of the material's compliance, clamped to what the
#: solver keeps stable at our steps (spring N/m, bending N·m).
CLOTH_SPRING_KE = (1e1, 1e2)
CLOTH_BEND_KE = (1e-2, 1e1)
#: Spring damping (N·s/m) of every cloth spring.
CLOTH_SPRING_KD = 1.0
#: Soft bodies: Lamé stiffness (Pa) from the inverse compliances, clamped likewise.
SOFT_KE = (1e3, 5e5)
#: Soft bodies are this many tetrahedral cells across their smallest side.
CELLS_ACROSS = 6
#: The elastic wave may cross this fraction of a cell in one step. Fewer, longer steps with more
#: iterations (a whole cell at 10, half at 5) were 2× as fast and as stiff at rest, but an 8 cm sponge
#: thrown down at 5 m/s onto a box came out of the impact stretched 17–37 % and still moving after 1 s;
#: at a fifth of a cell it recovers its shape.
SOFT_STEP_CELLS = 0.2
#: Relaxation of the soft bodies' tetrahedral corrections (the material's ``relaxation``; the catalog's
#: default is 0.1), kept within these bounds. Newton sums every tetrahedron's correction of a particle
#: (a Jacobi step; an inner node of our mesh is in 24 tetrahedra), so a factor near 1 overshoots: an 8 cm
#: cube at the stiffness bound flew apart within a frame at 0.9 and 0.3, at 20 to 396 substeps a frame,
#: and stayed whole at 0.1.
SOFT_RELAXATION = (1e-3, 0.1)
#: s: the time constant of soft bodies' deformation damping (:class:`ShapeDamping`). An 8 cm sponge
#: dropped 30 cm: undamped, it bounced back 20 cm, stretched to 11 cm tall and still wobbled a second
#: later; at 0.02 s it bounced 6 cm; at 0.005 s it bounces about 7 mm, its fastest particle is under
#: 1 cm/s 0.7 s after the drop began and under 2 mm/s at 0.8 s; at 0.002 s it lands dead.
SOFT_DAMPING_S = 0.005


def _compliance_stiffness(compliance: float, bounds: tuple[float, float]) -> float:
    return float(np.clip(1.0 / max(float(compliance or 0.0), 1e-12), *bounds))


def pinned_particles(points: np.ndarray, ratio: float) -> np.ndarray:
    """Indices of the highest ``ratio`` (0–1) of a point set's height: what ``fixTopRatio`` pins."""
    if ratio <= 0:
        return np.zeros(0, np.int64)
    z = points[:, 2]
    cut = z.max() - min(ratio, 1.0) * (z.max() - z.min()) - 1e-9 * (1.0 + abs(z.max()))
    return np.nonzero(z >= cut)[0]


#: The cloth's edges are about this fraction of the surface's bounding-box diagonal, whatever the lifted mesh's
#: own triangles are (:func:`cloth_sheet`): longer ones are split to at most twice it, and vertices closer than
#: :data:`CLOTH_WELD` of it merged (a run of close vertices merges whole, which can leave an edge longer).
CLOTH_EDGE_FRACTION = 1.0 / 16.0
#: Vertices of the surface closer than this fraction of the cloth's edge are one particle.
CLOTH_WELD = 0.3
#: Triangles flatter than this (4√3·area / Σ edge², 1 for an equilateral one) are left out of the cloth.
CLOTH_MIN_QUALITY = 0.05
#: No cloth particle weighs less than this fraction of the cloth's mean particle mass.
CLOTH_MIN_MASS = 0.3
#: The springs' damping is at most this share of what a substep can take: Newton's XPBD sums each spring's
#: damped correction of a particle (a Jacobi step), which overshoots once kd·dt·n/m nears 1 (n springs on a
#: particle of mass m). With dt at most ``stability.CLOTH_FACTOR``·√(m/k), the bound is kd ≤ √(m·k)/(n·0.1);
#: an 8 cm cup made cloth (0.4 g particles) diverged in its first frame at kd = 1 N·s/m and at 0.4, and
#: stood at 0.
CLOTH_DAMPING_SHARE = 0.5


@dataclass
class ClothSheet:
    """The particles and triangles a cloth is simulated with, and how the object's own surface follows them."""

    particles: np.ndarray  # (P, 3) world metres
    triangles: np.ndarray  # (T, 3) indices into particles
    index: np.ndarray  # (V,) the particle each surface vertex follows
    offset: np.ndarray  # (V, 3) the surface vertex's offset from that particle at rest
    softened_from_n_m: float | None = None  # its springs' stiffness before ``add_cloth`` softened them, if it did
    spring_n_m: float | None = None  # N/m, its springs' stiffness as simulated
    needs_substeps: int | None = None  # substeps a frame its springs would ask before softening, if softened


def cloth_sheet(points: np.ndarray, faces: np.ndarray) -> ClothSheet:
    """A cloth fit for the solver from a lifted surface ``points`` (V, 3) / ``faces`` (F, 3).

    A lifted mesh is made for the eye: an extruded outline has fans of slivers and edges from 0.1 mm to
    4 cm, and a thin object's two faces lie closer than a particle's radius. As cloth, a zero-area triangle
    has no normal for its bending (NaN), and a particle of a tiny triangle weighs next to nothing, which the
    springs' damping throws about (a spoon switched to cloth reached 7,952 J in its first frame). So: edges
    longer than twice :data:`CLOTH_EDGE_FRACTION` of the diagonal are split, vertices within
    :data:`CLOTH_WELD` of that edge merged (a thin object's two faces become one sheet), collapsed and
    repeated triangles dropped, and so are slivers (:data:`CLOTH_MIN_QUALITY`), whose area is next to none,
    and the welded faces' overlapping and folded triangles (:func:`manifold_sheet`). Each surface vertex
    follows the particle it merged into (or the nearest kept one) at its rest offset."""
    import trimesh
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    points, faces = np.asarray(points, float), np.asarray(faces, np.int64)
    edge = max(float(np.linalg.norm(np.ptp(points, axis=0))) * CLOTH_EDGE_FRACTION, 1e-4)
    fine, fine_faces = trimesh.remesh.subdivide_to_size(points, faces, max_edge=2.0 * edge, max_iter=8)
    pairs = cKDTree(fine).query_pairs(CLOTH_WELD * edge, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])) if len(pairs) else ([], ([], [])),
                       shape=(len(fine), len(fine)))
    count, label = connected_components(graph, directed=False)
    merged = np.zeros((count, 3))
    np.add.at(merged, label, fine)
    merged /= np.bincount(label, minlength=count)[:, None]
    tris = label[fine_faces]
    tris = tris[(tris[:, 0] != tris[:, 1]) & (tris[:, 1] != tris[:, 2]) & (tris[:, 0] != tris[:, 2])]
    _, first = np.unique(np.sort(tris, axis=1), axis=0, return_index=True)
    tris = tris[np.sort(first)]
    quality = triangle_quality(merged, tris)
    keep = quality >= CLOTH_MIN_QUALITY
    tris = manifold_sheet(merged, tris[keep], quality[keep])
    if not len(tris):  # nothing of it is a sheet: the flattest fair triangle of its extent stands in
        raise ValueError("the surface has no triangle fit for cloth")
    used = np.unique(tris)
    renumber = np.full(count, -1)
    renumber[used] = np.arange(len(used))
    particles = merged[used]
    # the surface's own vertices: the first len(points) of the subdivided mesh are the originals
    index = renumber[label[:len(points)]]
    lost = index < 0
    if lost.any():
        index[lost] = cKDTree(particles).query(points[lost])[1]
    return ClothSheet(particles, renumber[tris], index, points - particles[index])


#: Two triangles on one edge whose third corners are less than this angle (degrees) apart about it lie folded
#: over each other.
CLOTH_FOLD_DEG = 30.0


def manifold_sheet(points: np.ndarray, tris: np.ndarray, quality: np.ndarray) -> np.ndarray:
    """The triangles ``tris`` of a welded surface that make one sheet: taken best ``quality`` first, each kept
    where none of its edges already has two triangles and it lies folded (:data:`CLOTH_FOLD_DEG`) over no kept
    triangle it shares an edge with. Welding a thin object's two faces into one leaves both faces' triangles
    on the same particles: a quad's two triangulations overlapping, the rim's edges in three or four
    triangles. As cloth, the overlapping triangles' springs and bending fight each other: the desk example's
    pencil made cloth (8 such edges) gained 0.006 -> 0.28 J in four frames and stopped the run. A closed
    surface's triangles all stay (each edge in two, none folded)."""
    on_edge: dict = {}  # (i, j), i < j -> the third corners of the kept triangles on it
    fold = np.cos(np.radians(CLOTH_FOLD_DEG))
    kept = []
    for t in np.argsort(-quality, kind="stable"):
        a, b, c = (int(x) for x in tris[t])
        edges = (((a, b), c), ((b, c), a), ((c, a), b))
        ok = True
        for (i, j), k in edges:
            others = on_edge.get((min(i, j), max(i, j)), ())
            if len(others) >= 2:
                ok = False
                break
            axis = points[j] - points[i]
            axis = axis / max(np.linalg.norm(axis), 1e-30)
            mine = points[k] - points[i]
            mine = mine - axis * (mine @ axis)
            for o in others:
                theirs = points[o] - points[i]
                theirs = theirs - axis * (theirs @ axis)
                if mine @ theirs > fold * np.linalg.norm(mine) * np.linalg.norm(theirs):
                    ok = False
                    break
            if not ok:
                break
        if ok:
            kept.append(t)
            for (i, j), k in edges:
                on_edge.setdefault((min(i, j), max(i, j)), []).append(k)
    return tris[np.sort(np.asarray(kept, np.int64))] if kept else tris[:0]


def triangle_quality(points: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """(T,) 4√3·area / Σ edge² of triangles (T, 3) over ``points``: 1 for an equilateral one, 0 for a flat one."""
    a, b, c = (points[tris[:, k]] for k in range(3))
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    squares = ((b - a) ** 2).sum(1) + ((c - b) ** 2).sum(1) + ((a - c) ** 2).sum(1)
    return 4.0 * np.sqrt(3.0) * area / np.maximum(squares, 1e-30)


def areal_density(obj, sheet: ClothSheet) -> float:
    """kg/m² of ``obj``'s cloth: its own where it was authored for a cloth (or the catalog's), else the solid's
    density (``obj.volume_density``, kg/m³) times its thickness, its volume over the sheet's area, so that the
    cloth weighs what the solid did. The desk example's pencil made cloth kept the 200 kg/m³ the estimate gave
    it as a solid; read as 200 kg/m² (50 times the catalog's cloth), the run with it stopped on the guard at
    frame 4, its energy 0.081 -> 0.133 J."""
    if obj.volume_density is None:
        return float(obj.params.get("density", 4.0))
    mesh = obj.trimesh()
    # a lifted mesh is not always closed; its hull's volume stands in where its own is not defined
    volume = abs(float(mesh.volume)) if mesh.is_watertight else float(mesh.convex_hull.volume)
    a, b, c = (sheet.particles[sheet.triangles[:, k]] for k in range(3))
    area = float(0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1).sum())
    return obj.volume_density * volume / max(area, 1e-12)


def add_cloth(builder, obj, wp, fps: float = 30.0, substeps: int | None = None) -> tuple[int, int, ClothSheet]:
    """Cloth from the object's own surface made fit for the solver (:func:`cloth_sheet`; springs + bending);
    returns (first particle, count, the sheet, whose particles are where the cloth starts). Its springs are
    no stiffer than the substeps a frame will take at ``fps`` resolve (the cloth rule, dt ≤ CLOTH_FACTOR·√(m/k),
    on its lightest particle): ``substeps``, the user's, where given, else ``stability.MAX_SUBSTEPS``; its
    bending is softened alike. A small, light
    object made cloth asks more at the stiffness clamp, and the plan's cap then stepped it beyond the rule:
    the desk example's coin (0.15 g in 194 particles, 4,718 substeps asked, 1,008 taken, beside MPM objects)
    crumpled and rose 3 cm off the desk within a second, the scene's fastest speed 36 m/s; at the stiffness
    the cap resolves (4.5 N/m) it lies flat and the fastest is 0.5 m/s. Softening the springs alone (bending
    at its clamp) stopped the run on the guard at frame 4. A spring still stretches 0.04 % under a
    particle's weight (the bench's 1 m cloth at its 100 N/m: 1.6 %)."""
    p = obj.params
    stretch = _compliance_stiffness(p.get("stretch_compliance", 1e-7), CLOTH_SPRING_KE)
    bend = _compliance_stiffness(p.get("bending_compliance", 1e-5), CLOTH_BEND_KE)
    sheet = cloth_sheet(obj.points, obj.faces)
    world, faces = sheet.particles, sheet.triangles
    edges = np.linalg.norm(world[faces[:, 0]] - world[faces[:, 1]], axis=1)
    radius = float(0.25 * np.median(edges))
    # start a particle radius clear of whatever it lies on (the ground, a saucer's top): contact would otherwise
    # throw the cloth up; the surface's offsets take the lift off again (frame 0 is the photo)
    world = world + [0.0, 0.0, radius]
    sheet.offset = obj.points - world[sheet.index]
    sheet.particles = world
    start, first_spring = builder.particle_count, len(builder.spring_damping)
    first_edge = len(builder.edge_bending_properties)
    with warnings.catch_warnings():
        # a thin object's two faces welded into one sheet meet at its rim in edges of more than two triangles,
        # which bending leaves out: expected, not the user's concern
        warnings.filterwarnings("ignore", message="Detected non-manifold edge")
        builder.add_cloth_mesh(pos=wp.vec3(0.0, 0.0, 0.0), rot=wp.quat_identity(), scale=1.0,
                               vel=wp.vec3(0.0, 0.0, 0.0), vertices=[wp.vec3(*q) for q in world],
                               indices=faces.ravel().tolist(), density=areal_density(obj, sheet),
                               edge_ke=bend, add_springs=True, spring_ke=stretch, spring_kd=CLOTH_SPRING_KD,
                               particle_radius=radius, label=obj.path)
    # a particle whose triangles are small weighs next to nothing, and the springs' damping throws it about
    mass = np.array(builder.particle_mass[start:start + len(world)], float)
    floored = np.maximum(mass, CLOTH_MIN_MASS * mass.mean())
    floored *= mass.sum() / floored.sum()
    ratio = 1.0 if obj.fixed else float(obj.prim.GetAttribute("physomni:fixTopRatio").Get() or 0.0)
    floored[pinned_particles(world, ratio)] = 0.0
    builder.particle_mass[start:start + len(world)] = floored.tolist()
    springs = np.asarray(builder.spring_indices[2 * first_spring:], int) - start
    if len(springs):
        from .stability import CLOTH_FACTOR, MAX_SUBSTEPS

        per_particle = np.bincount(springs, minlength=len(world)).max()
        light = float(floored[floored > 0].min()) if (floored > 0).any() else float(mass.mean())
        # the stiffness the substeps taken resolve (the user's, else the cap), a hair under so that the rule's
        # rounding up stays within it
        resolved = light * (CLOTH_FACTOR * (substeps or MAX_SUBSTEPS) * fps) ** 2 * (1.0 - 1e-6)
        if stretch > resolved:
            sheet.needs_substeps = math.ceil(math.sqrt(stretch / light) / (CLOTH_FACTOR * fps))
            soften = float(resolved) / stretch
            stretch = float(resolved)
            builder.spring_stiffness[first_spring:] = [stretch] * (len(builder.spring_stiffness) - first_spring)
            for e in range(first_edge, len(builder.edge_bending_properties)):
                ke, kd_e = builder.edge_bending_properties[e]
                builder.edge_bending_properties[e] = (ke * soften, kd_e)
            sheet.softened_from_n_m = float(stretch / soften)
        sheet.spring_n_m = float(stretch)
        bound = CLOTH_DAMPING_SHARE * np.sqrt(light * stretch) / (per_particle * CLOTH_FACTOR)
        kd = min(CLOTH_SPRING_KD, float(bound))
        builder.spring_damping[first_spring:] = [kd] * (len(builder.spring_damping) - first_spring)
    return start, len(world), sheet


def voxel_tets(mesh, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """A conforming tetrahedral mesh of the cubes of side ``cell`` whose centres lie inside a trimesh
    (:func:`.mpm.points_inside`, so a mesh with holes fills its volume, not its bounding box): (V, 3)
    vertices and (T, 4) positively oriented tetrahedra (6 per cube, Kuhn split)."""
    lo, hi = mesh.bounds
    n = np.maximum(np.ceil((hi - lo) / cell).astype(int), 1)
    origin = np.array([(lo[0] + hi[0] - n[0] * cell) / 2, (lo[1] + hi[1] - n[1] * cell) / 2, lo[2]])
    idx = np.stack(np.meshgrid(*[np.arange(k) for k in n], indexing="ij"), -1).reshape(-1, 3)
    centres = origin + (idx + 0.5) * cell
    inside = points_inside(mesh, centres)
    cubes = idx[inside] if inside.any() else idx[np.argmin(np.linalg.norm(centres - mesh.centroid, axis=1))][None]
    tets = []
    for perm in itertools.permutations(range(3)):
        corners = [np.zeros(3, int)]
        for axis in perm:
            c = corners[-1].copy()
            c[axis] = 1
            corners.append(c)
        tets.append(np.stack([cubes + c for c in corners], 1))  # (C, 4, 3) node coordinates
    tets = np.concatenate(tets)
    nodes, inverse = np.unique(tets.reshape(-1, 3), axis=0, return_inverse=True)
    tets = inverse.reshape(-1, 4)
    verts = origin + nodes * cell
    a, b, c, d = (verts[tets[:, k]] for k in range(4))
    flip = np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a) < 0
    tets[flip] = tets[flip][:, [0, 2, 1, 3]]
    return verts, tets


def add_soft_body(builder, obj, wp, cell: float | None = None) -> tuple[int, int, np.ndarray, float]:
    """A soft body from the object's voxelised volume; returns (first particle, count, rest vertices,
    largest stable step in s: a fifth of a cell crossed by the elastic wave, √(k/ρ); half a cell,
    the textbook bound, diverged on contact with the ground)."""
    mesh = obj.trimesh()
    cell = cell or max(float(np.min(mesh.extents)) / CELLS_ACROSS, 1e-3)
    radius = 0.25 * cell
    verts, tets = voxel_tets(mesh, cell)
    filled = _volume(verts, tets)
    verts, scale = _inset(verts, mesh.bounds, radius)
    volume = _volume(verts, tets)
    p = obj.params
    # the mass is the mesh's (a closed mesh), else the voxels' before the inset: neither the inset nor
    # the voxels' own approximation of the volume changes it
    density = max(float(p.get("density", 1000.0)), 1e-3) * (float(mesh.volume) if mesh.is_volume else filled) / volume
    k_mu = _compliance_stiffness(p.get("stretch_compliance", 0.0), SOFT_KE)
    k_lambda = _compliance_stiffness(p.get("volume_compliance", 0.0), SOFT_KE)
    start = builder.particle_count
    builder.add_soft_mesh(pos=wp.vec3(0.0, 0.0, 0.0), rot=wp.quat_identity(), scale=1.0,
                          vel=wp.vec3(0.0, 0.0, 0.0), vertices=[wp.vec3(*v) for v in verts],
                          indices=tets.ravel().tolist(), density=density,
                          k_mu=k_mu, k_lambda=k_lambda, k_damp=0.0, particle_radius=radius,
                          label=obj.path)
    if obj.fixed:
        for i in range(len(verts)):
            builder.particle_mass[start + i] = 0.0
    # the step is the smallest cell's, as the inset left it
    smallest = cell * float(np.min(scale))
    return start, len(verts), verts, SOFT_STEP_CELLS * smallest / np.sqrt(max(k_mu, k_lambda) / density)


def soft_turn(rest: np.ndarray, now: np.ndarray) -> np.ndarray:
    """(P, 3, 3): a soft body's best-fit rotation from its rest particles (P, 3) to where they are now
    (P, 3), for each particle, to carry the surface's offsets from its particles (``mpm.deform_surface``).
    Left unturned, the offsets of a ball rolling across a desk kept their rest directions, and its
    surface crumpled."""
    from scipy.spatial.transform import Rotation

    turn, _ = Rotation.align_vectors(now - now.mean(axis=0), rest - rest.mean(axis=0))
    return np.broadcast_to(turn.as_matrix(), (len(rest), 3, 3))


def _inset(verts: np.ndarray, bounds: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """The lattice's vertices (V, 3) fitted, axis by axis, to the mesh's bounds (2, 3) less the particles'
    ``radius`` (m), and the (3,) scale that took them there: at the extremes of the mesh's bounding box
    (its bottom, its top, its sides) the particles' surface is the mesh's, so whatever the mesh stands on
    or holds up touches it at the start, no deeper. Left with its nodes on the bounds, the particles
    stood a radius proud of every face, and a box resting on a sponge in the photo started that far
    inside it (6.7 mm on an 8 cm sponge) and was thrown off."""
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    want_lo, want_hi = bounds[0] + radius, bounds[1] - radius
    fits = (want_hi - want_lo > 0) & (hi - lo > 0)
    scale = np.where(fits, (want_hi - want_lo) / np.where(hi - lo > 0, hi - lo, 1.0), 1.0)
    centre = np.where(fits, (want_lo + want_hi) / 2, (lo + hi) / 2)
    return centre + (verts - (lo + hi) / 2) * scale, scale


def _volume(verts: np.ndarray, tets: np.ndarray) -> float:
    """Total volume (m³) of tetrahedra (T, 4) over vertices (V, 3)."""
    a, b, c, d = (verts[tets[:, k]] for k in range(4))
    return float(np.abs(np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a)).sum() / 6.0)


class ShapeDamping:
    """Damping of soft bodies' deformation (Müller et al. 2007, *Position Based Dynamics*, §3.5): after
    each XPBD substep, each soft body's particle velocities move toward the body's rigid motion (its
    centre of mass's velocity plus its angular velocity about it) by ``1 − exp(−dt / SOFT_DAMPING_S)``.
    Moving and turning as a whole is kept; wobbling dies out. Newton's own tetrahedral damping (Rayleigh,
    ``k_damp``) also slows the elastic correction, which at the relaxation soft bodies need
    (:data:`SOFT_RELAXATION`) left an 8 cm sponge too soft to hold its shape."""

    def __init__(self, body_of: np.ndarray, bodies: int, device):
        import warp as wp

        self.wp, self.device, self.bodies = wp, device, bodies
        self.body_of = wp.array(body_of.astype(np.int32), dtype=wp.int32, device=device)
        self.count = len(body_of)
        self.sums = wp.zeros(bodies, dtype=wp.vec4, device=device)  # Σm·x, Σm
        self.momentum = wp.zeros(bodies, dtype=wp.vec3, device=device)
        self.angular = wp.zeros(bodies, dtype=wp.vec3, device=device)
        self.inertia = wp.zeros(bodies, dtype=wp.mat33, device=device)

    @classmethod
    def of(cls, objects, ranges: dict, particle_count: int, device) -> "ShapeDamping | None":
        """The damping of every soft body among ``objects`` (``ranges``: path → (first particle, count));
        None when there is none."""
        body_of = np.full(particle_count, -1)
        k = 0
        for o in objects:
            if o.family == "soft" and o.path in ranges and not o.fixed:
                start, count = ranges[o.path]
                body_of[start:start + count] = k
                k += 1
        return cls(body_of, k, device) if k else None

    def apply(self, model, state, dt: float) -> None:
        wp, k = self.wp, _damping_kernels()
        rate = float(1.0 - np.exp(-dt / SOFT_DAMPING_S))
        for a in (self.sums, self.momentum, self.angular, self.inertia):
            a.zero_()
        x, v, m = state.particle_q, state.particle_qd, model.particle_mass
        wp.launch(k.sums, dim=self.count, inputs=[self.body_of, m, x, v], outputs=[self.sums, self.momentum],
                  device=self.device)
        wp.launch(k.moments, dim=self.count, inputs=[self.body_of, m, x, v, self.sums],
                  outputs=[self.angular, self.inertia], device=self.device)
        wp.launch(k.relax, dim=self.count, inputs=[self.body_of, x, self.sums, self.momentum, self.angular,
                                                   self.inertia, rate], outputs=[v], device=self.device)


@lru_cache(maxsize=1)
def _damping_kernels():
    import types

    import warp as wp

    @wp.kernel
    def sums(body: wp.array(dtype=wp.int32), m: wp.array(dtype=float), x: wp.array(dtype=wp.vec3),
             v: wp.array(dtype=wp.vec3), s: wp.array(dtype=wp.vec4), p: wp.array(dtype=wp.vec3)):
        i = wp.tid()
        b = body[i]
        if b < 0:
            return
        mx = m[i] * x[i]
        wp.atomic_add(s, b, wp.vec4(mx[0], mx[1], mx[2], m[i]))
        wp.atomic_add(p, b, m[i] * v[i])

    @wp.kernel
    def moments(body: wp.array(dtype=wp.int32), m: wp.array(dtype=float), x: wp.array(dtype=wp.vec3),
                v: wp.array(dtype=wp.vec3), s: wp.array(dtype=wp.vec4), L: wp.array(dtype=wp.vec3),
                inertia: wp.array(dtype=wp.mat33)):
        i = wp.tid()
        b = body[i]
        if b < 0 or s[b][3] <= 0.0:
            return
        r = x[i] - wp.vec3(s[b][0], s[b][1], s[b][2]) / s[b][3]
        wp.atomic_add(L, b, m[i] * wp.cross(r, v[i]))
        wp.atomic_add(inertia, b, m[i] * (wp.dot(r, r) * wp.identity(n=3, dtype=float) - wp.outer(r, r)))

    @wp.kernel
    def relax(body: wp.array(dtype=wp.int32), x: wp.array(dtype=wp.vec3), s: wp.array(dtype=wp.vec4),
              p: wp.array(dtype=wp.vec3), L: wp.array(dtype=wp.vec3), inertia: wp.array(dtype=wp.mat33),
              rate: float, v: wp.array(dtype=wp.vec3)):
        i = wp.tid()
        b = body[i]
        if b < 0 or s[b][3] <= 0.0:
            return
        mass = s[b][3]
        r = x[i] - wp.vec3(s[b][0], s[b][1], s[b][2]) / mass
        # per unit mass (m²): a millimetre body's inertia would underflow float32's determinant
        big = inertia[b] / mass
        omega = wp.vec3(0.0)
        if wp.determinant(big) > 0.0:
            omega = wp.inverse(big) * (L[b] / mass)
        rigid = p[b] / mass + wp.cross(omega, r)
        v[i] = v[i] + rate * (rigid - v[i])

    return types.SimpleNamespace(sums=sums, moments=moments, relax=relax)


class AirDrag:
    """Air resistance of cloths: a force −c·m·v on each particle (``c`` the cloth's ``air_resistance``,
    1/s), added to ``state.particle_f`` before each XPBD substep."""

    def __init__(self, coefficients: np.ndarray, device):
        import warp as wp

        self.wp, self.device = wp, device
        self.coefficients = wp.array(np.asarray(coefficients, np.float32), dtype=float, device=device)

    @classmethod
    def of(cls, objects, ranges: dict, particle_count: int, device) -> "AirDrag | None":
        """The drag of every cloth among ``objects`` (``ranges``: path → (first particle, count)); None when
        no cloth resists the air."""
        c = np.zeros(particle_count)
        for o in objects:
            if o.family == "cloth" and o.path in ranges:
                start, count = ranges[o.path]
                c[start:start + count] = float(o.params.get("air_resistance") or 0.0)
        return cls(c, device) if c.any() else None

    def apply(self, model, state) -> None:
        self.wp.launch(_drag_kernel(), dim=model.particle_count,
                       inputs=[self.coefficients, model.particle_mass, state.particle_qd],
                       outputs=[state.particle_f], device=self.device)


@lru_cache(maxsize=1)
def _drag_kernel():
    import warp as wp

    @wp.kernel
    def drag(c: wp.array(dtype=float), mass: wp.array(dtype=float), qd: wp.array(dtype=wp.vec3),
             f: wp.array(dtype=wp.vec3)):
        i = wp.tid()
        f[i] = f[i] - c[i] * mass[i] * qd[i]

    return drag
