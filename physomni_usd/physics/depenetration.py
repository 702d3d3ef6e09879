"""Start overlaps resolved at a bounded separation speed: objects lifted from a photo often start a few
millimetres inside each other, and XPBD separates them by moving their positions, from which it derives
their velocities — 5 mm corrected in one 4 ms substep is 1.2 m/s, and halving the step doubles it. For the
first moments of a run (:attr:`Depenetration.until`), every body found in a start overlap and every
cloth particle that starts at rest is kept below ``SEPARATION_SPEED`` plus what gravity and the force fields
alone could have given it since t = 0 (the way PhysX bounds its depenetration velocity): the positions
separate, the velocity the correction would inject does not appear, and nothing that was at rest in the
photo gains speed from it. The energy the separation adds (lifting a body out of another) is the solver's
work, bounded by :meth:`Depenetration.energy_bound`, and the guard counts it as such.

The guard arms the bound again where it rolls back to a state that holds an overlap (:meth:`Depenetration.rearm`):
a coarse step can leave a hull a millimetre inside what it rests on between two contact searches, and the finer
step the guard retries with would otherwise separate it at d/dt — faster the finer the step (1.4 mm under a cup
became 0.5 m/s at 64 substeps a frame and 10 m/s at 512, and the run diverged for taking finer steps)."""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from .stability import GRAVITY

#: m/s: the fastest a start overlap is pushed apart (PhysX's default bound is 5 m/s for games; objects on a
#: table that start 5 mm inside each other separate in 50 ms at this speed, too slow to be seen as a jump).
SEPARATION_SPEED = 0.1
#: Overlaps shallower than this (m) are the contact margin, not an overlap.
OVERLAP_MIN_M = 1e-4
#: A roll-back re-arms the bound only for overlaps deeper than this (m): XPBD leaves bodies resting under load
#: a few tenths of a millimetre deep (a stack of four 2000 kg/m3 boxes sits 0.23-0.30 mm deep at every check),
#: and re-arming at that depth would clamp nearly every body of a loaded scene at each roll-back (a ball hitting
#: a stack could not move it); the overlap a coarse step leaves between two contact searches is a millimetre or
#: more (1.39 mm under the cup whose finer retry diverged).
REARM_OVERLAP_M = 1e-3
#: How long the bound holds (s): at least the first, at most the second, else three times the time the
#: deepest overlap takes to separate at ``SEPARATION_SPEED``.
WINDOW_S = (0.1, 0.5)


class Depenetration:
    """The velocity bound of a :class:`~.stepping.Stepper`'s start overlaps. ``bodies`` and ``particles``
    are the indices bounded, ``depth`` the deepest start overlap (m), ``until`` how long (s) the bound holds
    after :attr:`since`; a stepper holding one calls :meth:`apply` after each substep while :meth:`active`."""

    def __init__(self, stepper, acceleration: float = GRAVITY):
        import warp as wp

        model, state = stepper.model, stepper.state
        self.acceleration = float(acceleration)
        bodies, self.depth = _overlapping_bodies(stepper)
        self.particles = _resting_particles(model, state, stepper.pending)
        if stepper.separating_particles is not None:
            self.particles = np.intersect1d(self.particles, stepper.separating_particles)
        if model.particle_count and len(self.particles):
            self.depth = max(self.depth, _particle_depth(stepper))
        until = _window(self.depth) if bodies or len(self.particles) else 0.0
        self.bodies = _unpushed(bodies, stepper.pending, until)
        self.until = until if self.any else 0.0
        device = model.device
        # the frame's start time within the window and the window's length, written outside a capture
        self._t = wp.zeros(2, dtype=float, device=device)
        self._body_cap = self._caps(model.body_count, self.bodies, device)
        self._particle_cap = self._caps(model.particle_count, self.particles, device)
        self._radius = None
        if model.body_count:
            # an angular speed ω moves a body's surface at ω·r: bound it through the radius of gyration
            mass = np.maximum(model.body_mass.numpy(), 1e-12)
            inertia = model.body_inertia.numpy()
            r = np.sqrt(np.trace(inertia, axis1=1, axis2=2) / mass)
            self._radius = wp.array(np.maximum(r, 1e-3).astype(np.float32), dtype=float, device=device)
        self._masses = (model.body_mass.numpy()[self.bodies] if len(self.bodies) else np.zeros(0),
                        model.particle_mass.numpy()[self.particles] if len(self.particles) else np.zeros(0))
        #: when the bound's window opened (s): 0 for the start overlaps, the roll-back's time once re-armed
        self.since = 0.0
        self._prior_j = 0.0  # the energy bound of the windows before this one
        self._start = (self.bodies, self.particles, self.depth, self.until, self._masses)
        self.rearms = 0

    def rearm(self, stepper, t: float) -> bool:
        """Open a new window at time ``t`` (s) for the rigid bodies in an overlap deeper than ``REARM_OVERLAP_M``
        in ``stepper``'s state now (the guard has just rolled back to it); returns whether any was found. Only
        bodies are bounded: a particle's start rest does not hold mid-run. A body already moving faster than
        ``SEPARATION_SPEED`` there (its centre, or its surface turning: ω times its radius of gyration) keeps
        its own speed as its cap: the bound stops the separation adding speed, it takes none away from a body
        caught mid-impact. The caps are written into the same arrays, so frames captured before read them."""
        if self._body_cap is None:
            return False
        bodies, depth = _overlapping_bodies(stepper, REARM_OVERLAP_M)
        # searched a second time, as a new model's contacts are: one search is matched against the failed
        # attempt's contacts, and the retry would start from a contact history the run never had there
        if stepper.pipeline is not None:
            stepper.pipeline.collide(stepper.state, stepper.contacts)
        widening = self.active(t)
        end = max(self.since + self.until, t + _window(depth)) if widening else t + _window(depth)
        bodies = _unpushed(bodies, stepper.pending, end)
        if not len(bodies):
            return False
        qd = stepper.state.body_qd.numpy()[bodies].astype(np.float64)
        turning = np.linalg.norm(qd[:, 3:], axis=1) * self._radius.numpy()[bodies]
        caps = np.maximum(np.maximum(np.linalg.norm(qd[:, :3], axis=1), turning), SEPARATION_SPEED)
        body_mass = stepper.model.body_mass.numpy()
        if widening:
            # the window open at t (the start's, with its resting cloth, or an earlier roll-back's) goes on,
            # widened: replacing it would drop its particles, its bodies and their mass from the energy bound
            old = self._body_cap.numpy()
            merged = np.union1d(self.bodies, bodies).astype(int)
            body_caps = old[merged]
            mine = np.searchsorted(merged, bodies)
            body_caps[mine] = np.maximum(body_caps[mine], caps)
            depth = max(self.depth, depth)
            until = max(self.until, t - self.since + _window(depth))
            self._open(merged, self.particles, depth, until, (body_mass[merged], self._masses[1]), self.since,
                       body_caps)
        else:
            if t != self.since:  # a second roll-back to the same state re-opens its window, not adds to it
                self._prior_j = self.energy_bound(math.inf)
            self._open(bodies, np.zeros(0, int), depth, _window(depth), (body_mass[bodies], np.zeros(0)), t, caps)
        self.rearms += 1
        return True

    def restart(self) -> None:
        """Back to the start overlaps' window (the run went back to t = 0)."""
        self._prior_j, self.rearms = 0.0, 0
        self._open(*self._start, 0.0)

    def _open(self, bodies, particles, depth, until, masses, since, body_caps=SEPARATION_SPEED) -> None:
        self.bodies, self.particles, self.depth, self.until, self._masses = bodies, particles, depth, until, masses
        self.since = float(since)
        for cap, indices, values in ((self._body_cap, bodies, body_caps),
                                     (self._particle_cap, particles, SEPARATION_SPEED)):
            if cap is not None:
                cap.assign(_cap_values(cap.shape[0], indices, values))

    @staticmethod
    def _caps(count: int, indices: np.ndarray, device):
        import warp as wp

        return wp.array(_cap_values(count, indices), dtype=float, device=device) if count else None

    @property
    def any(self) -> bool:
        return bool(len(self.bodies) or len(self.particles))

    def active(self, t0: float) -> bool:
        """Whether the bound acts in a frame starting at ``t0`` (s)."""
        return self.any and self.since <= t0 + 1e-9 and t0 - self.since < self.until

    def set_time(self, t0: float) -> None:
        """The frame's start time within the window, read by the kernels (a captured frame reads it from the
        device): what gravity may have given a body is counted from the window's opening."""
        self._t.assign(np.array([max(float(t0) - self.since, 0.0), self.until], np.float32))

    def apply(self, model, state, t_offset: float) -> None:
        """Bound the velocities in ``state``, ``t_offset`` seconds after the frame's start."""
        import warp as wp

        body_kernel, particle_kernel = _kernels()
        if self._body_cap is not None and len(self.bodies):
            wp.launch(body_kernel, dim=model.body_count,
                      inputs=[state.body_qd, self._body_cap, self._radius, self._t, t_offset, self.acceleration],
                      device=model.device)
        if self._particle_cap is not None and len(self.particles):
            wp.launch(particle_kernel, dim=model.particle_count,
                      inputs=[state.particle_qd, self._particle_cap, self._t, t_offset, self.acceleration],
                      device=model.device)

    def energy_bound(self, t: float) -> float:
        """Most energy (J) the separation can have added by time ``t``: each bounded mass lifted by the
        deepest overlap plus the kinetic energy of the bound's speed (the fall gravity gives is not counted:
        it converts energy, it adds none)."""
        m = float(self._masses[0].sum() + self._masses[1].sum())
        now = m * (GRAVITY * self.depth + 0.5 * SEPARATION_SPEED ** 2) if self.any and t > self.since else 0.0
        return self._prior_j + now

    def as_dict(self) -> dict:
        return {"bodies": len(self.bodies), "particles": len(self.particles), "deepest_m": round(self.depth, 5),
                "until_s": round(self.since + self.until, 4), "separation_speed_m_s": SEPARATION_SPEED,
                "rearmed": self.rearms}


def _unpushed(bodies, pending, until: float) -> np.ndarray:
    """``bodies`` less those a push reaches before ``until`` (s): the push sets their speed within the window,
    which the bound would clip; a push due after the window closes leaves the body to it."""
    pushed = {p.body for p in pending if p.body is not None and p.at < until}
    return np.array([b for b in bodies if b not in pushed], int)


def _cap_values(count: int, indices: np.ndarray, values=SEPARATION_SPEED) -> np.ndarray:
    """(count,) float32 speed caps (m/s): ``values`` at ``indices``, −1 (not bounded) elsewhere."""
    caps = np.full(count, -1.0, np.float32)
    caps[indices] = values
    return caps


def _window(depth: float) -> float:
    """How long (s) the bound holds for an overlap ``depth`` (m) deep."""
    return float(np.clip(3.0 * depth / SEPARATION_SPEED, *WINDOW_S))


def _overlapping_bodies(stepper, deeper_than: float = OVERLAP_MIN_M) -> tuple[list[int], float]:
    """Dynamic bodies in a rigid contact deeper than ``deeper_than`` (m) in the stepper's state, and the
    deepest."""
    model, state = stepper.model, stepper.state
    if stepper.pipeline is None or not model.body_count:
        return [], 0.0
    c = stepper.contacts
    stepper.pipeline.collide(state, c)
    n = int(c.rigid_contact_count.numpy()[0])
    if not n:
        return [], 0.0
    from scipy.spatial.transform import Rotation

    shape_body = model.shape_body.numpy()
    q = state.body_q.numpy().astype(np.float64)
    inv_mass = model.body_inv_mass.numpy()
    s0, s1 = c.rigid_contact_shape0.numpy()[:n], c.rigid_contact_shape1.numpy()[:n]
    p0, p1 = c.rigid_contact_point0.numpy()[:n], c.rigid_contact_point1.numpy()[:n]
    normal = c.rigid_contact_normal.numpy()[:n]
    margin = c.rigid_contact_margin0.numpy()[:n] + c.rigid_contact_margin1.numpy()[:n]

    def world(shapes, points):
        b = shape_body[shapes]
        out = points.astype(np.float64).copy()
        on_body = b >= 0
        if on_body.any():
            qb = q[b[on_body]]
            out[on_body] = Rotation.from_quat(qb[:, 3:7]).apply(points[on_body]) + qb[:, :3]
        return out, b

    w0, b0 = world(s0, p0)
    w1, b1 = world(s1, p1)
    depth = -(np.einsum("ij,ij->i", normal, w1 - w0) - margin)
    deep = depth > deeper_than
    # contacts with the ground or a fixed body count too: a body sunk into the floor separates as slowly
    bodies = {int(b) for b in np.concatenate([b0[deep], b1[deep]]) if b >= 0 and inv_mass[b] > 0}
    return sorted(bodies), float(depth[deep].max()) if deep.any() else 0.0


def _resting_particles(model, state, pending) -> np.ndarray:
    """Particles (cloth, soft bodies) that start at rest, are not pinned, and get no push."""
    if not model.particle_count:
        return np.zeros(0, int)
    v = np.linalg.norm(state.particle_qd.numpy(), axis=1)
    keep = (model.particle_mass.numpy() > 0) & (v == 0)
    for p in pending:
        if p.particles and not p.mpm:
            keep[p.particles[0]:p.particles[0] + p.particles[1]] = False
    return np.flatnonzero(keep)


def _particle_depth(stepper) -> float:
    """Deepest a particle's sphere starts inside a shape (m), from the contacts the search found."""
    depth = _particle_contacts(stepper)[2]
    return float(max(depth.max(), 0.0)) if len(depth) else 0.0


def _particle_contacts(stepper) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The particle–shape contacts the last search found: (N,) particle indices, (N, 3) normals pointing
    out of the shape (in world axes, as Newton stores them), (N,) depths (m, positive inside), (N,) the
    shape's body (-1: static)."""
    model, state, c = stepper.model, stepper.state, stepper.contacts
    empty = (np.zeros(0, int), np.zeros((0, 3)), np.zeros(0), np.zeros(0, int))
    if c is None:
        return empty
    n = int(c.soft_contact_count.numpy()[0])
    if not n:
        return empty
    from scipy.spatial.transform import Rotation

    idx = c.soft_contact_indices.numpy()[:n, 0]
    shapes = c.soft_contact_shape.numpy()[:n]
    pos = c.soft_contact_body_pos.numpy()[:n].astype(np.float64)
    normal = c.soft_contact_normal.numpy()[:n].astype(np.float64)
    shape_body = model.shape_body.numpy()
    q = state.body_q.numpy().astype(np.float64) if model.body_count else np.zeros((0, 7))
    b = shape_body[shapes]
    on_body = b >= 0
    if on_body.any():
        qb = q[b[on_body]]
        pos[on_body] = Rotation.from_quat(qb[:, 3:7]).apply(pos[on_body]) + qb[:, :3]  # stored in the body's frame
    ok = idx >= 0
    idx, pos, normal, b = idx[ok], pos[ok], normal[ok], b[ok]
    x = state.particle_q.numpy()[idx].astype(np.float64)
    r = model.particle_radius.numpy()[idx]
    return idx, normal, r - np.einsum("ij,ij->i", normal, x - pos), b


def _movable_bodies(model) -> np.ndarray:
    """(B,) whether each body moves: some mass, and not kinematic."""
    if not model.body_count:
        return np.zeros(0, bool)
    import newton

    kinematic = (model.body_flags.numpy() & int(newton.BodyFlags.KINEMATIC)) != 0
    return (model.body_inv_mass.numpy() > 0) & ~kinematic


def lift_out(stepper, ranges: dict, bodies: dict | None = None, fixed=(), passes: int = 3) -> dict:
    """Move each soft body (``ranges``: path → (first particle, count)) that starts inside a shape out of
    it as a whole, before the first step, along the normal of its deepest contact; returns path → the
    distance moved (m). A soft body's particles cannot be held to the separation bound (that clips the
    body's own elastic motion), and left to the contacts a 2 mm overlap launched an 8 cm sponge at
    6 m/s; moved as one, nothing in it is strained and nothing gains speed.

    A rigid body that moves and lies on the soft body (the contact's normal, out of the body, points
    down) is lifted out of it instead (``bodies``: body index → path, for what is returned): moving the
    soft body down would only press it into what holds it up, and a box 3 mm into the sponge it rests
    on, left to the contacts, was thrown off at tens of joules. A soft body in ``fixed`` (paths) is never
    moved, but what lies on it is lifted all the same. A lifted body that then starts inside another rigid
    body is separated like any rigid start overlap, at the bounded speed (:class:`Depenetration`)."""
    moved = {}
    bodies = bodies or {}
    movable = _movable_bodies(stepper.model)
    for _ in range(passes):
        if stepper.pipeline is not None:
            stepper.pipeline.collide(stepper.state, stepper.contacts)
        idx, normal, depth, body = _particle_contacts(stepper)
        q = stepper.state.particle_q.numpy()
        bq = stepper.state.body_q.numpy() if movable.size else None
        lifts = {}  # body index → the shift that takes it out of every soft body it lies on
        changed = False
        for path, (start, count) in ranges.items():
            mine = (idx >= start) & (idx < start + count) & (depth > OVERLAP_MIN_M)
            on_top = mine & (body >= 0) & (normal[:, 2] < 0)
            on_top[on_top] = movable[body[on_top]]
            for b in np.unique(body[on_top]):
                k = np.flatnonzero(on_top & (body == b))
                k = k[np.argmax(depth[k])]
                shift = -normal[k] * (depth[k] + OVERLAP_MIN_M)
                if np.linalg.norm(shift) > np.linalg.norm(lifts.get(int(b), np.zeros(3))):
                    lifts[int(b)] = shift
            mine &= ~on_top
            if not mine.any() or path in fixed:
                continue
            k = np.flatnonzero(mine)[np.argmax(depth[mine])]
            shift = normal[k] * (depth[k] + OVERLAP_MIN_M)
            q[start:start + count] += shift.astype(q.dtype)
            moved[path] = moved.get(path, 0.0) + float(np.linalg.norm(shift))
            changed = True
        for b, shift in lifts.items():
            bq[b, :3] += shift.astype(bq.dtype)
            name = bodies.get(b, f"body {b}")
            moved[name] = moved.get(name, 0.0) + float(np.linalg.norm(shift))
            changed = True
        if not changed:
            break
        stepper.state.particle_q.assign(q)
        if lifts:
            stepper.state.body_q.assign(bq)
    return moved


@lru_cache(maxsize=1)
def _kernels():
    import warp as wp

    @wp.kernel
    def bound_bodies(qd: wp.array(dtype=wp.spatial_vector), cap: wp.array(dtype=float), radius: wp.array(dtype=float),
                     t0: wp.array(dtype=float), t_offset: float, accel: float):
        b = wp.tid()
        c = cap[b]
        t = t0[0] + t_offset
        if c < 0.0 or t >= t0[1]:
            return
        c = c + accel * t
        w = qd[b]
        v = wp.spatial_top(w)
        om = wp.spatial_bottom(w)
        n = wp.length(v)
        if n > c:
            v = v * (c / n)
        m = wp.length(om)
        c_w = c / radius[b]
        if m > c_w:
            om = om * (c_w / m)
        qd[b] = wp.spatial_vector(v, om)

    @wp.kernel
    def bound_particles(qd: wp.array(dtype=wp.vec3), cap: wp.array(dtype=float), t0: wp.array(dtype=float),
                        t_offset: float, accel: float):
        i = wp.tid()
        c = cap[i]
        t = t0[0] + t_offset
        if c < 0.0 or t >= t0[1]:
            return
        c = c + accel * t
        v = qd[i]
        n = wp.length(v)
        if n > c:
            qd[i] = v * (c / n)

    return bound_bodies, bound_particles
