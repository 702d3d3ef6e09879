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
itself is handed, so a pair the last search did not hold is one the solver does not see either."""

from __future__ import annotations

from functools import lru_cache


@lru_cache(maxsize=1)
def impact_kernel():
    """A kernel setting ``flag[0]`` to 1 where a contact that can touch within ``dt`` seconds (its gap at most
    what its approach closes meanwhile, plus ``reach``) has its two surface points moving apart or together along
    its normal faster than ``speed`` m/s."""
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

    return impact
