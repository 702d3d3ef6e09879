"""Every tunable of the pipeline, with its default, unit and valid range, and the rules on them.

Defaults follow the paper where it gives one (``shared`` REFERENCE table);
where it is silent the choice is ours and written beside the field. A field
that the command line sets carries an :class:`Option` (its flag and help):
the CLI declares its options from these, and a refused value is named by its
flag (:func:`option_of`), so a new option is one field here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field

from .errors import InputError


@dataclass(frozen=True)
class Option:
    """How a settings field is given on the command line: ``flag`` (``--seconds``), ``text`` (what it is,
    one sentence without a full stop where ``default`` follows), ``default`` (the default in words, for
    a field whose default None stands for a choice made later), ``limit`` (what bounds it beyond its
    range, appended to the range), ``metavar``."""

    flag: str
    text: str
    default: str | None = None
    limit: str = ""
    metavar: str | None = None

#: What build and estimate write to a shot's physics scene: XPBD substeps per frame (30 fps), the step
#: planner's count for free rigid motion (``physics/stability.py``'s ``RIGID_SUBSTEPS["free"]``), and XPBD
#: iterations per substep (2 met every rigid reference case at 1 %; more only where mass ratios or strong
#: fields ask for them).
DEFAULT_SUBSTEPS = 8
DEFAULT_ITERATIONS = 2


class _Settings(BaseModel):
    model_config = ConfigDict(extra="forbid", validate_assignment=True, allow_inf_nan=False)


class CameraSettings(_Settings):
    fov_deg: Annotated[float | None, Option(
        "--fov", "Vertical field of view of the photo in degrees",
        "from the focal length in the photo's EXIF, else its vanishing points, else 50°")] = Field(
        None, gt=5.0, lt=150.0, description="Vertical field of view of the photo, degrees; None reads it from the "
                                            "photo's EXIF focal length (perceive.exif), else estimates it from "
                                            "its vanishing points, else 50° (a phone's main camera).")
    fov_source: str | None = Field(None, description="What set fov_deg where the user did not (the photo's "
                                                     "EXIF, by build); None: the user. Reported as the view's "
                                                     "source.")
    pitch_deg: Annotated[float | None, Option(
        "--pitch", "Downward camera tilt in degrees, 0 (level) to 90 (straight down)",
        "estimated from the photo: round outlines, vanishing points, horizon, where objects stand")] = Field(
        None, ge=0.0, le=90.0, description="Downward tilt of the camera, degrees; None estimates it from the "
                                           "photo (align/cues.py).")
    height_m: Annotated[float | None, Option(
        "--camera-height", "Camera height above the ground in metres; sets the scene's scale",
        "from the objects' typical sizes by label, else 1 m")] = Field(
        None, gt=0.01, le=1000.0, description="Height of the camera above the ground, metres; it sets the scene's "
                                              "scale. None: the scale comes from the objects' typical sizes "
                                              "(physomni_usd/sizes.py), or a camera 1 m high if no label has one.")


class LiftSettings(_Settings):
    rows: int = Field(16, ge=4, le=256, description="Cross-sections sampled along an object's silhouette.")
    sections: int = Field(16, ge=8, le=128, description="Vertices around each cross-section.")
    shape: Annotated[Literal["auto", "round", "extrude"], Option(
        "--shape", "How silhouettes become meshes: surface of revolution, extrusion, or by symmetry.")] = Field(
        "auto", description="round: surface of revolution; extrude: slab of the outline; "
                            "auto: round when the outline is mirror-symmetric.")
    depth_ratio: float = Field(0.4, gt=0.01, le=2.0,
                               description="Depth of an extruded object as a fraction of the smaller of its "
                                           "width and height (a row narrower than that is as deep as it is "
                                           "wide).")
    symmetry_iou: float = Field(0.88, ge=0.0, le=1.0,
                                description="Mirror IoU of the outline above which auto picks round.")


class BuildSettings(_Settings):
    camera: CameraSettings = CameraSettings()
    lift: LiftSettings = LiftSettings()
    fps: Annotated[float, Option("--fps", "Frames per second of the shot.")] = Field(
        30.0, ge=1.0, le=1000.0, description="Frames per second of the shot.")
    plate_dilation: float = Field(0.015, ge=0.0, le=0.2,
                                  description="Mask dilation before inpainting, as a fraction of the image diagonal.")
    alignment: str = Field("agmf", pattern="^(none|canonical|ransac|agmf)$",
                           description="Scene alignment of external meshes (--meshes): the paper's ablation variants.")
    render_compare: bool = Field(True, description="Weigh the cues' camera pitch against others by lifting the "
                                                   "scene under each and comparing its silhouettes, sizes and "
                                                   "supports with the photo's (align.compare).")
    render_compare_fov: bool = Field(False, description="Where no cue reads the field of view, search it with "
                                                         "the pitch (align.compare.search_view; about 3x the "
                                                         "pitch search's lifts).")
    camera_search: bool = Field(True, description="Refine the camera against the masks after aligning external "
                                                   "meshes (coarse-to-fine: random samples, then Powell).")
    camera_search_evals: int = Field(300, ge=1, le=100000, description="Cap on renders of the camera search.")
    settle_s: Annotated[float, Option(
        "--settle", "Seconds the built scene is simulated with nothing pushed, to keep where each object "
        "settles (a few mm into a bowl's hollow) as its rest pose and to name what falls; it ends early once "
        "everything is still, and goes on to twice as long while what still moves could yet be kept; 0 writes "
        "the scene as placed.")] = Field(
        2.0, ge=0.0, le=5.0, description="Seconds of the settle (physics.settle): the built scene simulated "
                                         "with nothing pushed, small settling kept, falls reported; 0: none.")
    gap_m: float = Field(0.002, ge=0.0, le=1.0, description="Clearance left between objects' footprints, metres.")
    # 40 MP covers a full-frame camera's photo; what a build needs grows with the pixels (gigabytes at 48 MP)
    max_pixels: Annotated[int, Option(
        "--max-pixels", "Refuse a larger photo (width × height), judged from its header before decoding.")] = Field(
        40_000_000, ge=65_536, le=1_000_000_000, description="Largest photo, in pixels (width × height), read from "
                                                             "its header before anything decodes it.")
    working_pixels: int = Field(1_000_000, ge=65_536, le=1_000_000_000,
                                description="A larger photo is worked on (masks, cues, lifting, placement) at "
                                            "this many pixels; the plate, the textures and frame 0 keep the "
                                            "photo's own (perceive.working).")
    max_objects: int = Field(64, ge=1, le=1000,
                             description="Most objects one shot may have (--mask and --box together); each costs "
                                         "a lift, a texture and a body, and the alignment grows with their pairs.")


#: Most solver steps one `simulate` may ask for (frames × --substeps): 20 s at 100 fps × 500 substeps, about
#: a quarter of an hour of stepping even at a millisecond a step.
MAX_SOLVER_STEPS = 1_000_000


#: Most MPM particles one shot may hold when --particle-spacing is given: each costs its grid cells and a
#: transfer each step (about 4 GB of state and hours of stepping on a CPU at this count).
MAX_PARTICLES = 2_000_000


#: A ball's collider (``physics.round``): a rigid object lifted as what may be a ball collides as a sphere
#: only where the upright ellipsoid with its hull's extents is round, its longest semi-axis within
#: ``BALL_SPHERE_SPREAD`` of its shortest (a taller one balancing on its end as an ellipsoid rolls away), and
#: the sphere is the hull's shape: that ellipsoid holds at least ``BALL_MIN_FILL`` of the hull's volume (a
#: tessellated ball: 1.0-1.04, the hull lying inside its points' ellipsoid; a cylinder 0.67; a cube 0.52)
#: and the sphere, its radius the smallest semi-axis and under its centre of mass, pokes out of the hull by at most
#: ``BALL_MAX_PROTRUSION`` of its radius (a tessellated ball: under 2 %; its centre of mass 1 mm off the
#: middle of a 3.2 cm ball, 3.5 %). Everything else keeps its hull.
BALL_MIN_FILL = 0.9
BALL_MAX_PROTRUSION = 0.05
BALL_SPHERE_SPREAD = 0.05
#: ... or where it is round across (its level semi-axes within ``BALL_SPHERE_SPREAD``) and its upright one the
#: longest by at most ``BALL_TALL_SPREAD``: a ball lifted from its footprint takes its height from the tangent
#: cone of its outline, that uncertain (452298/004's orange: 6.6 % taller than wide, truly round), and its
#: hull rocked on its facets (7.8° in 2 s). It collides as the sphere of its level radius, its lowest point
#: the hull's.
BALL_TALL_SPREAD = 0.10
#: A ball seen standing (``lift.silhouette.ball_body``) rests on a round sole: its sphere cut this fraction of
#: its radius over its lowest point (a sole √(2·0.03) ≈ 0.25 of its radius across, 2 mm of a 7 cm orange's
#: height flat). On its pole alone its hull, which a ball something rests on collides as, rocked on the pole's
#: small facets: the lower of two stacked oranges turned 6° and slid 12 mm.
BALL_SOLE = 0.03
#: A round thing is lifted as a centred ball (``lift.ball``) from the circle its visible outline shows: the arc the
#: photo shows must cover at least ``BALL_ARC_MIN`` of that circle to measure it (a ball's label otherwise takes
#: its whole outline's circle), and an outline whose label names no ball is one only where that arc fits its circle
#: to ``BALL_ARC_RMS`` of the radius. A ball's label takes a looser ``BALL_LABEL_ARC_RMS`` (a fruit is a little
#: flat or lumpy), but a fit worse than that (a straight cut, two fruits' merged outline) is no ball's outline.
BALL_ARC_MIN = 0.3
BALL_ARC_RMS = 0.02
BALL_LABEL_ARC_RMS = 0.06
#: A ball's label's arc covering ``BALL_ELLIPSE_ARC`` of its circle and fitting an upright ellipse to under
#: ``BALL_ELLIPSE_GAIN`` of the circle's error (and ``BALL_LABEL_ARC_RMS``) is lifted as that upright oblate
#: spheroid, its height kept at least ``BALL_FLAT_MIN`` of its width (and at most its width: taller, it would
#: stand on its tip). A fruit 12 px across fits no curve better than 2-3 % (its pixels), hence a ratio.
BALL_ELLIPSE_ARC = 0.5
BALL_ELLIPSE_GAIN = 0.7
BALL_FLAT_MIN = 0.5
#: Angular bins over which the visible arc's coverage of its circle is counted (``lift.ball.fit_circle``).
BALL_ARC_BINS = 36
#: An outline pixel is the thing's own edge only where no other object's visible mask and no hidden part of its
#: completed outline lie within this many pixels of it: an occluder's straight edge is not the ball's.
BALL_EDGE_PX = 2
#: A ball's diameter read from its arc must lie within this factor of its label's typical size at the scene's
#: scale, and under 0.9 of the camera's height above its support; else the arc (or the ground it was put on) was
#: wrong and the outline's own lift is kept.
BALL_SIZE_BAND = 2.0
#: An outline is hidden where more than this fraction of its completed mask is not seen (completion's slack).
BALL_HIDDEN_FRACTION = 0.02
#: A label the size table calls a ball is a round thing's (lifted as a centred ball whatever its outline) where its
#: typical height is at least this fraction of its length: a lemon (6 of 7 cm) is, a potato or an egg is not.
BALL_LABEL_ROUNDNESS = 0.8
#: A ball something rests on keeps its hull (a sphere has no rolling resistance, so what stands on it rolls it
#: away: two round balls stacked 2 mm off centre, the lower as a sphere rolled 22 cm, as a hull 1 mm): another
#: object's lowest point over the ball, above its middle and at most this far above its top.
BALL_LOAD_GAP = 0.005

#: What a lifted rigid object truly rests on (``geometry.resting.real_contact``): its points within this (m) of
#: its lowest point. The solver touches vertices, and a slanted foot's 10 mm contact band reads a centre of
#: mass 13 mm inside a foot it lies 17 mm outside of (241611/038's cup on a book tipped at once). Over the
#: 258 objects of that seed, none whose centre of mass lay at least 6 mm inside this contact moved; most at
#: under 6 mm, outside it, or on two points did. What it is asked to keep is still the steady margin
#: (``geometry.resting.STEADY_MARGIN``, up to 10 mm), the same as inside a top: 6 mm is what that seed's
#: objects showed, not a bound, and a margin apart for the contact would judge one foot by two rules.
REAL_CONTACT = 0.002
#: An object is kept steady against at least this tilt (degrees): its centre of mass at least
#: tan(this) times its height over its sole inside its foot (``geometry.resting.steady_margin``), as well as the
#: least-width rule. A quarter of a 16.6 mm foot (4.2 mm) passed a 92 mm slab, a bowl squashed thin to make
#: room, its centre of mass 4.8 mm inside: it tipped over at 5.3° and fell 15 cm (587774/046). 7° is above that
#: tip and costs a low object nothing (a 3 cm book's 15 mm centre needs 1.8 mm, below the least-width rule).
STEADY_TILT_DEG = 7.0
#: A stacked load at least this many times its supporter's mass (solids at their labels' table densities) ...
HEAVY_LOAD = 4.5
#: ... is kept this many times the steady margin inside its top (``physics.support.steady_stacks``): the light
#: supporter leans under it in the solver. 241611/054's cup, 5.3 times its book's mass and 10 mm inside its top,
#: tilted the book 0.9° and slid off; 046's, 4.1 times its book's, stood 14 mm inside; books on books and boxes
#: on boxes are lighter than that over what holds them. One failing scene set both: a guard, not a law.
HEAVY_LOAD_MARGIN = 1.4
#: A height not read from the photo (a label's typical size, a guess: boxes come in every size) of a thing on
#: another's top is cut to where the footprint its outline holds (``lift.footprint.held_height``) keeps this
#: share of the outline's cast at its foot. A small box on a stack, given the 30 cm of boxes in general, had no
#: footprint, was lifted as a slab on one corner of its slanted lower edge and fell off (587774/051, /026); a
#: 12 × 10 × 9 cm box given a height just under the one with no footprint kept a 6 × 3 cm sliver 30 cm tall
#: (3.5 % of its cast), a fin that toppled. A box's own footprint keeps about half its cast
#: (that box's 0.64 from 72° above, 0.50 from 55°, 0.41 from 44°): seen lower than about 55° the cut comes out
#: below the box (7.6 of its 9 cm from 44°), a squat box rather than a fin.
HELD_SHARE = 0.5

#: Seconds of stillness after which ``run`` ends a take when its length was not asked for.
REST_SECONDS = 1.0

#: Simulated seconds of a shot that has no length of its own yet (built, never simulated).
DEFAULT_SECONDS = 3.0


class SimulateSettings(_Settings):
    seconds: Annotated[float | None, Option(
        "--seconds", "Simulated seconds",
        "the shot's own length, its last frame over its frame rate; "
        f"{DEFAULT_SECONDS:g} for a shot never simulated")] = Field(
        None, gt=0.0, le=600.0, description="Simulated seconds; None: the shot's own length (its last frame over "
                                            f"its frame rate), {DEFAULT_SECONDS:g} for a shot never simulated.")
    fps: Annotated[float | None, Option("--fps", "Frames per second", "the shot's")] = Field(
        None, ge=1.0, le=1000.0, description="Frames per second; None keeps the shot's.")
    substeps: Annotated[int | None, Option(
        "--substeps", "Solver steps per frame", "chosen from the shot's materials and speeds",
        f"; at most {MAX_SOLVER_STEPS:,} steps in all (frames × substeps)")] = Field(
        None, ge=1, le=1000, description="Solver steps per frame; None keeps the shot's.")
    iterations: int | None = Field(None, ge=1, le=100, description="Solver iterations; None keeps the shot's.")
    device: str | None = Field(None, description="warp device ('cpu', 'cuda:0'); None picks cuda when present.")
    particle_spacing: Annotated[float | None, Option(
        "--particle-spacing", "MPM particle spacing",
        "2 particles per cm³ of the MPM objects, each counted as at least 1,000, at most 15,000 particles",
        f", and at most {MAX_PARTICLES:,} particles in all", metavar="METRES")] = Field(
        None, gt=1e-4, le=10.0, description="MPM particle spacing in metres; None chooses it from the objects' sizes.")
    mpm_steps: Annotated[int | None, Option(
        "--mpm-steps", "MPM steps per frame",
        "what the bench found accurate for the shot's materials (elastic 16, sand 4, liquid 2 at 30 fps), "
        "fewer where the CFL bound allows; fewer is a faster, less accurate preview")] = Field(
        None, ge=1, le=1000, description="MPM steps per frame; None chooses them from the materials.")
    rest_seconds: float | None = Field(None, gt=0.0, le=60.0,
                                       description="End the take once nothing has moved for this long (that "
                                                   "still stretch kept) and no push or force field is still to "
                                                   "act; None simulates all the seconds.")

    def for_shot(self, own_seconds: float | None, fps: float) -> SimulateSettings:
        """These settings for a shot whose own length is ``own_seconds`` (None: never simulated) at ``fps``
        frames a second: ``seconds`` filled in where not asked for, and refused (InputError) when frames ×
        ``substeps`` exceed :data:`MAX_SOLVER_STEPS`, before any work rather than after an hour of it."""
        seconds = self.seconds if self.seconds is not None else (own_seconds or DEFAULT_SECONDS)
        if self.substeps is not None:
            steps = round(seconds * fps) * self.substeps
            if steps > MAX_SOLVER_STEPS:
                raise InputError(f"--substeps {self.substeps}: {seconds:g} s at {fps:g} fps is {steps:,} solver "
                                 f"steps; at most {MAX_SOLVER_STEPS:,} (fewer --seconds, --fps or --substeps)")
        return self.model_copy(update={"seconds": seconds})


class RenderSettings(_Settings):
    shadow_strength: float = Field(0.45, ge=0.0, le=1.0,
                                   description="Darkening of the ground where a moved object touches it.")
    shadow_falloff: float = Field(0.15, gt=0.0, le=10.0,
                                  description="Reach of a contact shadow, as a fraction of the object's height: "
                                              "a ground point this far from the object's surface (beside or "
                                              "under it) is darkened a quarter as much as at contact.")
    shadow_blur: float = Field(0.012, ge=0.0, le=0.2, description="Shadow softness, fraction of the image diagonal.")
    quality: int = Field(9, ge=1, le=10, description="H.264 quality, 10 is best.")
    max_size: Annotated[int, Option(
        "--max-size", "Longest side of the video in pixels; larger photos are rendered smaller (frame 0 is the photo "
                      "at that size), smaller ones at their own size. H.264 needs even sides: an odd width or "
                      "height loses its last column or row. The default is HD video's 1280 (1280×720's long "
                      "side): a frame where an object moves costs about 0.2 CPU seconds at 741×500, 0.3 at "
                      "1280×864 and 0.8 at 1920×1295 on a 2-core CPU, so a 12 MP photo's video at full HD "
                      "costs about 2.7× its 1280 one; pass 1920 or the photo's own size for more. Above 1100 px "
                      "rays are cast on every third pixel where the surface seen is smooth; a frame where "
                      "nothing moved is the last one again and costs only its encoding.")] = Field(
                          1280, ge=64, le=8192,
                          description="Longest side of the video in pixels; larger photos are rendered smaller.")
    device: str | None = Field(None, description="warp device; None picks cuda when present.")


#: Every settings model whose fields the command line sets.
MODELS = (CameraSettings, LiftSettings, BuildSettings, SimulateSettings, RenderSettings)


def option(model: type[BaseModel], field: str) -> Option | None:
    """The :class:`Option` that ``model``'s ``field`` carries, or None."""
    return next((m for m in model.model_fields[field].metadata if isinstance(m, Option)), None)


def option_of(model_name: str, field: str) -> str | None:
    """The flag that sets ``field`` of the settings model named ``model_name`` (a pydantic error's
    title), else of any model with such a field; None when no option sets it."""
    found = [m for m in MODELS if field in m.model_fields and option(m, field) is not None]
    found.sort(key=lambda m: m.__name__ != model_name)
    return option(found[0], field).flag if found else None
