"""What the artist controls per object besides its material: fixed bodies, and velocities given at a
time (``physomni:initialVelocity`` / ``initialAngularVelocity`` / ``velocityStartTime``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pxr import Usd


@dataclass
class Push:
    """A velocity given at ``at`` seconds to a rigid body (``body``) or to a range of particles
    (``particles`` = (first, count), of the MPM model when ``mpm``)."""
    at: float
    linear: np.ndarray | None  # m/s
    angular: np.ndarray | None = None  # rad/s, bodies only
    body: int | None = None
    particles: tuple[int, int] | None = None
    mpm: bool = False


def read_controls(stage: Usd.Stage, path_body: dict, own: set | frozenset = frozenset()) -> tuple[set, list[Push]]:
    """Fixed bodies, and the velocities ``physomni:initialVelocity`` / ``initialAngularVelocity`` give them.
    The bodies at the paths in ``own`` were built here, not by Newton's USD importer (a hollow body cut into
    convex pieces, a stand-in): the importer gives a body its UsdPhysics ``physics:velocity`` (what ``run
    --push`` at 0 s writes), so these take it as a push at 0 s; without it a pushed pot stood still."""
    fixed, pushes = set(), []
    for path, b in path_body.items():
        prim = stage.GetPrimAtPath(path)
        if prim.GetAttribute("physomni:fixed").Get():
            fixed.add(b)
            continue
        push = _initial_velocity(prim) or (_rigid_body_velocity(prim) if path in own else None)
        if push is not None:
            push.body = b
            pushes.append(push)
    return fixed, pushes


def particle_pushes(stage: Usd.Stage, ranges: dict, mpm: bool = False) -> list[Push]:
    """The same for objects made of particles: path → (first particle, count). An object a layer switched
    from rigid keeps the UsdPhysics ``physics:velocity`` its rigid body was given (``run --push`` at 0 s
    writes that) as a push at 0 s: that layer changes what it is made of, not how it was pushed."""
    pushes = []
    for path, rng in ranges.items():
        prim = stage.GetPrimAtPath(path)
        push = _initial_velocity(prim) or _rigid_body_velocity(prim)
        if push is not None and push.linear is not None:
            push.particles, push.mpm = rng, mpm
            pushes.append(push)
    return pushes


def _initial_velocity(prim: Usd.Prim) -> Push | None:
    lin = prim.GetAttribute("physomni:initialVelocity")
    ang = prim.GetAttribute("physomni:initialAngularVelocity")
    lin = np.asarray(lin.Get(), float) if lin and lin.HasAuthoredValue() else None
    ang = np.radians(np.asarray(ang.Get(), float)) if ang and ang.HasAuthoredValue() else None
    if lin is None and ang is None:
        return None
    at = prim.GetAttribute("physomni:velocityStartTime")
    return Push(max(float(at.Get() or 0.0) if at else 0.0, 0.0), lin, ang)


def _rigid_body_velocity(prim: Usd.Prim) -> Push | None:
    attr = prim.GetAttribute("physics:velocity")
    return Push(0.0, np.asarray(attr.Get(), float)) if attr and attr.HasAuthoredValue() else None


def give_velocities(pushes: list[Push], state, mpm_state=None) -> None:
    """Set each push's velocity: bodies in ``state``, particles in ``state`` or (MPM) ``mpm_state``."""
    bodies = [p for p in pushes if p.body is not None]
    if bodies:
        qd = state.body_qd.numpy()
        for p in bodies:
            if p.linear is not None:
                qd[p.body, :3] = p.linear
            if p.angular is not None:
                qd[p.body, 3:] = p.angular
        state.body_qd.assign(qd)
    for target, mine in ((state, [p for p in pushes if p.particles and not p.mpm]),
                         (mpm_state, [p for p in pushes if p.particles and p.mpm])):
        if mine:
            v = target.particle_qd.numpy()
            for p in mine:
                start, count = p.particles
                v[start:start + count] = p.linear
            target.particle_qd.assign(v)
