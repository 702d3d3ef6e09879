"""A simulation prepared once, for ``simulate`` and the live preview alike: the composed stage checked,
its objects read, the solver and rates chosen (:func:`scene_settings`), the Newton models built
(:class:`~.assembly.ShotModels`) and the step plan chosen from them (:func:`~.stability.plan_steps`) —
Newton's builder and finalize, before its solver is stepped."""

from __future__ import annotations

import pathlib
from dataclasses import dataclass

from pxr import Usd, UsdPhysics

from .._warp import compiled_seconds, load_newton, load_warp
from ..errors import InputError
from ..settings import SimulateSettings
from ..usd import layers
from ..usd.author import OBJECTS
from .assembly import ShotModels, shot_models
from .checks import check_inputs
from .diagnose import refuse_broken_scene
from .objects import SimObject, scene_objects
from .params import authored, describe, ignored_parameters, particle_values
from .stability import DEFAULT_ITERATIONS, DEFAULT_SUBSTEPS, PlanInputs, SceneConfig, StepPlan, plan_steps

SUPPORTED_SOLVERS = ("xpbd",)


def scene_settings(stage: Usd.Stage, settings: SimulateSettings) -> SceneConfig:
    """Solver, substeps, iterations and fps: ``settings``' where given, else the stage's physics scene's."""
    scene = next((p for p in stage.Traverse() if p.IsA(UsdPhysics.Scene)), None)

    def attr(name, default):
        a = scene.GetAttribute(name) if scene else None
        v = a.Get() if a and a.HasAuthoredValue() else None
        return default if v is None else v

    fps = settings.fps or stage.GetTimeCodesPerSecond() or 30.0
    cfg = SceneConfig(solver=str(attr("physomni:solver", "xpbd")),
                      substeps=int(settings.substeps or attr("physomni:substeps", DEFAULT_SUBSTEPS)),
                      iterations=int(settings.iterations or attr("physomni:iterations", DEFAULT_ITERATIONS)),
                      fps=float(fps))
    if cfg.solver not in SUPPORTED_SOLVERS:
        raise InputError(f"physomni:solver = {cfg.solver!r} is not available; use one of {SUPPORTED_SOLVERS}")
    if not 1 <= cfg.substeps <= 1000 or not 1 <= cfg.iterations <= 100:
        raise InputError("physomni:substeps must be in [1, 1000] and physomni:iterations in [1, 100]")
    return cfg


def kernels_first_use() -> pathlib.Path | None:
    """The marker to write once this machine's warp kernel cache holds the simulator's kernels, or None
    when it already does (the marker names the versions of warp and Newton whose kernels it holds)."""
    wp, newton = load_warp(), load_newton()
    cache = pathlib.Path(wp.config.kernel_cache_dir or "")
    if not cache.is_dir():
        return None
    marker = cache / f"physomni-kernels-warp{wp.__version__}-newton{newton.__version__}"
    return None if marker.exists() else marker


def plan_inputs(models: ShotModels, settings: SimulateSettings) -> PlanInputs:
    """What the step plan of ``models`` is chosen from: the shot's rates, what the models say of the
    scene (MPM scene, cloth springs, soft bodies' step, force fields over ``settings.seconds``), and the
    steps ``settings`` fixes."""
    cfg = models.cfg
    return PlanInputs(models.objects, cfg.fps, cfg.substeps, base_iterations=cfg.iterations,
                      fixed_substeps=settings.substeps is not None, mpm_steps=settings.mpm_steps, mpm=models.mpm,
                      cloth_masses=models.cloth_masses, cloth_stiffness=models.cloth_stiffness,
                      soft_dt=models.soft_dt, acceleration=models.field_acceleration(settings.seconds),
                      field_kinds=tuple(f.kind for f in models.fields.fields),
                      particles=bool(models.model.particle_count))


@dataclass
class Prepared:
    """A shot ready to step: its composed ``stage``, solver and rates ``config``, ``objects``, the
    parameters its solvers ignore (``params.ignored_parameters``), the built ``models`` and the ``plan``
    they start on. ``kernels_marker`` is the file to write once the run has compiled the simulator's
    kernels (None: already in the cache), ``compiled_before`` warp's compile seconds before the build."""
    stage: Usd.Stage
    config: SceneConfig
    objects: list[SimObject]
    ignored: dict
    models: ShotModels
    plan: StepPlan
    settings: SimulateSettings
    kernels_marker: pathlib.Path | None = None
    compiled_before: float | None = None


def refuse_unsimulatable(stage: Usd.Stage, settings: SimulateSettings = SimulateSettings(), *, name: str = "",
                         own_seconds: float | None = None,
                         checked: bool = False) -> tuple[SceneConfig, SimulateSettings, list[SimObject]]:
    """Every refusal ``simulate`` makes of the composed ``stage`` before it builds a model, in its order: the
    solver and rates (:func:`scene_settings`), the step cap (:meth:`SimulateSettings.for_shot`), every authored
    value (``checks.check_inputs``, InputError), no objects (InputError), and an error-level finding of the
    scene (``diagnose.refuse_broken_scene``, :class:`~.diagnose.SceneRefused`). ``build`` ends on the same call,
    so that it never writes what this refuses. ``checked``: the stage's values and findings already passed
    (the same composed stage simulated again). Returns the solver and rates, the resolved settings and the
    objects."""
    cfg = scene_settings(stage, settings)
    settings = settings.for_shot(own_seconds, cfg.fps)
    if not checked:
        check_inputs(stage)
    objects = scene_objects(stage)
    if not objects:
        raise InputError(f"{name or stage.GetRootLayer().identifier}: no objects to simulate under {OBJECTS}")
    if not checked:
        refuse_broken_scene(stage)
    return cfg, settings, objects


#: The composed stage whose input checks last passed in this process: the checks are a function of the
#: composed stage alone, so the same stage simulated again (a bench, a batch's retries) is not checked again.
_CHECKED: dict = {}


def prepare_simulation(stage: Usd.Stage, settings: SimulateSettings = SimulateSettings(), *, name: str = "",
                       reuse: bool = True, own_seconds: float | None = None,
                       echo=lambda m: None) -> Prepared:
    """Check the composed ``stage`` (``layers.open_shot(..., mute_sim=True)``), read its objects, build its
    models and choose their step plan. ``name`` is the shot as the user gave it, for the refusals;
    ``reuse`` False builds new models (the preview, which changes them) where the last ones built for
    the same composed stage would be rewound (:func:`~.assembly.shot_models`). ``own_seconds`` is the
    shot's own length, the length simulated where ``settings.seconds`` is None
    (:meth:`SimulateSettings.for_shot`, which also refuses too many solver steps); the settings so
    resolved are the returned ``settings``. What the solvers will ignore, and a first compile of the
    kernels, are said through ``echo``."""
    digest = layers.content_digest(stage)
    checked = _CHECKED.get("digest") == digest
    cfg, settings, objects = refuse_unsimulatable(stage, settings, name=name, own_seconds=own_seconds,
                                                  checked=checked)
    _CHECKED["digest"] = digest
    shared = particle_values(objects)
    ignored = ignored_parameters(objects, shared)
    for kind, items in ignored.items():
        if authored(items):
            echo(f"simulate: {describe(kind, authored(items))}")
    marker = kernels_first_use()
    if marker is not None:
        echo("simulate: compiling physics kernels, once per machine (a minute or two) ...")
    compiled_before = compiled_seconds()
    models = (shot_models(stage, objects, cfg, settings, digest, shared) if reuse
              else ShotModels(stage, objects, cfg, settings, shared))
    plan = plan_steps(plan_inputs(models, settings))
    return Prepared(stage, cfg, objects, ignored, models, plan, settings, marker, compiled_before)
