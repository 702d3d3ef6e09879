"""Frames of a shot composited over its plate, written as an H.264 MP4.

H.264 in yuv420p needs even sides: a photo with an odd width or height is
rendered at its own size and the video drops its last column or row, so that
the video never shows a pixel the photo does not have.
"""

from __future__ import annotations

import dataclasses
import pathlib
import time
from dataclasses import dataclass

import cv2
import numpy as np
from pxr import Usd, UsdGeom

from .._files import all_or_nothing, atomic_path, make_dirs
from .._warp import pick_device
from ..errors import InputError
from ..report import prepare_writes, update_report
from ..settings import BuildSettings, RenderSettings
from ..usd import layers
from ..geometry.camera import RenderCamera
from ..geometry.raycast import ContactCaster, RayCaster, contact_falloff, covered_pixels
from ..texture.fill import hole_owners
from ..usd.author import write_render_layer
from .moves import LIMITS as MOVE_LIMITS, MOVES, move_matrices
from .encode import encoder_failure, even_sides, video_writer
from .passes import PassWriter, pass_files
from .stage import (read_camera, read_objects, read_particles, read_photo, read_photo_camera, read_photo_points,
                    read_photo_camera_matrix, read_plate, read_wide_plate, visible, world_points)
from .pillow import with_pillows
from .world import photo_environment


#: Contact shadows are soft (blurred over 1.2 % of the diagonal), so their ground points are taken on a grid this
#: many times coarser in each direction: each costs a closest-point query per moved object (at 4, the desk's ball
#: alone took 45 ms of CPU a frame).
SHADOW_STEP = 8
#: An object that has moved no more than this many pixels is in place: the frame shows the photo there (its
#: edges, its real shadow), not the texture over the plate. Through the photo's camera the motion is that of the
#: object's own points from where build placed them (:meth:`ShotRenderer._photo_points`), so that the first frame
#: is the photo whatever mesh the build lifted; through any other camera it is how far the surface seen is from
#: where the photo shows it.
IN_PLACE_PX = 0.75
#: Further motion, in pixels, over which an object changes from the photo to its texture over the plate
#: (the plate without it and its contact shadow, and its synthetic shadow wherever it now is).
REVEAL_PX = 2.0
#: A frame of a video whose objects have all moved less than this many pixels on the screen since the last frame
#: drawn (through the same camera, nothing shown or hidden, no particles) is that frame again: a shot's objects
#: come to rest within a second or two and then lie still, or creep by the solver's rounding (1e-8 m a frame,
#: 1e-5 px). It is that small because a lifted mesh's stretched side walls alias: on the 12 MP motorcycle at
#: 960 px, a motion of 5e-3 px changed 633 pixels by up to 183 levels. At 1920 px, over the frames where it
#: creeps (40–90), each given as the last drawn: at 1e-4 px 27 of 51 drawn and at most 1 pixel a frame more
#: than 2 levels off drawing it, at 3e-4 18 and 2, at 1e-3 8 and 6 (of 2.5 M; the worst 104 levels, against
#: 61 at 1e-4): a few pixels' aliasing for a third of the creeping frames' cost.
STILL_PX = 1e-3
#: A video frame larger than this (long side, pixels) casts its primary rays on a grid of every ``step``-th pixel,
#: ``step`` = round(long side / WORK_PX) made odd (down): 1 up to 1100 px (the bundled examples' 0.4 MP and less),
#: 3 above that (the default 1280 and full HD's 1920), 5 from 2420 px. Only the region that can differ from
#: the photo is drawn (what moved, where it stood, their shadows): a pixel between four samples that see one
#: surface, its texture mapped smoothly across them (:data:`SMOOTH_PX`), takes its texture coordinate by
#: interpolation and the texture's own full-size texel; every other pixel there (silhouettes, seams, cut-outs)
#: casts its own ray. The step is odd, so that each sample is the centre of its block. On the 12 MP motorcycle
#: at 1920 px (step 3) a moving frame casts 0.24 M rays where casting every covered pixel took 0.9–1.2 M (its
#: 741 px photo casts 0.14–0.18 M), its texels still the full-size texture's; what it loses is a feature thinner
#: than the step between two samples that both miss it, and it differs from casting every ray by a level or two
#: along seams. At 1280 px its 91 frames took 9.6 CPU seconds at step 3 against 23.9 casting every covered
#: pixel, every frame's PSNR against those at least 46.8 dB.
WORK_PX = 440
#: Largest departure (frame pixels) of four samples' texture coordinates from one affine map, and of three in a
#: row from a straight line, under which the pixels between them are interpolated rather than cast.
SMOOTH_PX = 0.5
#: Particles are drawn as spheres spread over this multiple of their projected radius (they overlap, so
#: that a set of them reads as one surface), shaded by a light travelling along PARTICLE_LIGHT (camera axes:
#: right, down, forward: from above the camera, to its left) with PARTICLE_AMBIENT of their colour in full shade.
PARTICLE_SPREAD = 1.6
#: Smoothing of the particles' surface (Gaussian sigma) in units of that spread radius: wide enough that
#: the lattice MPM seeds them on does not show as bumps in the shading.
PARTICLE_SMOOTH = 2.0
PARTICLE_LIGHT = (0.4, 0.7, 0.6)
PARTICLE_AMBIENT = 0.55
#: A turned surface is shaded by that light relative to how it faced it in the photo (``_turned_shading``), at
#: most this much brighter than the photo shows it (its texture already holds the photo's light).
TURN_BRIGHTEN = 1.2


@dataclass(frozen=True)
class FrameState:
    """What one frame was rendered from, returned beside its image by :meth:`ShotRenderer.render`: the control
    passes (:func:`~physomni_usd.rendering.passes.frame_passes`) are computed from it alone, so that a frame's
    passes can never be read off another frame's camera or hits. Its arrays are not changed by later frames
    (the rays are shared, read-only, by the frames of one camera)."""
    time: float  # time code
    camera: RenderCamera
    rays: np.ndarray  # (H, W, 3) float32 unit primary rays in world, one per pixel centre
    points: np.ndarray | None = None  # (N, 3) world points of every object mesh at ``time``; None without meshes
    mesh_face: np.ndarray | None = None  # (H, W) int32 first face on each ray whatever the texture's alpha, −1 none
    mesh_depth: np.ndarray | None = None  # (H, W) float32 metres along the ray to that face
    bary: np.ndarray | None = None  # (H, W, 2) float32 barycentric (u, v) on that face
    # (H, W) float32 0–1: how much of each pixel the particles drawn this frame cover (they are no faces, so
    # ``mesh_face`` does not see them); None for a stage without particles
    particle_alpha: np.ndarray | None = None
    # (H, W) int32 the face each pixel shows: the first on its ray whose texel is opaque (the image's), −1 where
    # the ray leaves through cut-outs only or meets nothing
    face: np.ndarray | None = None


class ShotRenderer:
    """Renders frames of one composed stage; build once, call :meth:`frame` (the image) or :meth:`render`
    (the image and its :class:`FrameState`) per time code."""

    def __init__(self, stage: Usd.Stage, settings: RenderSettings = RenderSettings()):
        self.stage = stage
        self.settings = settings
        #: Whether :meth:`render` may give the last frame drawn again for a frame where nothing moved by
        #: :data:`STILL_PX` (a video's frames, in order, of a stage nobody edits between them); off, every call
        #: draws: a preview that edits the stage between frames, and the control passes, read each frame's own.
        self.reuse_still = False
        self._last = None
        plate = read_plate(stage)
        h, w = plate.shape[:2]
        scale = min(1.0, settings.max_size / max(h, w))
        if scale < 1.0:
            size = (max(2, round(w * scale)), max(2, round(h * scale)))
            plate = cv2.resize(plate, size, interpolation=cv2.INTER_AREA)
        self.plate = plate.astype(np.float32)
        self.height, self.width = self.plate.shape[:2]
        # a slab is drawn as a pillow of its mask: no walls to stretch once it turns (physics keeps the slab)
        self.objects = with_pillows(read_objects(stage), stage, read_photo_camera(stage, w, h))
        self._read_photo(stage, (w, h))
        self.particles = read_particles(stage)
        self.device = pick_device(settings.device)
        self.size = float(np.median([o.height for o in self.objects])) if self.objects else 1.0
        self._rays_key = None
        self._build_atlas(scale)
        self.photo_camera = read_photo_camera(stage, self.width, self.height)
        self.environment = _environment(self)
        self._read_wide_plate(stage, scale, (w, h))
        self._world_key = None
        step = max(1, int(round(max(self.width, self.height) / WORK_PX)))
        self._step = step - 1 + step % 2  # odd: each sample is the centre of its step × step block
        self._region_cache = None

    def _read_wide_plate(self, stage: Usd.Stage, scale: float, size: tuple[int, int]) -> None:
        """The plate beyond the frame at the frame's scale, and where the plate sits in it (x, y); shots built
        without one extend the plate's border pixels outward. ``size``: the plate's own (w, h); a photo above
        0.4 MP (``texture.carry.FILL_PIXELS``) has its wide plate at the fill's reduced size (``build``), scaled
        here by its own ratio."""
        wide = read_wide_plate(stage)
        if wide is None:
            self.wide_plate, self.wide_offset = self.plate, (0.0, 0.0)
            return
        image, (top, bottom, left, right) = wide
        inner = (image.shape[1] - left - right, image.shape[0] - top - bottom)
        if inner != tuple(size) and min(inner) > 0:
            sx, sy = self.width / inner[0], self.height / inner[1]
            grown = (max(2, round(image.shape[1] * sx)), max(2, round(image.shape[0] * sy)))
            image = cv2.resize(image, grown, interpolation=cv2.INTER_AREA if sx < 1 else cv2.INTER_LINEAR)
            self.wide_plate = image.astype(np.float32)
            self.wide_offset = (left * sx, top * sy)
            return
        if scale < 1.0:
            size = (max(2, round(image.shape[1] * scale)), max(2, round(image.shape[0] * scale)))
            image = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
        self.wide_plate = image.astype(np.float32)
        self.wide_offset = (left * image.shape[1] / wide[0].shape[1], top * image.shape[0] / wide[0].shape[0])

    def _is_photo_camera(self, cam) -> bool:
        p = self.photo_camera
        return (np.allclose(cam.axes, p.axes, atol=1e-7) and np.allclose(cam.origin, p.origin, atol=1e-7)
                and abs(cam.fx - p.fx) < 1e-6 * p.fx and abs(cam.fy - p.fy) < 1e-6 * p.fy)

    def _world_background(self, cam) -> tuple[np.ndarray, np.ndarray | None, tuple | None]:
        """For a camera other than the photo's: per pixel, the environment (ground and backdrop) it sees,
        textured by projecting the wide plate from the photo's camera — (H, W, 3) plate colour, and the photo's
        colour and its owners (owner, sharer, share: :meth:`_read_photo`; −1 outside the photo) at the same
        place, so that the photo still shows wherever its object has not moved."""
        key = (tuple(np.round(cam.axes.ravel(), 9)), tuple(np.round(cam.origin, 9)), cam.fx, cam.fy)
        if key != self._world_key:
            t, _, _ = self.environment.intersect(cam.origin, self._rays)
            pts = cam.origin + self._rays.astype(np.float64) * t[..., None]
            uv, z = self.photo_camera.project(pts.reshape(-1, 3))
            uv[z <= 1e-6] = -1e4  # behind the photo's camera: the wide plate's border, never an empty pixel
            u = uv[:, 0].reshape(self.height, self.width).astype(np.float32)
            v = uv[:, 1].reshape(self.height, self.width).astype(np.float32)
            # the owners are read at the pixel a point falls in (nearest, from the floored map)
            self._world_map = (u, v, np.floor(u), np.floor(v))
            self._world_key = key
        u, v, fu, fv = self._world_map
        ox, oy = self.wide_offset
        plate = cv2.remap(self.wide_plate, u - 0.5 + ox, v - 0.5 + oy, cv2.INTER_LINEAR,
                          borderMode=cv2.BORDER_REPLICATE)
        if self.photo is None:
            return plate, None, None
        photo = cv2.remap(self.photo, u - 0.5, v - 0.5, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        owner = cv2.remap(self._owner_f, fu, fv, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT,
                          borderValue=-1).astype(np.int32)
        if self._sharer_f is None:
            return plate, photo, (owner, None, None)
        sharer = cv2.remap(self._sharer_f, fu, fv, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT,
                           borderValue=-1).astype(np.int32)
        share = cv2.remap(self.share, fu, fv, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT, borderValue=0.0)
        return plate, photo, (owner, sharer, share)

    def _owners(self) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """The owner, sharer and share of each photo pixel (:meth:`_read_photo`), for :func:`_revealed`; the
        last two None where no pixel is shared."""
        if self._sharer_f is None:
            return self.owner, None, None
        return self.owner, self.sharer, self.share

    def _read_photo(self, stage: Usd.Stage, size: tuple[int, int]) -> None:
        """The photo at the plate's size and, per pixel, the object whose part of the plate it is, and one that
        shares it (``texture.fill.hole_owners``: the object whose mask it lies in or nearest to, a contact
        shadow its caster's too, and how much; −1 where there is none): where that object (and, as far as it
        shares the pixel, the other) has not moved, the frame is the photo. Shots without the photo or the
        textures' places in it render as texture over plate throughout."""
        self.photo, self.owner, self.sharer, self.share = None, None, None, None
        # float32 copies for cv2.remap (:meth:`_world_background`); the sharer's None where nothing is shared
        self._owner_f, self._sharer_f = None, None
        photo = read_photo(stage)
        placed = [k for k, o in enumerate(self.objects) if o.origin is not None]
        if photo is None or photo.shape[1::-1] != size or not placed:
            return
        w, h = size
        # the owners are found at the frame's size, not the photo's: hole_owners seeks the shadows again as the
        # plate did, and its cost grows with the pixels (on the motorcycle 0.14 CPU s at 741 px wide, 0.7 at
        # 1920; a 12 MP photo's size would cost several times that)
        frame = (self.width, self.height)
        masks = [None] * len(self.objects)
        for k in placed:
            o = self.objects[k]
            x0, y0 = o.origin
            mask = np.zeros((h, w), np.uint8)
            # the photo crop: 255 where the photo shows the object; build paints what others hide at 254
            a = o.texture[:, : o.texture.shape[1] // 2 if o.two_sided else None, 3] == 255
            th, tw = min(a.shape[0], h - y0), min(a.shape[1], w - x0)
            if th <= 0 or tw <= 0:
                continue
            mask[y0:y0 + th, x0:x0 + tw] = a[:th, :tw]
            if frame != size:  # a frame pixel any part of which shows the object is the object's
                mask = cv2.resize(mask, frame, interpolation=cv2.INTER_AREA)
            masks[k] = mask > 0
        if frame != size:
            photo = cv2.resize(photo, frame, interpolation=cv2.INTER_AREA)
        # the shot does not record the dilation its plate was built with: the default's is the build's unless
        # the build was given another, and then the shadows found here may differ from the plate's a little
        owner, sharer, share = hole_owners(photo, masks, BuildSettings().plate_dilation)
        self.photo, self.owner, self.sharer, self.share = photo.astype(np.float32), owner, sharer, share
        self._owner_f = owner.astype(np.float32)
        self._sharer_f = sharer.astype(np.float32) if (sharer >= 0).any() else None
        self.to_frame = (self.width / w, self.height / h)  # photo pixels → frame pixels

    def _build_atlas(self, scale: float = 1.0) -> None:
        """Stack every texture in one RGBA atlas and map each triangle corner to atlas pixels. ``scale``: the
        frame's size over the photo's; textures are stacked at it (a 12 MP photo's own textures make a 29 MP
        atlas, which the frame samples at under half its resolution), so the atlas costs what the frame does."""
        textures = [_at_scale(o.texture, o.two_sided, scale) for o in self.objects]
        widths = [t.shape[1] for t in textures] or [1]
        atlas_w = max(widths)
        offsets, y = [], 0
        for t in textures:
            offsets.append(y)
            y += t.shape[0]
        atlas = np.zeros((max(y, 1), atlas_w, 4), np.uint8)
        faces, corners, base = [], [], 0
        #: per object, atlas pixels over its texture's own pixels (x, y): the rounding of each texture's size
        self.atlas_scale = np.array([(t.shape[1] / o.texture.shape[1], t.shape[0] / o.texture.shape[0])
                                     for o, t in zip(self.objects, textures)] + [(1.0, 1.0)], np.float32)
        # atlas pixel → photo pixel, per object: (atlas pixel + (x0, y0) · its scale − its row in the atlas)
        # / its scale
        self.atlas_to_photo = np.array([(o.origin[0] * sc[0], o.origin[1] * sc[1] - y0) if o.origin is not None
                                        else (0, 0) for o, y0, sc in zip(self.objects, offsets, self.atlas_scale)]
                                       + [(0, 0)], np.float32)
        self.face_object = np.concatenate([np.full(len(o.faces), k, np.int32) for k, o in enumerate(self.objects)]
                                          + [np.zeros(0, np.int32)])
        for o, t, y0 in zip(self.objects, textures, offsets):
            th, tw = t.shape[:2]
            atlas[y0:y0 + th, :tw] = t
            cs = o.corner_st.reshape(-1, 2)
            corners.append(np.stack([cs[:, 0] * tw, (1.0 - cs[:, 1]) * th + y0], 1))
            faces.append(o.faces + base)
            base += len(o.st)
        # textures holding [photo crop | unseen sides] are twice the crop's width: the crop's own width
        self.photo_width = np.array([t.shape[1] // 2 if o.two_sided else t.shape[1]
                                     for o, t in zip(self.objects, textures)] + [0], np.float32)
        self.atlas_rgb = np.ascontiguousarray(atlas[..., :3])
        self.atlas_alpha = atlas[..., 3].astype(np.float32) / 255.0
        self.faces = np.concatenate(faces) if faces else np.zeros((0, 3), np.int64)
        self.corner_px = np.concatenate(corners) if corners else np.zeros((0, 2))  # (F·3, 2) atlas pixels
        self.caster = self.contact = None
        if len(self.faces):
            pts = self.points_at(Usd.TimeCode(0))
            self.caster = RayCaster(pts, self.faces, self.corner_px, self.atlas_alpha, self.device)
            self.contact = ContactCaster(pts, self.faces, self.face_object, self.device)
            self._start_points = self._photo_points()
            self._start_hidden = list(self._hidden)
        start = Usd.TimeCode(self.stage.GetStartTimeCode())
        self._start_particles = {str(p.prim.GetPath()): np.asarray(UsdGeom.Points(p.prim).GetPointsAttr().Get(start)
                                                                   or [], np.float64) for p in self.particles}

    def _photo_points(self) -> np.ndarray:
        """(N, 3) every object's points where the photo shows it, in :meth:`points_at`'s order: as ``build``
        placed them in ``scene.usda``, not as the first frame composes them. Motion is measured from these, so an
        object that an edit or a session layer moved at the first frame itself has left where the photo shows it
        (the saucer shows where the cup stood, the cup shows where it now is), while the first frame simulate
        writes, where build put everything, is still the photo. Stages without a scene layer measure from their
        first frame."""
        points = self.points_at(Usd.TimeCode(self.stage.GetStartTimeCode()))
        placed = read_photo_points(self.stage, self.objects)
        if placed is None:
            return points
        points = points.copy()
        for k, pts in enumerate(placed):
            lo, hi = self._point_range[k]
            if pts is not None and len(pts) == hi - lo and not self._hidden[k]:
                points[lo:hi] = pts
            elif not self._hidden[k]:
                # an object the scene layer lacks (added by an edit) or holds with other points is not one the
                # photo shows: no place to be still at (NaN counts as moved in _pixel_motion)
                points[lo:hi] = np.nan
        return points

    def points_at(self, time: Usd.TimeCode) -> np.ndarray:
        """(N, 3) world points of every object mesh at ``time``, in the ray caster's order (a hidden object's
        collapsed onto one point, so that nothing hits it)."""
        cache = UsdGeom.XformCache(time)
        out = []
        self._hidden = []
        for o in self.objects:
            pts = world_points(o, cache, self.stage, time)
            hidden = o.prim is not None and not visible(o.prim, time)
            if hidden:
                pts = np.broadcast_to(pts[:1], pts.shape)  # every triangle degenerate: nothing to hit
            out.append(pts)
            self._hidden.append(hidden)
        ends = np.cumsum([len(p) for p in out])
        self._point_range = list(zip(ends - np.array([len(p) for p in out]), ends))
        return np.concatenate(out)

    def _visible_particles(self, time: Usd.TimeCode) -> list:
        """(particle set, world points (N, 3)) for each set visible and non-empty at ``time``."""
        out = []
        for part in self.particles:
            if visible(part.prim, time):
                pts = UsdGeom.Points(part.prim).GetPointsAttr().Get(time)
                if pts:
                    out.append((part, np.asarray(pts, np.float64)))
        return out

    def _shadow_strength(self, height: np.ndarray) -> np.ndarray:
        """Darkening of the ground under a particle ``height`` metres above it: the objects' contact shadow
        (:func:`contact_falloff`) with the median object's size."""
        s = self.settings
        return s.shadow_strength * contact_falloff(np.maximum(height, 0.0) / (s.shadow_falloff * self.size))

    def _on_screen(self, uv: np.ndarray, z: np.ndarray) -> np.ndarray:
        """Which projected points (uv (N, 2) pixels, z (N,) depth) land in front of the camera and in the frame."""
        return (z > 1e-3) & (uv[:, 0] >= 0) & (uv[:, 1] >= 0) & (uv[:, 0] < self.width) & (uv[:, 1] < self.height)

    def _particle_shadow(self, cam, particles: list) -> np.ndarray:
        """(H, W) darkening of the ground under ``particles`` (from :meth:`_visible_particles`): each
        particle's footprint at z = 0, fading with its height as the objects' shadows do, then blurred like them."""
        s = self.settings
        shadow = np.zeros((self.height, self.width), np.float32)
        for part, pts in particles:
            strength = self._shadow_strength(pts[:, 2])
            uv, z = cam.project(pts * [1.0, 1.0, 0.0])
            ok = self._on_screen(uv, z)
            order = np.argsort(strength[ok])  # the strongest last, so it wins where footprints overlap
            radius = np.maximum(part.width * cam.fx / z[ok][order], 1.0)
            for (u, v), r, k in zip(uv[ok][order], radius, strength[ok][order]):
                cv2.circle(shadow, (int(round(u)), int(round(v))), int(round(r)), float(k), -1)
        blur = s.shadow_blur * float(np.hypot(self.width, self.height))
        if blur > 0.5 and shadow.any():
            shadow = cv2.GaussianBlur(shadow, (0, 0), blur)
        return shadow

    def _splat(self, out: np.ndarray, cam, particles: list, depth: np.ndarray | None,
               drawn: np.ndarray | None = None) -> np.ndarray:
        """Draw ``particles`` (from :meth:`_visible_particles`) as one shaded surface per set, hidden where a
        mesh is nearer (``depth``: distance along each pixel's ray, or None); ``drawn`` (H, W) float32, where
        given, takes in each pixel's largest coverage by any set (0–1).

        Each particle is a sphere of its prim's width seen through the pixel of its centre; the nearest
        sphere's front per pixel, spread over the spheres' projected radius (a min filter), is smoothed
        into a surface whose screen-space normals shade the set's colour from a light above and in front.
        Nothing of the particles' lattice shows: no disc outlines, no highlight per particle."""
        for part, pts in particles:
            uv, z = cam.project(pts)
            ok = self._on_screen(uv, z)
            if not ok.any():
                continue
            uv, z, pts = uv[ok], z[ok], pts[ok]
            r_px = 0.5 * part.width * cam.fx / z  # each sphere's radius on screen
            radius = max(1, int(round(float(np.median(r_px)) * PARTICLE_SPREAD)))
            iu = np.clip(uv[:, 0].astype(np.int64), 0, self.width - 1)
            iv = np.clip(uv[:, 1].astype(np.int64), 0, self.height - 1)
            front = np.full(self.height * self.width, np.inf, np.float32)
            np.minimum.at(front, iv * self.width + iu, (np.linalg.norm(pts - cam.origin, axis=1)
                                                       - 0.5 * part.width).astype(np.float32))
            front = front.reshape(self.height, self.width)
            big = np.float32(1e30)
            kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * radius + 1, 2 * radius + 1))
            spread = cv2.erode(np.where(np.isfinite(front), front, big), kernel)
            cover = (spread < big).astype(np.uint8)
            # gaps between the spheres are the lattice showing through, not the pile's shape
            cover = cv2.morphologyEx(cover, cv2.MORPH_CLOSE, kernel).astype(np.float32)
            spread = np.where(cover > 0, np.minimum(spread, cv2.dilate(np.where(spread < big, spread, 0), kernel)),
                              big)
            if depth is not None:
                cover *= (spread < depth + 0.5 * part.width).astype(np.float32)
            if not cover.any():
                continue
            # a smooth surface through the fronts, normalised by coverage so that its rim does not sink
            sigma = max(1.0, PARTICLE_SMOOTH * radius)
            filled = np.where(cover > 0, spread, 0.0).astype(np.float32)
            smooth = cv2.GaussianBlur(filled, (0, 0), sigma) / np.maximum(cv2.GaussianBlur(cover, (0, 0), sigma),
                                                                          1e-6)
            # screen-space normal: metres of depth per metre across (a pixel spans distance / fx metres)
            per_px = np.maximum(smooth, 1e-6) / cam.fx
            gx = cv2.Sobel(smooth, cv2.CV_32F, 1, 0, ksize=3) / (8.0 * per_px)
            gy = cv2.Sobel(smooth, cv2.CV_32F, 0, 1, ksize=3) / (8.0 * per_px)
            # the rim, where the surface turns away, leans outward by the coverage's own gradient
            soft = cv2.GaussianBlur(cover, (0, 0), sigma)
            gx -= 2.0 * cv2.Sobel(soft, cv2.CV_32F, 1, 0, ksize=3) / 8.0 * radius
            gy -= 2.0 * cv2.Sobel(soft, cv2.CV_32F, 0, 1, ksize=3) / 8.0 * radius
            n = np.stack([gx, gy, -np.ones_like(gx)], -1)  # toward the camera; axes: right, down, forward
            n /= np.linalg.norm(n, axis=-1, keepdims=True)
            light = np.array(PARTICLE_LIGHT, np.float32)
            lambert = np.clip(-(n @ (light / np.linalg.norm(light))), 0.0, 1.0)
            shade = PARTICLE_AMBIENT + (1.0 - PARTICLE_AMBIENT) * lambert
            colour = part.colour.astype(np.float32)[None, None, :] * shade[..., None] * 1.15
            alpha = cv2.GaussianBlur(cover, (0, 0), 0.6)[..., None] * cover[..., None]
            out = out * (1.0 - alpha) + np.clip(colour, 0, 255) * alpha
            if drawn is not None:
                np.maximum(drawn, alpha[..., 0], out=drawn)
        return out

    def _turned_shading(self, face: np.ndarray, state: FrameState) -> np.ndarray:
        """(H, W) factor on the texture's colour of each surface seen: the photo's shading stays with the light,
        not with a surface that has turned (a rolled ball's lit side does not roll with it). Lambert under the
        particles' light (fixed to the photo's camera) with the normal now, over the same with the normal in the
        first frame (smooth across each mesh); 1 where nothing has turned or bent."""
        out = np.ones(face.shape, np.float32)
        if state.points is None or state.bary is None or not len(self.faces):
            return out
        if getattr(self, "_rest_normals", None) is None:
            self._rest_normals = _vertex_normals(self.points_at(Usd.TimeCode(self.stage.GetStartTimeCode())),
                                                 self.faces)
        normals = _vertex_normals(state.points, self.faces)
        # only the faces that turned or bent (a shot's objects mostly stand or slide): the rest stay 1, cheaply
        cos = np.einsum("ij,ij->i", normals, self._rest_normals) / np.maximum(
            np.linalg.norm(normals, axis=1) * np.linalg.norm(self._rest_normals, axis=1), 1e-12)
        turned = (cos < 1.0 - 1e-6)[self.faces].any(axis=1)
        hit = (face >= 0) & turned[np.maximum(face, 0)]
        if not hit.any():
            return out
        f = face[hit]
        # the barycentrics are those of the first face on the ray; behind a cut-out pixel take the face's middle
        same = state.mesh_face[hit] == f
        u = np.where(same, state.bary[hit][:, 0], 1.0 / 3.0)
        v = np.where(same, state.bary[hit][:, 1], 1.0 / 3.0)
        w = np.stack([u, v, 1.0 - u - v], -1)[..., None]
        tri = self.faces[f]
        now = (normals[tri] * w).sum(1)
        rest = (self._rest_normals[tri] * w).sum(1)
        cam = self.photo_camera if self.photo_camera is not None else state.camera
        to_light = -(np.array(PARTICLE_LIGHT, np.float64) @ cam.axes)
        to_light /= np.linalg.norm(to_light)

        def lambert(n):
            n = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-9)
            return PARTICLE_AMBIENT + (1.0 - PARTICLE_AMBIENT) * np.clip(n @ to_light, 0.0, 1.0)

        # a side the photo saw in shade is lit less than the photo would show it, and a copy of the seen side
        # that now faces the light is brightened a little only: it already carries the photo's light
        out[hit] = np.clip(lambert(now) / lambert(rest), PARTICLE_AMBIENT, TURN_BRIGHTEN)
        return out

    def _contact_shadow(self, cam, time: Usd.TimeCode, points: np.ndarray, moved: np.ndarray) -> np.ndarray:
        """(h, w) darkening of the ground on the shadow grid: each object's contact shadow, weighted by how far
        it has left the photo (``moved`` (K + 1,) from :meth:`_moved`; an object in place keeps the photo's own
        shadow). Under the photo's camera an object still where build placed it casts none, even where the
        photo does not show it, so that frame 0 is the photo; a hidden object casts none."""
        k_all = len(self.objects)
        weight = self.settings.shadow_strength * moved[:k_all].astype(np.float64)
        photo_view = self._is_photo_camera(cam)
        for k, o in enumerate(self.objects):
            lo, hi = self._point_range[k]
            hidden = o.prim is not None and not visible(o.prim, time)
            still = photo_view and np.array_equal(points[lo:hi], self._start_points[lo:hi])
            if hidden or still:
                weight[k] = 0.0
        reach = self.settings.shadow_falloff * np.array([max(o.height, 1e-3) for o in self.objects])
        self.contact.update(points, weight)
        env = self.environment
        return self.contact.darkening(cam.origin, self._shadow_rays, weight, reach,
                                      (env.backdrop_normal, env.backdrop_offset))

    def _texel_offset(self, obj: np.ndarray, px: np.ndarray, at=(0, 0)) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For each pixel that sees the photo crop of an object's texture: how far (frame pixels) the texel it
        sees lies from that pixel in the photo, as (H, W) bool which pixels those are, their objects and their
        distances (in the order of ``np.nonzero``); 0 where the surface shows the photo's own pixel.

        ``obj`` (H, W) is the object seen through each pixel (−1 for none), ``px`` its atlas coordinates; ``at``
        the frame pixel (x, y) of their top-left corner (a region of the frame)."""
        # only the photo crop of each texture says where the photo shows the object; its unseen sides'
        # opaque copy (texture/sides.py) lies to the right of it and says nothing
        hit = (obj >= 0) & (px[..., 0] < self.photo_width[np.maximum(obj, 0)])
        ys, xs = np.nonzero(hit)
        k = obj[hit]
        shift, per = self.atlas_to_photo[k], self.atlas_scale[k]
        sx = (px[hit][:, 0] + shift[:, 0]) / per[:, 0] * self.to_frame[0]
        sy = (px[hit][:, 1] + shift[:, 1]) / per[:, 1] * self.to_frame[1]
        return hit, k, np.hypot(sx - (xs + at[0] + 0.5), sy - (ys + at[1] + 0.5))

    def _moved(self, obj: np.ndarray, px: np.ndarray) -> np.ndarray:
        """(K,) per object, 0 where it is seen where the photo shows it, rising to 1 once it has moved
        :data:`IN_PLACE_PX` + :data:`REVEAL_PX` pixels (1 for objects not seen, or not placed in the photo).

        ``obj`` (H, W) is the object seen through each pixel (−1 for none), ``px`` its atlas coordinates."""
        k_all = len(self.objects)
        moved = np.ones(k_all + 1, np.float32)  # the last entry stands for "no object"
        if self.photo is None:
            return moved
        _, k, d = self._texel_offset(obj, px)
        order = np.argsort(k, kind="stable")
        k, d = k[order], d[order]
        bounds = np.searchsorted(k, np.arange(k_all + 1))
        for i, o in enumerate(self.objects):
            di = d[bounds[i]:bounds[i + 1]]
            if o.origin is not None and di.size:
                m = float(np.percentile(di, 90))
                moved[i] = np.clip((m - IN_PLACE_PX) / REVEAL_PX, 0.0, 1.0)
        return moved

    def _shows_photo(self, obj: np.ndarray, px: np.ndarray, at=(0, 0)) -> np.ndarray:
        """(H, W) float32, 1 where the surface seen shows the photo's own pixel there (to within :data:`IN_PLACE_PX`
        + :data:`REVEAL_PX`), 0 elsewhere: a side wall stretched from the outline, an unseen side, no surface."""
        hit, _, d = self._texel_offset(obj, px, at)
        out = np.zeros(obj.shape, np.float32)
        out[hit] = d <= IN_PLACE_PX + REVEAL_PX
        return out

    def _pixel_motion(self, cam, now: np.ndarray, start: np.ndarray) -> float:
        """The farthest any of the points ``now`` (N, 3) has moved on the screen of ``cam`` (pixels) from where it
        was in the photo (``start``, the same points); 0 for points that have not moved at all."""
        if now.shape != start.shape:
            return np.inf
        if np.array_equal(now, start):
            return 0.0
        uv0, z0 = cam.project(start)
        uv1, z1 = cam.project(now)
        front = (z0 > 1e-6) & (z1 > 1e-6)
        if not front.all():  # a point crossed behind the camera: it has moved, however far that shows
            return np.inf
        return float(np.max(np.hypot(*(uv1 - uv0).T))) if len(now) else 0.0

    def _moved_since_start(self, cam, points: np.ndarray, particles: list) -> tuple[np.ndarray, list]:
        """Through the photo's camera: (K + 1,) per object, 0 where it has not moved from where the photo shows it,
        rising to 1 once a point of it has moved :data:`IN_PLACE_PX` + :data:`REVEAL_PX` pixels (as :meth:`_moved`);
        and the particle sets (of ``particles``) that have moved at all, the only ones drawn.

        Motion, not how well the lifted mesh reproduces the photo, decides: an object in place is the photo,
        whatever its mesh, texture or stretched side walls would show. An object hidden now that was seen at
        the first frame has moved (it left), unless its particles, which stand in for it, have not."""
        k_all = len(self.objects)
        moved = np.ones(k_all + 1, np.float32)
        index = {o.path: k for k, o in enumerate(self.objects)}
        drawn, by_object = [], {}
        for part, pts in particles:
            d = self._pixel_motion(cam, pts, self._start_particles.get(str(part.prim.GetPath()), np.zeros((0, 3))))
            m = float(np.clip((d - IN_PLACE_PX) / REVEAL_PX, 0.0, 1.0))
            if m > 0.0:
                drawn.append((part, pts))
            owner = index.get(part.prim.GetCustomDataByKey("physomni:object"))
            if owner is not None:
                by_object[owner] = max(by_object.get(owner, 0.0), m)
        for k in range(k_all):
            lo, hi = self._point_range[k]
            if self._hidden[k]:
                d = np.inf
                if k in by_object:
                    moved[k] = by_object[k]
                    continue
            elif self._start_hidden[k]:
                d = np.inf  # it appeared
            else:
                d = self._pixel_motion(cam, points[lo:hi], self._start_points[lo:hi])
            moved[k] = np.clip((d - IN_PLACE_PX) / REVEAL_PX, 0.0, 1.0)
        return moved, drawn

    def frame(self, t: float) -> np.ndarray:
        """The composited frame at time code ``t``, (H, W, 3) uint8."""
        return self.render(t)[0]

    def render(self, t: float) -> tuple[np.ndarray, FrameState]:
        """The composited frame at time code ``t``, (H, W, 3) uint8, and what it was rendered from."""
        time_code = Usd.TimeCode(t)
        cam = read_camera(self.stage, time_code, self.width, self.height)
        key = (tuple(np.round(cam.axes.ravel(), 9)), cam.fx, cam.fy)
        if key != self._rays_key:
            self._rays = cam.rays()
            self._rays.flags.writeable = False  # shared by every FrameState of this camera
            self._shadow_rays = np.ascontiguousarray(cam.rays(SHADOW_STEP), np.float32)
            self._rays_key = key
        # read once a frame: both the particles' shadows and their splats need them
        particles = self._visible_particles(time_code)
        drawn = np.zeros((self.height, self.width), np.float32) if self.particles else None
        if self._is_photo_camera(cam):
            plate, photo, owners = self.plate, self.photo, self._owners()
        else:
            plate, photo, owners = self._world_background(cam)
        if self.caster is None:
            out = plate * (1.0 - self._particle_shadow(cam, particles)[..., None])
            image = np.clip(self._splat(out, cam, particles, None, drawn) + 0.5, 0, 255).astype(np.uint8)
            return image, FrameState(float(t), cam, self._rays, particle_alpha=drawn)
        points = self.points_at(time_code)
        still = self._still(cam, points, particles)
        if still is not None:
            return still[0].copy(), dataclasses.replace(still[1], time=float(t))
        self.caster.update(points)
        if (self._step > 1 and self.reuse_still and not self.particles and self.photo is not None
                and self._is_photo_camera(cam)):
            image = self._render_region(cam, time_code, points)
            if image is not None:
                # a video's frame: what its passes would need of it (the per-pixel hits) is not kept
                state = FrameState(float(t), cam, self._rays, points)
                self._last = (cam, tuple(self._hidden), points.copy(), image.copy(), state)
                return image, state
        face, px = self.caster.cast(cam.origin, self._rays, 1e6, pixels=covered_pixels(cam, points, self.faces))
        # the caster's buffers are overwritten by the next cast: the state keeps its own
        state = FrameState(float(t), cam, self._rays, points, self.caster.mesh_face.copy(),
                           self.caster.mesh_depth.copy(), self.caster.bary.copy(), drawn, face.copy())
        hit = face >= 0
        obj = np.where(hit, self.face_object[np.maximum(face, 0)], -1)
        faithful = None
        if self._is_photo_camera(cam) and self.photo is not None:
            moved, particles = self._moved_since_start(cam, points, particles)
            faithful = self._shows_photo(obj, px)
        else:
            moved = self._moved(obj, px)
        s = self.settings
        shadow = self._contact_shadow(cam, time_code, points, moved)
        blur = s.shadow_blur * float(np.hypot(self.width, self.height)) / SHADOW_STEP
        if blur > 0.5 and shadow.any():
            shadow = cv2.GaussianBlur(shadow, (0, 0), blur)
        shadow = cv2.resize(shadow, (self.width, self.height), interpolation=cv2.INTER_LINEAR)
        if self.particles:
            shadow = 1.0 - (1.0 - shadow) * (1.0 - self._particle_shadow(cam, particles))
        if photo is None:
            back = plate
        else:  # the photo, except where the object it shows there has moved: the plate
            revealed = _revealed(moved, *owners)
            back = photo + revealed[..., None] * (plate - photo)
        out = back * (1.0 - shadow[..., None])
        mx = np.where(hit, px[..., 0] - 0.5, -10).astype(np.float32)
        my = np.where(hit, px[..., 1] - 0.5, -10).astype(np.float32)
        colour = cv2.remap(self.atlas_rgb, mx, my, cv2.INTER_LINEAR,
                           borderMode=cv2.BORDER_REPLICATE).astype(np.float32)
        colour *= self._turned_shading(face, state)[..., None]
        alpha = cv2.remap(self.atlas_alpha, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        if self.photo is not None:  # an object in place is the photo itself, without resampling, unless the
            # object the photo shows there has left (the saucer where the cup stood shows its texture)
            colour = self.photo + np.maximum(moved[obj], revealed)[..., None] * (colour - self.photo)
        a = np.where(hit, np.clip(alpha, 0.0, 1.0), 0.0)
        if faithful is not None:
            # an object in place is seen only where its surface shows the photo's own pixel: where another
            # object has left, the lift's stretched walls and unseen sides of what stayed are not drawn over
            # the plate, while what stayed and was hidden (the saucer under the cup) is
            a *= np.maximum(moved[obj], faithful)
        a = a[..., None]
        out = out * (1.0 - a) + colour * a
        if self.particles:
            out = self._splat(np.ascontiguousarray(out, np.float32), cam, particles, self.caster.depth, drawn)
        image = np.clip(out + 0.5, 0, 255).astype(np.uint8)
        if self.reuse_still and not self.particles:
            self._last = (cam, tuple(self._hidden), points.copy(), image.copy(), state)
        return image, state

    def _region_setup(self):
        """What :meth:`_render_region` keeps from frame to frame: the photo and the plate as bytes (the frame
        wherever nothing changed, and where an object left), the sample grid's rows and columns (frame pixels), and
        per object (and K for no object) the box
        (x0, y0, x1, y1) of the pixels it owns where the plate differs from the photo, None where there are none."""
        if self._region_cache is None:
            s = self._step
            photo_u8 = np.clip(self.photo + 0.5, 0, 255).astype(np.uint8)
            differs = np.any(np.abs(self.plate - self.photo) > 0.5, axis=2)
            boxes = []
            for k in list(range(len(self.objects))) + [-1]:
                yy, xx = np.nonzero(differs & (self.owner == k))
                boxes.append((int(xx.min()), int(yy.min()), int(xx.max()) + 1, int(yy.max()) + 1) if len(yy)
                             else None)
            plate_u8 = np.clip(self.plate + 0.5, 0, 255).astype(np.uint8)
            self._region_cache = (photo_u8, plate_u8, np.arange(s // 2, self.height, s),
                                  np.arange(s // 2, self.width, s), boxes)
        return self._region_cache

    def _render_region(self, cam, time_code: Usd.TimeCode, points: np.ndarray) -> np.ndarray | None:
        """The frame through the photo's camera (no particles) for a frame larger than :data:`WORK_PX`, as
        :meth:`render` composes it, but only over the box that can differ from the photo: the objects that moved
        (where they are), what they owned in the photo where the plate differs from it (where they were), their
        shadows, and the objects in place that the pixels of a moved object's photo now show in their texture.
        Primary rays are cast on the sample grid of every ``step``-th pixel and, between samples, only where the
        samples do not see one smoothly mapped surface (:data:`WORK_PX`, :data:`SMOOTH_PX`). None where a
        point is behind the camera (the caller casts every ray)."""
        photo_u8, plate_u8, gy, gx, boxes = self._region_setup()
        s, c = self._step, self._step // 2
        H, W = self.height, self.width
        k_all = len(self.objects)
        moved, _ = self._moved_since_start(cam, points, [])
        uv, z = cam.project(points)
        if not len(points) or np.min(z) <= 1e-6 or np.abs(uv).max() > 8.0 * max(W, H):
            return None
        # each object's triangles on the sample grid (sample (i, j) at grid coordinates (j, i))
        gh, gw = len(gy), len(gx)
        tri = np.round(((uv - 0.5 - c) / s) * 16).astype(np.int32)[self.faces]
        cov_moved = np.zeros((gh, gw), np.uint8)
        cov_still = np.zeros((gh, gw), np.uint8)
        shows_moved = moved[self.face_object] > 0
        for t, m in zip(tri, shows_moved):
            cv2.fillConvexPoly(cov_moved if m else cov_still, t, 1, lineType=cv2.LINE_8, shift=4)
        kernel = np.ones((3, 3), np.uint8)
        cov_any = cv2.dilate(cov_moved | cov_still, kernel).astype(bool)
        shadow = self._contact_shadow(cam, time_code, points, moved)
        blur = self.settings.shadow_blur * float(np.hypot(W, H)) / SHADOW_STEP
        if blur > 0.5 and shadow.any():
            shadow = cv2.GaussianBlur(shadow, (0, 0), blur)
        # the box, in frame pixels
        box = []

        def grid_box(mask):
            yy, xx = np.nonzero(mask)
            if len(yy):
                box.append((gx[xx.min()] - s, gy[yy.min()] - s, gx[xx.max()] + s + 1, gy[yy.max()] + s + 1))

        grid_box(cov_moved)
        grid_box(cov_still & (moved[self._region_owner(gy, gx)] > 0))
        for k, b in enumerate(boxes):
            if b is not None and moved[k if k < k_all else -1] > 0:
                box.append(b)
        yy, xx = np.nonzero(shadow > 1e-3)
        if len(yy):
            box.append(((xx.min() - 1) * SHADOW_STEP, (yy.min() - 1) * SHADOW_STEP, (xx.max() + 2) * SHADOW_STEP,
                        (yy.max() + 2) * SHADOW_STEP))
        if not box:
            return photo_u8.copy()
        b = np.array(box)
        # on whole blocks of the grid, so that its samples are the centres of the box's blocks
        x0, y0 = max(0, int(b[:, 0].min())) // s * s, max(0, int(b[:, 1].min())) // s * s
        x1, y1 = min(W, int(b[:, 2].max())), min(H, int(b[:, 3].max()))
        if x1 <= x0 or y1 <= y0:
            return photo_u8.copy()
        # the samples around the box, cast where any triangle may cover them
        i_lo, i_hi = y0 // s, min(gh - 1, (y1 - 1) // s)
        j_lo, j_hi = x0 // s, min(gw - 1, (x1 - 1) // s)
        sy, sx = gy[i_lo:i_hi + 1], gx[j_lo:j_hi + 1]
        cov = cov_any[i_lo:i_hi + 1, j_lo:j_hi + 1]
        flat = (sy[:, None] * W + sx[None, :])[cov].astype(np.int32)
        face, px = self.caster.cast(cam.origin, self._rays, 1e6, pixels=flat)
        g_face = face[np.ix_(sy, sx)]
        g_px = px[np.ix_(sy, sx)].astype(np.float32)
        g_mesh_face = self.caster.mesh_face[np.ix_(sy, sx)]
        g_bary = self.caster.bary[np.ix_(sy, sx)]
        g_hit = g_face >= 0
        g_obj = np.where(g_hit, self.face_object[np.maximum(g_face, 0)], -1)
        # cells whose four samples see one surface mapped smoothly: interpolated, not cast
        tol = SMOOTH_PX * float(self.atlas_scale.max()) / min(self.to_frame)  # frame pixels → atlas pixels
        # per texture axis (planes, not a last axis of two: numpy reduces short last axes slowly)
        planes = [np.where(g_hit, g_px[..., k], np.float32(np.nan)) for k in (0, 1)]
        bend = np.full(g_hit.shape, np.inf, np.float32)
        twist = np.ones((max(g_hit.shape[0] - 1, 0), max(g_hit.shape[1] - 1, 0)), bool)
        with np.errstate(invalid="ignore"):
            across = np.zeros(g_hit.shape, np.float32)
            down = np.zeros(g_hit.shape, np.float32)
            for q in planes:
                if q.shape[1] > 2:
                    np.maximum(across[:, 1:-1], np.abs(q[:, :-2] - 2 * q[:, 1:-1] + q[:, 2:]), out=across[:, 1:-1])
                if q.shape[0] > 2:
                    np.maximum(down[1:-1], np.abs(q[:-2] - 2 * q[1:-1] + q[2:]), out=down[1:-1])
                twist &= np.abs(q[:-1, :-1] + q[1:, 1:] - q[1:, :-1] - q[:-1, 1:]) <= tol
            bend[1:-1, 1:-1] = np.maximum(across, down)[1:-1, 1:-1]
            bend[~g_hit] = np.inf
            flat_pt = bend <= tol
        o = g_obj
        cell = (flat_pt[:-1, :-1] & flat_pt[1:, :-1] & flat_pt[:-1, 1:] & flat_pt[1:, 1:] & twist
                & (o[:-1, :-1] == o[1:, :-1]) & (o[:-1, :-1] == o[:-1, 1:]) & (o[:-1, :-1] == o[1:, 1:])
                & (o[:-1, :-1] >= 0))
        fy = (np.arange(y0, y1) - c) / s - i_lo
        fx = (np.arange(x0, x1) - c) / s - j_lo
        a, bb = np.floor(fy).astype(np.int64), np.floor(fx).astype(np.int64)
        ok_y, ok_x = (a >= 0) & (a < cell.shape[0]), (bb >= 0) & (bb < cell.shape[1])
        smooth = cell[np.clip(a, 0, max(cell.shape[0] - 1, 0))][:, np.clip(bb, 0, max(cell.shape[1] - 1, 0))] \
            if cell.size else np.zeros((y1 - y0, x1 - x0), bool)
        smooth &= ok_y[:, None] & ok_x[None, :]
        # cells whose four samples see nothing: nothing drawn between them (a feature thinner than the step may
        # fall between samples and go undrawn; WORK_PX)
        empty = (o[:-1, :-1] < 0) & (o[1:, :-1] < 0) & (o[:-1, 1:] < 0) & (o[1:, 1:] < 0)
        empty = empty[np.clip(a, 0, max(cell.shape[0] - 1, 0))][:, np.clip(bb, 0, max(cell.shape[1] - 1, 0))] \
            if cell.size else np.zeros((y1 - y0, x1 - x0), bool)
        empty &= ok_y[:, None] & ok_x[None, :]
        near_y = np.clip(np.round(fy).astype(np.int64), 0, len(sy) - 1)
        near_x = np.clip(np.round(fx).astype(np.int64), 0, len(sx) - 1)
        exact = ~smooth & ~empty & cov[near_y][:, near_x]
        pxr = self._upsample(np.where(g_hit[..., None], g_px, 0.0).astype(np.float32), y0, x0, y1, x1, i_lo, j_lo)
        obj = np.where(smooth, o[near_y][:, near_x], -1)
        sy_, sx_ = np.nonzero(smooth)
        tx = np.clip(pxr[sy_, sx_, 0].astype(np.int64), 0, self.atlas_alpha.shape[1] - 1)
        ty = np.clip(pxr[sy_, sx_, 1].astype(np.int64), 0, self.atlas_alpha.shape[0] - 1)
        cut = self.atlas_alpha[ty, tx] < 0.5
        exact[sy_[cut], sx_[cut]] = True
        obj[sy_[cut], sx_[cut]] = -1
        shade = self._upsample(self._turned_shading(g_face, FrameState(0.0, cam, self._rays, points, g_mesh_face,
                                                                       None, g_bary)), y0, x0, y1, x1, i_lo, j_lo)
        ey, ex = np.nonzero(exact)
        if len(ey):
            flat = ((ey + y0) * W + ex + x0).astype(np.int32)
            face, px = self.caster.cast(cam.origin, self._rays, 1e6, pixels=flat)
            f = face.reshape(-1)[flat]
            obj[ey, ex] = np.where(f >= 0, self.face_object[np.maximum(f, 0)], -1)
            pxr[ey, ex] = px.reshape(-1, 2)[flat]
        self.region_counts = (int(cov.sum()), int(len(ey)), (y1 - y0) * (x1 - x0))
        # the frame's composition (:meth:`render`) over the box, in bytes where it is the photo or the plate
        # (the plate where its object left), in floats only where a shadow, a partly moved owner or an object is
        m_own = _revealed(moved, *(None if a is None else a[y0:y1, x0:x1] for a in self._owners()))
        sh = cv2.resize(shadow, (W, H), interpolation=cv2.INTER_LINEAR)[y0:y1, x0:x1]
        image = photo_u8.copy()
        region = image[y0:y1, x0:x1]
        np.copyto(region, plate_u8[y0:y1, x0:x1], where=(m_own >= 1.0)[..., None])
        hit = obj >= 0
        partial = (m_own > 0.0) & (m_own < 1.0)
        drawn = hit | (sh > 0.5 / 255.0) | partial
        rows, cols = np.nonzero(drawn.any(1))[0], np.nonzero(drawn.any(0))[0]
        if not len(rows):
            return image
        # in floats over the drawn pixels' box only, and from the bytes just composed: where the owner's object
        # is in place or gone (m_own 0 or 1) they are the photo or the plate exactly, as the floats would be;
        # only a partly moved owner's pixels take the blend of the two
        r0, r1, c0, c1 = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
        inner = (slice(r0, r1), slice(c0, c1))
        out = region[inner].astype(np.float32)
        if partial.any():
            py, px_ = np.nonzero(partial)
            q = self.photo[y0 + py, x0 + px_]
            out[py - r0, px_ - c0] = (self.plate[y0 + py, x0 + px_] - q) * m_own[py, px_][:, None] + q
        out *= (1.0 - sh[inner])[..., None]
        hy, hx = np.nonzero(hit)
        if len(hy):
            # gathered through flat indices where the array allows: a fraction of the cost of two index arrays
            flat = hy * hit.shape[1] + hx
            k = _gather(obj, hy, hx, flat)
            pf = pxr.reshape(-1, 2)[flat] if pxr.flags.c_contiguous else pxr[hy, hx]
            tx, ty = pf[:, 0], pf[:, 1]
            colour = _sample(self.atlas_rgb, tx - 0.5, ty - 0.5).astype(np.float32)
            colour *= _gather(shade, hy, hx, flat)[:, None]
            p0 = self.photo.reshape(-1, 3)[(hy + y0) * W + hx + x0]
            colour = p0 + np.maximum(moved[k], _gather(m_own, hy, hx, flat))[:, None] * (colour - p0)
            alpha = np.clip(_sample(self.atlas_alpha, tx - 0.5, ty - 0.5), 0.0, 1.0)
            if np.any(moved[k] < 1.0):  # an object in place is drawn only where it shows the photo's own pixel
                crop = tx < self.photo_width[k]
                shift, per = self.atlas_to_photo[k], self.atlas_scale[k]
                d = np.hypot((tx + shift[:, 0]) / per[:, 0] * self.to_frame[0] - (hx + x0 + 0.5),
                             (ty + shift[:, 1]) / per[:, 1] * self.to_frame[1] - (hy + y0 + 0.5))
                alpha *= np.maximum(moved[k], crop & (d <= IN_PLACE_PX + REVEAL_PX))
            o = out.reshape(-1, 3)
            at = (hy - r0) * out.shape[1] + hx - c0
            o0 = o[at]
            o[at] = o0 + alpha[:, None] * (colour - o0)
        # every term is a blend of colours and a darkening, never below 0: only the top needs the clip
        out += 0.5
        np.minimum(out, 255.0, out=out)
        np.copyto(region[inner], out.astype(np.uint8), where=drawn[inner][..., None])
        return image

    def _upsample(self, grid: np.ndarray, y0: int, x0: int, y1: int, x1: int, i_lo: int, j_lo: int) -> np.ndarray:
        """``grid`` (samples i_lo.., j_lo.. of the sample grid) interpolated bilinearly at the frame pixels of the
        box (x0, y0)–(x1, y1), whose corner is that of sample (i_lo, j_lo)'s block: with an odd step, cv2.resize
        maps the block centres onto the samples exactly."""
        s = self._step
        assert y0 == i_lo * s and x0 == j_lo * s
        h, w = grid.shape[:2]
        out = cv2.resize(grid, (w * s, h * s), interpolation=cv2.INTER_LINEAR)
        short = (max(0, y1 - y0 - out.shape[0]), max(0, x1 - x0 - out.shape[1]))
        if any(short):  # a last partial block without a sample of its own
            out = cv2.copyMakeBorder(out, 0, short[0], 0, short[1], cv2.BORDER_REPLICATE)
        return out[:y1 - y0, :x1 - x0]

    def _region_owner(self, gy: np.ndarray, gx: np.ndarray) -> np.ndarray:
        """The photo's owner (:meth:`_read_photo`) at the samples of rows ``gy`` and columns ``gx``."""
        if getattr(self, "_grid_owner", None) is None:
            self._grid_owner = self.owner[np.ix_(gy, gx)]
        return self._grid_owner

    def _still(self, cam, points: np.ndarray, particles: list):
        """The last frame drawn and its state, where :attr:`reuse_still` allows and this frame would draw the
        same: the same camera, the same objects shown, none moved :data:`STILL_PX` on the screen, no
        particles; else None."""
        if not self.reuse_still or self.particles or particles or self._last is None:
            return None
        last_cam, hidden, last_points, image, state = self._last
        same_camera = (np.array_equal(cam.axes, last_cam.axes) and np.array_equal(cam.origin, last_cam.origin)
                       and cam.fx == last_cam.fx and cam.fy == last_cam.fy)
        if not same_camera or hidden != tuple(self._hidden) or points.shape != last_points.shape:
            return None
        if not np.array_equal(points, last_points) and self._pixel_motion(cam, points, last_points) >= STILL_PX:
            return None
        return image, state


def _revealed(moved: np.ndarray, owner: np.ndarray, sharer: np.ndarray | None,
              share: np.ndarray | None) -> np.ndarray:
    """(H, W) float32: how far each pixel shows the plate rather than the photo, ``moved`` (K + 1,) of its
    ``owner`` (H, W) int32, −1 for none (the last entry); where ``sharer`` (H, W) int32 names a second object
    (near a shadow it casts, ``texture.fill.hole_owners``), the less moved of the two, as far as ``share``
    (H, W) float32 says it shares the pixel: the photo's shadow stays while its caster stands there."""
    out = moved[owner]
    if sharer is not None:
        shared = sharer >= 0
        if shared.any():
            m = out[shared]
            out[shared] = m + share[shared] * (np.minimum(m, moved[sharer[shared]]) - m)
    return out


#: Points in a row of the maps :func:`_sample` gives cv2.remap (which takes fewer than 32767).
REMAP_ROW = 16384


def _at_scale(texture: np.ndarray, two_sided: bool, scale: float) -> np.ndarray:
    """``texture`` (h, w, 4) uint8 resized by ``scale`` (≤ 1), a two-sided one's halves (the photo crop, its
    unseen sides) each on its own so that neither bleeds into the other; as it is at 1. Colours reach past the
    alpha edge (texture.objects.crop_texture), so an area average there keeps the object's colours."""
    if scale >= 1.0:
        return texture
    halves = np.split(texture, 2, axis=1) if two_sided else [texture]
    h, w = halves[0].shape[:2]
    size = (max(1, round(w * scale)), max(1, round(h * scale)))
    return np.concatenate([cv2.resize(t, size, interpolation=cv2.INTER_AREA) for t in halves], axis=1)


def _sample(image: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``image`` (h, w[, C]) sampled bilinearly at the points (``x``, ``y``) (N,) pixel coordinates (pixel centres
    at integers), clamped at its border: (N[, C]) of its type."""
    n = len(x)
    rows = -(-n // REMAP_ROW)
    mx = np.zeros(rows * REMAP_ROW, np.float32)
    my = np.zeros(rows * REMAP_ROW, np.float32)
    mx[:n], my[:n] = x, y
    out = cv2.remap(image, mx.reshape(rows, REMAP_ROW), my.reshape(rows, REMAP_ROW), cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_REPLICATE)
    return out.reshape((rows * REMAP_ROW,) + image.shape[2:])[:n]


def _gather(a: np.ndarray, ys: np.ndarray, xs: np.ndarray, flat: np.ndarray) -> np.ndarray:
    """``a`` (h, w) at the pixels (``ys``, ``xs``), ``flat`` = ys · w + xs: through the flat index where ``a`` is
    contiguous (one index array, not two)."""
    return a.reshape(-1)[flat] if a.flags.c_contiguous else a[ys, xs]


def _vertex_normals(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(N, 3) area-weighted normals (not normalised) of ``points`` (N, 3) metres under ``faces`` (F, 3)."""
    p = np.asarray(points, np.float64)
    fn = np.cross(p[faces[:, 1]] - p[faces[:, 0]], p[faces[:, 2]] - p[faces[:, 0]])
    out = np.zeros_like(p)
    for c in range(3):
        out[:, c] = sum(np.bincount(faces[:, k], fn[:, c], len(p)) for k in range(3))
    return out


def _environment(renderer: ShotRenderer):
    """The environment of the photo's camera, its backdrop beyond the farthest object at the first frame."""
    cam = renderer.photo_camera
    farthest = 0.0
    if renderer.caster is not None:
        d = renderer.points_at(Usd.TimeCode(renderer.stage.GetStartTimeCode())) - cam.origin
        farthest = float(np.max(np.hypot(d[:, 0], d[:, 1])))
    return photo_environment(cam, farthest)


def render_shot(shot, output=None, settings: RenderSettings = RenderSettings(), progress=None,
                passes: tuple[str, ...] = (), passes_dir=None, camera: str | None = None,
                camera_amount: float = 1.0, still: bool = False) -> dict:
    """Render every frame of ``shot`` to ``output`` (default: ``video.mp4`` beside it); returns the report section.
    ``passes`` (names from :data:`passes.PASSES`) also go to ``passes_dir`` (default: ``passes/`` beside the shot).
    ``camera`` (a name from :data:`moves.MOVES`) first writes that move, ``camera_amount`` × its default size,
    to the shot's ``render.usda``; None renders the camera the shot already has. A shot never simulated is
    refused unless ``still`` (its video would be one frame of the photo)."""
    check_camera_move(camera, camera_amount)
    check_render_inputs(shot, passes, passes_dir, still)
    with all_or_nothing():
        return _render_shot(shot, output, settings, progress, passes, passes_dir, camera, camera_amount)


def check_render_inputs(shot, passes, passes_dir, still: bool) -> None:
    """Refuse (InputError, before any work) a shot never simulated unless ``still``, ``passes_dir`` without
    ``passes``, and a shot whose composed stage holds a non-finite or absurd value."""
    from ..physics.checks import check_values

    root = layers.shot_file(shot)
    if not still and root.is_file() and layers.shot_seconds(root) is None:
        raise InputError(f"{root} was never simulated, so its video would be one still frame: run "
                         f"`physomni-usd simulate {root}` first, or pass --still for that one frame")
    if passes_dir is not None and not passes:
        raise InputError("--passes-dir needs --passes (e.g. --passes depth,normal,flow,mask)")
    check_values(layers.open_shot(shot))


def check_camera_move(camera: str | None, amount: float) -> None:
    """One line naming the option when the move or its amount cannot be rendered."""
    if camera is not None and camera not in MOVES:
        raise InputError(f"--camera {camera}: no such move; one of {', '.join(MOVES)}")
    MOVE_LIMITS.check(camera_amount=amount)


def write_camera_move(folder: pathlib.Path, stage: Usd.Stage, camera: str, amount: float) -> dict:
    """Write ``camera`` × ``amount`` as the shot's ``render.usda`` (static: an empty one, where one exists) and
    put that layer in the root; returns what the report says of the move."""
    info = {"move": camera, "amount": amount}
    path = folder / layers.RENDER
    start, end = int(stage.GetStartTimeCode()), int(stage.GetEndTimeCode())
    fps = stage.GetTimeCodesPerSecond() or 30.0
    if camera == "static":
        if path.exists():
            write_render_layer(path, fps=fps, frames=end - start + 1, metadata={"physomni:cameraMove": info})
        return info
    scene = read_photo_camera_matrix(stage)
    centre = _objects_centre(stage, Usd.TimeCode(start))
    matrices = move_matrices(scene, centre, camera, amount, end - start + 1)
    size, unit = MOVES[camera]
    info.update({"size": round(size * amount, 4), "unit": unit, "pivot_m": np.round(centre, 4).tolist()})
    layer_info = {k: v for k, v in info.items() if k != "pivot_m"}  # USD dictionaries hold no lists
    write_render_layer(path, fps=fps, frames=end - start + 1, matrices=matrices, start=start,
                       metadata={"physomni:cameraMove": layer_info})
    layers.ensure_render_sublayer(folder)
    return info


def _objects_centre(stage: Usd.Stage, time: Usd.TimeCode) -> np.ndarray:
    """(3,) centre of the objects' world bounds at ``time`` (the origin when there are none)."""
    from ..usd.author import OBJECTS

    root = stage.GetPrimAtPath(OBJECTS)
    if not root:
        return np.zeros(3)
    box = UsdGeom.BBoxCache(time, [UsdGeom.Tokens.default_, UsdGeom.Tokens.render]).ComputeWorldBound(root)
    r = box.ComputeAlignedRange()
    return np.zeros(3) if r.IsEmpty() else np.array(r.GetMidpoint(), np.float64)


def _render_shot(shot, output, settings: RenderSettings, progress, passes=(), passes_dir=None, camera=None,
                 camera_amount: float = 1.0) -> dict:
    t0 = time.perf_counter()
    folder = layers.shot_folder(shot)
    stage = layers.open_shot(shot)
    move = None
    if camera is not None:
        prepare_writes(folder, [folder / layers.RENDER, folder / layers.SHOT])
        move = write_camera_move(folder, stage, camera, camera_amount)
        stage = layers.open_shot(shot)
    out = pathlib.Path(output) if output else folder / "video.mp4"
    if out.exists() and out.is_dir():
        raise InputError(f"video output {out} is a directory")
    if out.suffix.lower() != ".mp4":
        raise InputError(f"video output {out.name} must end in .mp4")
    start, end = int(stage.GetStartTimeCode()), int(stage.GetEndTimeCode())
    pass_dir = (pathlib.Path(passes_dir) if passes_dir else folder / "passes") if passes else None
    pass_paths = pass_files(pass_dir.absolute(), passes, range(start, end + 1)) if passes else []
    prepare_writes(folder, [out if out.is_absolute() else pathlib.Path.cwd() / out] + pass_paths)
    make_dirs(out.parent)
    fps = stage.GetFramesPerSecond() or stage.GetTimeCodesPerSecond() or 30.0
    renderer = ShotRenderer(stage, settings)
    renderer.reuse_still = not passes  # the frames in order, the stage unchanged; the passes read every frame
    t_setup = time.perf_counter()
    n = end - start + 1
    pass_writer = PassWriter(pass_dir, passes, renderer, fps, settings.quality) if passes else None
    try:
        with atomic_path(out) as tmp:
            writer = video_writer(tmp, fps, settings.quality)
            try:
                for k, t in enumerate(range(start, end + 1)):
                    image, state = renderer.render(float(t))
                    writer.append_data(even_sides(image))
                    if pass_writer:
                        pass_writer.add(state, float(t + 1) if t < end else None)
                    if progress:
                        progress(k + 1, n)
            except BaseException:
                if pass_writer:
                    pass_writer.close(ok=False)
                raise
            finally:
                writer.close()
        pass_section = pass_writer.close() if pass_writer else None
    except OSError as exc:
        raise encoder_failure(exc, out) from None
    t_end = time.perf_counter()
    section = {"video": str(out), "frames": n, "fps": fps, "width": renderer.width - renderer.width % 2,
               "height": renderer.height - renderer.height % 2,
               "device": renderer.device,
               "seconds": {"setup": round(t_setup - t0, 4), "frames": round(t_end - t_setup, 4)},
               "total_seconds": round(t_end - t0, 4),
               "frames_per_second": round(n / max(t_end - t_setup, 1e-9), 3)}
    if pass_section:
        section["passes"] = pass_section
    section["seconds_per_frame"] = round((t_end - t_setup) / max(n, 1), 4)
    section["camera"] = move or _camera_in_shot(stage)
    update_report(folder, render=section)
    return section


def _camera_in_shot(stage: Usd.Stage) -> dict:
    """What the report says of a camera this render did not write: the move in render.usda, if any."""
    for layer in stage.GetLayerStack(includeSessionLayers=False):
        if layer.realPath and pathlib.Path(layer.realPath).name == layers.RENDER:
            return dict(layer.customLayerData.get("physomni:cameraMove", {"move": "static"}))
    return {"move": "static"}
