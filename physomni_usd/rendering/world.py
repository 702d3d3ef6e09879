"""The world around the objects: the ground plane and a backdrop, both reaching past the photo's frame.

The photo shows the ground up to some distance and, above it, whatever stands
far away. We model that as two planes: the ground (z = 0, the shot's ground)
and a vertical backdrop facing the photo's camera at the depth of the photo's
far content. Both are textured by projecting the (extended) plate from the
photo's own camera, so frame 0 reproduces the plate and a moving camera sees
the same surfaces from elsewhere. A ray that meets neither (a camera turned
far away from the scene) ends on a far sphere, so every pixel sees something
and every depth is finite.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Kinds of environment surface a ray can end on.
GROUND, BACKDROP, FAR = 0, 1, 2


@dataclass
class Environment:
    """Ground z = 0 and the backdrop plane ``dot(p, normal_h) = offset`` (normal_h horizontal, towards the camera).

    ``far`` is the radius of the sphere about ``centre`` that catches rays meeting neither plane.
    """

    backdrop_normal: np.ndarray  # (3,) unit, horizontal, pointing back at the photo's camera
    backdrop_offset: float  # metres: the plane is dot(p, backdrop_normal) = backdrop_offset
    centre: np.ndarray  # (3,) centre of the far sphere (the photo's camera)
    far: float  # metres

    def intersect(self, origin: np.ndarray, rays: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Where rays from ``origin`` (3,) along unit ``rays`` (..., 3) end on the environment.

        Returns the distance along each ray (...,) in metres (finite everywhere), the surface kind (...,)
        (:data:`GROUND`, :data:`BACKDROP` or :data:`FAR`) and the world-space unit normal (..., 3).
        """
        o = np.asarray(origin, np.float64)
        d = np.asarray(rays, np.float64)
        with np.errstate(divide="ignore", invalid="ignore"):
            t_ground = np.where(d[..., 2] < -1e-9, -o[2] / d[..., 2], np.inf)
            dn = d @ self.backdrop_normal
            t_back = np.where(dn < -1e-9, (self.backdrop_offset - o @ self.backdrop_normal) / dn, np.inf)
        t_ground = np.where(t_ground > 0, t_ground, np.inf)
        t_back = np.where(t_back > 0, t_back, np.inf)
        # the far sphere, from inside: t = −b + sqrt(b² − c), with c < 0 while the origin is inside it
        oc = o - self.centre
        b = d @ oc
        c = float(oc @ oc) - self.far ** 2
        t_far = -b + np.sqrt(np.maximum(b * b - c, 0.0))
        t_far = np.where(t_far > 0, t_far, self.far)
        t = np.minimum(np.minimum(t_ground, t_back), t_far)
        kind = np.where(t == t_ground, GROUND, np.where(t == t_back, BACKDROP, FAR)).astype(np.int8)
        normal = np.zeros(d.shape, np.float64)
        normal[kind == GROUND] = (0.0, 0.0, 1.0)
        normal[kind == BACKDROP] = self.backdrop_normal
        far = kind == FAR
        if far.any():
            p = o + d[far] * t[far][:, None] - self.centre
            normal[far] = -p / np.linalg.norm(p, axis=-1, keepdims=True)
        return t, kind, normal


#: How far behind the farthest object the backdrop stands, as a share of that object's distance.
BACKDROP_BEHIND = 0.1
#: Pitch (degrees below level) beyond which the photo is taken to show the ground up to its top edge.
GROUND_PITCH_DEG = 45.0


def photo_environment(camera, farthest: float) -> Environment:
    """The environment seen by the photo's ``camera`` (a RenderCamera).

    ``farthest`` (metres) is the largest horizontal distance from the camera to a point of an object. What
    the photo shows behind the objects is most often what stands behind them (a wall, a shelf, the far side
    of a table): the backdrop stands just behind the farthest object. A camera pitched down more than
    :data:`GROUND_PITCH_DEG` sees mostly the surface the objects stand on: there the backdrop stands where the
    photo's top edge meets the ground, so that all the photo shows is ground. Never nearer than 1 m.
    """
    forward = np.asarray(camera.axes[2], np.float64)
    h = np.array([forward[0], forward[1], 0.0])
    if np.linalg.norm(h) < 1e-6:  # looking straight down: "forward" is the photo's up direction
        h = -np.asarray(camera.axes[1], np.float64) * [1.0, 1.0, 0.0]
    h /= np.linalg.norm(h)
    origin = np.asarray(camera.origin, np.float64)
    distance = (1.0 + BACKDROP_BEHIND) * farthest
    top = camera.rays()[0]  # (W, 3) the photo's top row
    pitch = np.degrees(np.arcsin(np.clip(-forward[2], -1.0, 1.0)))
    if np.all(top[:, 2] < -1e-6) and (pitch > GROUND_PITCH_DEG or farthest <= 0):
        t = -origin[2] / top[:, 2]
        distance = max(distance, float(np.max((top * t[:, None]) @ h)) * 1.02)
    distance = max(distance, 1.0)
    offset = float(origin @ h) + distance
    return Environment(-h, -offset, origin, 50.0 * distance)
