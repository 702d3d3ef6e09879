"""Which substeps hold an impact, for the restitution passes (``stability.RESTITUTION_PASSES``).

Newton's XPBD solves restitution after every substep's position solve, on the contacts of its contact buffer
that came to overlap in it, each body pair's contacts together, then averages each body's changes over the
pairs it is in; the outer passes repeat that averaging until a body pressed between several others has
converged. Passes beyond the first change nothing in a substep where no contact fires (Newton skips a contact
slower than its resting threshold, 2·g·dt), and little where every contact is slower than
``stability.IMPACT_SPEED``, the speed below which a whole frame already gets Newton's default. A frame that may
hold an impact therefore decides its passes substep by substep, on the device (a captured frame replays the
choice; ``warp.capture_if``): the full passes where a contact of the buffer that can touch within the substep
moves along its normal faster than ``IMPACT_SPEED``, the default elsewhere. The contacts are those the solver
itself is handed, so a pair the last search did not hold is one the solver does not see either.

Within a substep the passes stop once one changes no body (:class:`PassGate`): the passes after it could change
nothing either, so the result is the same bit for bit. In the pile of ``bench peer`` about half the substeps
given the full passes stop early that way, most after 2 to 6."""

from __future__ import annotations

import threading
from functools import lru_cache

#: held while a gate stands in for the solver module's ``warp``: a preview and a build may step on two threads
_SWAP = threading.RLock()


def impact_kernel():
    """A kernel setting ``flag[0]`` to 1 where a contact that can touch within ``dt`` seconds (its gap at most
    what its approach closes meanwhile, plus ``reach``) has its two surface points moving apart or together along
    its normal faster than ``speed`` m/s."""
    return _kernels()[0]


def fired_kernel():
    """A kernel setting ``flag[0]`` to 1 where a restitution pass changed some body (its count of pairs that
    fired above zero)."""
    return _kernels()[1]


@lru_cache(maxsize=1)
def _kernels():
    # both defined before either is launched: a warp module whose kernels are added after it loaded is
    # compiled again (a second build of this module on a cold cache)
    import warp as wp

    @wp.func
    def surface_point(b: int, p: wp.vec3, body_q: wp.array(dtype=wp.transform),
                      body_qd: wp.array(dtype=wp.spatial_vector), body_com: wp.array(dtype=wp.vec3)):
        # the support point in the world, as the solver's overlap test places it, and its velocity
        if b < 0:
            return p, wp.vec3(0.0)
        X = body_q[b]
        world = wp.transform_point(X, p)
        com = wp.transform_point(X, body_com[b])
        qd = body_qd[b]
        return world, wp.spatial_top(qd) + wp.cross(wp.spatial_bottom(qd), world - com)

    @wp.kernel
    def impact(count: wp.array(dtype=wp.int32), shape0: wp.array(dtype=wp.int32), shape1: wp.array(dtype=wp.int32),
               point0: wp.array(dtype=wp.vec3), point1: wp.array(dtype=wp.vec3), normal: wp.array(dtype=wp.vec3), margin0: wp.array(dtype=float),
               margin1: wp.array(dtype=float), shape_body: wp.array(dtype=wp.int32),
               body_q: wp.array(dtype=wp.transform), body_qd: wp.array(dtype=wp.spatial_vector),
               body_com: wp.array(dtype=wp.vec3), dt: float, reach: float, speed: float,
               flag: wp.array(dtype=wp.int32)):
        tid = wp.tid()
        if tid >= count[0]:
            return
        s0 = shape0[tid]
        s1 = shape1[tid]
        b0 = -1
        b1 = -1
        if s0 >= 0:
            b0 = shape_body[s0]
        if s1 >= 0:
            b1 = shape_body[s1]
        if b0 == b1:
            return
        w0, v0 = surface_point(b0, point0[tid], body_q, body_qd, body_com)
        w1, v1 = surface_point(b1, point1[tid], body_q, body_qd, body_com)
        n = normal[tid]
        closing = -wp.dot(v1 - v0, n)  # > 0: the two points approach
        gap = wp.dot(n, w1 - w0) - (margin0[tid] + margin1[tid])
        if gap <= wp.max(closing, 0.0) * dt + reach and wp.abs(closing) > speed:
            flag[0] = 1

    @wp.kernel
    def fired(count: wp.array(dtype=float), flag: wp.array(dtype=wp.int32)):
        if count[wp.tid()] > 0.0:
            flag[0] = 1

    return impact, fired

class PassGate:
    """Newton's restitution passes, each after the first run only where the pass before it changed a body.
    A pass that changes nothing hands the next one the same velocities at the same bound (the bound differs
    only in the first pass, and a first pass that fires nothing under its looser bound cannot fire under the
    later one), so every pass after it would change nothing too: skipping them leaves the result bit for bit
    the same. The check runs on the device (``warp.capture_if``), so a captured frame replays it.

    Newton runs its passes in a loop inside ``SolverXPBD.step``; while :meth:`step` runs, the solver module's
    ``warp`` is this gate, which passes every call through unchanged except the two launches of a pass, which
    it runs together under the condition. A Newton whose solver does not name the two kernels as expected
    (:attr:`usable` False) is stepped as it is."""

    def __init__(self, solver):
        import inspect

        import warp as wp

        self._wp = wp
        self.module = inspect.getmodule(type(solver).step)
        self.solve = getattr(self.module, "solve_manifold_restitution", None)
        self.apply = getattr(self.module, "apply_restitution_deltas", None)
        # the pass index and the fired pairs per body, found by name: a Newton that renamed or reordered them
        # is stepped as it is rather than gated on the wrong argument
        names = [a.label for a in getattr(getattr(self.solve, "adj", None), "args", ())]
        self._outer_at = names.index("outer_iteration") if "outer_iteration" in names else None
        self._count_at = names.index("body_manifold_count") if "body_manifold_count" in names else None
        with _SWAP:  # another thread's gate may hold the module swapped meanwhile
            plain = getattr(self.module, "wp", None) is wp
        self.usable = (self.module is not None and plain and self.apply is not None
                       and self._outer_at is not None and self._count_at is not None)
        self.flag = wp.zeros(1, dtype=wp.int32, device=solver.model.device) if self.usable else None
        self._pending = self._owner = None

    def __getattr__(self, name):
        if name.startswith("_"):  # never through to warp: an instance not yet initialised (a copy) has no _wp
            raise AttributeError(name)
        return getattr(self._wp, name)

    def step(self, solver, *args) -> None:
        """``solver.step(*args)`` with the passes gated."""
        if not self.usable:
            solver.step(*args)
            return
        with _SWAP:
            self._pending, self._owner = None, threading.get_ident()
            self.module.wp = self
            try:
                solver.step(*args)
                self._flush()  # a solve no apply followed (not Newton's loop today): run it, never drop it
            finally:
                self.module.wp, self._owner = self._wp, None

    def _flush(self) -> None:
        pending, self._pending = self._pending, None
        if pending is not None:
            self._wp.launch(self.solve, **pending)

    def launch(self, kernel=None, *args, **kwargs):
        wp = self._wp
        if threading.get_ident() != self._owner:  # an unguarded solver stepping on another thread meanwhile
            return wp.launch(kernel, *args, **kwargs)
        if kernel is self.solve and not args and "inputs" in kwargs and "outputs" in kwargs:
            self._flush()
            self._pending = kwargs
            return None
        pending, self._pending = self._pending, None
        if pending is None or kernel is not self.apply or args:
            if pending is not None:
                wp.launch(self.solve, **pending)
            return wp.launch(kernel, *args, **kwargs)
        given = list(pending["inputs"]) + list(pending["outputs"])
        outer = given[self._outer_at] if self._outer_at < len(given) else None
        counts = given[self._count_at] if self._count_at < len(given) else None
        if not (isinstance(outer, int) and getattr(counts, "dtype", None) is wp.float32):
            wp.launch(self.solve, **pending)  # a Newton that lays the pass out otherwise: its loop as it is
            return wp.launch(kernel, **kwargs)
        device = wp.get_device(counts.device)
        # on a GPU outside a capture the branch would copy the flag to the host and wait, once per pass
        always = outer == 0 or not (device.is_cpu or device.is_capturing)

        def one_pass():
            wp.launch(self.solve, **pending)
            self.flag.zero_()
            wp.launch(fired_kernel(), dim=counts.shape[0], inputs=[counts], outputs=[self.flag],
                      device=counts.device)
            wp.launch(kernel, **kwargs)

        if always:
            one_pass()
        else:
            wp.capture_if(self.flag, on_true=one_pass)
        return None
