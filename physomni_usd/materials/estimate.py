"""``estimate``: the physics configuration of a shot, from rules, a VLM, or the user.

Generated values (rules, vlm) replace ``physics.usda``; what a user gave on
the command line before — pushes, fixed objects, force fields of source
``user``, solver settings — is carried over. ``--set`` values are checked
here against the catalog and go to the artist's ``edits.usda`` through
:func:`physomni_usd.usd.overrides.add_overrides`: authored on that layer
itself through Sdf (every prim, property, time sample and layer metadata already
in it stays; ``#`` comments, which are not part of USD's data model, do not
survive any USD save) and saved through a temporary file and a rename. Without
``--set`` the file is not touched. This module writes no USD itself.
"""

from __future__ import annotations

import pathlib

import cv2
from pxr import Sdf, Usd, UsdPhysics

from ..errors import InputError
from ..fields import parse_force_options, read_force_fields
from ..perceive.masks import MAX_LABEL
from .._files import all_or_nothing
from ..settings import DEFAULT_ITERATIONS, DEFAULT_SUBSTEPS
from ..report import Timer, prepare_writes, update_report
from ..swappable import registry
from ..usd import layers
from ..usd.author import PhysicsObject, write_physics_layer
from ..usd.contract import MATERIAL_TYPE, bound_material, object_prims
from ..usd.overrides import add_overrides
from .catalog import PARAMS, canonical_key, check_params, keys_of, material_type
from .defaults import GROUND_MATERIAL
from .report import material_report

INPUTS = "inputs"
#: Where in a shot `build` keeps the photo the estimate is made from.
PHOTO = pathlib.PurePath(INPUTS, "photo.png")


def parse_sets(specs, objects: list[Usd.Prim]) -> list[tuple[Usd.Prim, str, object]]:
    """``NAME.KEY=VALUE`` → (object prim, canonical key or 'material', value); NAME is a prim name (one
    object) or a label (every object with that label, one tuple each)."""
    by_name: dict[str, list[Usd.Prim]] = {}
    for prim in objects:
        by_name.setdefault(prim.GetAttribute("physomni:label").Get(), []).append(prim)
    for prim in objects:
        by_name[prim.GetName()] = [prim]
    out = []
    for spec in specs or ():
        target, eq, value = spec.partition("=")
        name, dot, key = target.rpartition(".")
        if not eq or not dot or not name or not key or not value.strip():
            raise InputError(f"--set {spec!r}: expected NAME.KEY=VALUE, e.g. cup.density=800 or cup.material=mpm_sand")
        prims = by_name.get(name.strip())
        if not prims and len(name) > MAX_LABEL:  # said in a line, not echoed whole (twice) onto the terminal
            raise InputError(f"--set {spec[:40] + '…'!r}: the name is {len(name):,} characters long, and no object's "
                             f"name or label is longer than {MAX_LABEL}")
        if not prims:
            from ..suggest import did_you_mean

            known = ", ".join(sorted(n for n in by_name if n))
            raise InputError(f"--set {spec!r}: no object named {name.strip()!r}{did_you_mean(name, by_name)} "
                             f"(known: {known})")
        key = key.strip().lower()
        if key in ("material", "material_type", "type"):
            try:
                kind = material_type(value.strip())
            except ValueError as exc:
                raise InputError(f"--set {spec!r}: {exc}") from None
            out += [(prim, "material", kind) for prim in prims]
            continue
        k = canonical_key(key)
        if k is None:
            raise InputError(f"--set {spec!r}: unknown parameter {key!r}; one of friction, {', '.join(PARAMS)}")
        p = PARAMS["static_friction" if k == "friction" else k]
        if p.choices:
            v = value.strip()
        else:
            try:
                v = float(value)
            except ValueError:
                raise InputError(f"--set {spec!r}: {value!r} is not a number") from None
        if not p.accepts(v):
            raise InputError(f"--set {spec!r}: {k} must be in {p.describe_range()}")
        out += [(prim, k, v) for prim in prims]
    return out


def apply_sets(folder: pathlib.Path, sets) -> list[str]:
    """Check ``--set`` values against the objects' physics materials and author them in ``edits.usda``
    (:func:`physomni_usd.usd.overrides.add_overrides`, which keeps every spec already there, as for the
    preview's "Keep settings"); returns what was set. Nothing is written when one value is refused."""
    if not sets:
        return []
    stage = layers.open_shot(folder, mute_sim=True)
    types: dict = {}  # material prim path → the type it will have (a material may be shared)
    writes, done = [], []
    # material types first, so that parameters are checked against the type they will have
    for prim, key, value in sorted(sets, key=lambda s: s[1] != "material"):
        prim = stage.GetPrimAtPath(prim.GetPath())
        mat = bound_material(prim)
        if mat is None:
            raise InputError(f"{prim.GetPath()} has no physics material; run `physomni-usd build` again")
        where = f"{mat.GetPath()}"
        if key == "material":
            types[mat.GetPath()] = value
            writes.append((str(mat.GetPath()), MATERIAL_TYPE, value))
            done.append(f"{prim.GetName()}.material = {value}")
            continue
        material = types.get(mat.GetPath()) or mat.GetAttribute(MATERIAL_TYPE).Get() or "rigid"
        targets = ("static_friction", "dynamic_friction") if key == "friction" else (key,)
        for t in targets:
            if t not in keys_of(material):
                raise InputError(f"{where}: a {material} material has no {t}; it takes {', '.join(keys_of(material))}")
            writes.append((str(mat.GetPath()), PARAMS[t].attr, value))
            done.append(f"{prim.GetName()}.{t} = {value}")
    add_overrides(folder, writes, mute_sim=True)
    return done


def _carried_controls(folder: pathlib.Path) -> tuple[dict, dict, list]:
    """Per object: velocities and flags from the current physics layer; scene solver settings; user fields."""
    physics_path = folder / layers.PHYSICS
    if not physics_path.exists():
        return {}, {}, []
    layers.check_layer(physics_path)
    root = Sdf.Layer.CreateAnonymous(".usda")
    root.subLayerPaths[:] = [str(physics_path), str(folder / layers.SCENE)]
    stage = Usd.Stage.Open(root)
    physics = Sdf.Layer.FindOrOpen(str(physics_path))

    def own(attr):  # a value authored in the physics layer itself
        return attr.Get() if attr and physics.GetAttributeAtPath(attr.GetPath()) is not None else None

    controls = {}
    for prim in object_prims(stage):
        body = UsdPhysics.RigidBodyAPI(prim)
        controls[prim.GetName()] = {
            "velocity": own(body.GetVelocityAttr()), "angular_velocity": own(body.GetAngularVelocityAttr()),
            "fixed": bool(own(prim.GetAttribute("physomni:fixed"))),
            "initial_velocity": own(prim.GetAttribute("physomni:initialVelocity")),
            "initial_angular_velocity": own(prim.GetAttribute("physomni:initialAngularVelocity")),
            "start": own(prim.GetAttribute("physomni:velocityStartTime")),
        }
    scene = stage.GetPrimAtPath("/World/PhysicsScene")
    solver = {k: own(scene.GetAttribute(f"physomni:{k}")) for k in ("solver", "substeps", "iterations")}
    user_fields = []
    for f in read_force_fields(stage):
        source = stage.GetPrimAtPath(f.path).GetAttribute("physomni:source").Get()
        if source == "user":
            user_fields.append(f)
    return controls, solver, user_fields


def _set_without_photo(folder, set_values, new_fields, estimator, echo, timer) -> dict:
    """A shot with no ``inputs/photo.png`` (assembled by a script or by hand, not by ``build``): there is
    nothing to estimate from, but ``--set`` needs no estimate, so its values go to edits.usda and
    physics.usda is kept as it is."""
    photo_path = folder / PHOTO
    if not set_values or new_fields:
        why = "--force is written with an estimate, which needs it" if new_fields else "nothing to estimate from"
        raise InputError(f"{photo_path} is missing: {why} (`build` keeps the photo there); "
                         "--set NAME.KEY=VALUE alone still sets values in edits.usda")
    prepare_writes(folder, [layers.EDITS], echo)
    echo(f"estimate: {photo_path} is missing, so nothing is estimated: physics.usda is kept and only --set applied")
    with timer.step("write"):
        done = apply_sets(folder, set_values)
    for line in done:
        echo(f"estimate: set {line} in edits.usda")
    section = material_report(layers.open_shot(folder, mute_sim=True), estimator)
    section.update({"estimator": None, "estimated": False, "warnings": [f"{photo_path.name} is missing: only --set was applied"],
                    "set": done, "seconds": timer.seconds, "total_seconds": timer.total, "force_fields": []})
    update_report(folder, estimate=section)
    return section


def _inputs(folder: pathlib.Path, names: list[str]):
    photo_path = folder / PHOTO
    photo = cv2.imread(str(photo_path), cv2.IMREAD_COLOR)
    if photo is None:
        raise InputError(f"{photo_path} cannot be read as an image; `build` writes it from the photo: run it again")
    masks = []
    for name in names:
        mask = cv2.imread(str(folder / INPUTS / "masks" / f"{name}.png"), cv2.IMREAD_GRAYSCALE)
        if mask is None:
            raise InputError(f"the mask of {name} is missing from {folder / INPUTS / 'masks'}")
        masks.append(mask > 0)
    return cv2.cvtColor(photo, cv2.COLOR_BGR2RGB), masks


#: An estimator's size this far (a factor) from the scene's is worth a warning.
SIZE_WARN_FACTOR = 1.5


def compare_sizes(prims, labels, configs) -> dict:
    """Each object's longest dimension in the scene beside the estimator's, with a warning where they differ
    by more than ``SIZE_WARN_FACTOR`` (the scale is fixed by ``build``: ``--size`` changes it)."""
    import numpy as np
    from pxr import UsdGeom

    out, warnings = {}, []
    for prim, label, cfg in zip(prims, labels, configs):
        points = UsdGeom.Mesh(prim).GetPointsAttr().Get() if prim.IsA(UsdGeom.Mesh) else None
        scene = float(np.ptp(np.asarray(points), axis=0).max()) if points else None
        out[prim.GetName()] = {"scene_m": None if scene is None else round(scene, 4), "estimated_m": cfg.size_m}
        if scene and cfg.size_m and max(scene / cfg.size_m, cfg.size_m / scene) > SIZE_WARN_FACTOR:
            warnings.append(f"{prim.GetName()} is {scene:.3g} m in the scene; the estimator says about "
                            f"{cfg.size_m:.3g} m (build again with --size {label}={cfg.size_m:.3g} to use it)")
    out["_warnings"] = warnings
    return out


def estimate_shot(shot, estimator: str = "rules", vlm=None, sets=(), force_specs=(), echo=lambda m: None) -> dict:
    """Run one estimator over a shot (and apply ``--set`` / ``--force``); returns the report section."""
    with all_or_nothing():
        return _estimate_shot(shot, estimator, vlm, sets, force_specs, echo)


def _estimate_shot(shot, estimator, vlm, sets, force_specs, echo) -> dict:
    timer = Timer()
    folder = layers.shot_folder(shot)
    with timer.step("read"):
        stage = layers.open_shot(folder, mute_sim=True)
        prims = object_prims(stage)
        if not prims:
            raise InputError(f"{folder}: no objects under /World/Objects to estimate")
        set_values = parse_sets(sets, prims)
        new_fields = parse_force_options(force_specs)
        layers.warn_orphan_overs(stage, folder, echo)
        photo_less = not (folder / PHOTO).exists()
    if photo_less:
        return _set_without_photo(folder, set_values, new_fields, estimator, echo, timer)
    with timer.step("read"):
        prepare_writes(folder, [layers.PHYSICS] + ([layers.EDITS] if set_values else []), echo)
        names = [p.GetName() for p in prims]
        labels = [p.GetAttribute("physomni:label").Get() or p.GetName() for p in prims]
        photo, masks = _inputs(folder, names)
        controls, solver, user_fields = _carried_controls(folder)
    with timer.step(estimator):
        backend = registry.load("estimator", estimator, **({"settings": vlm} if estimator == "vlm" else {}))
        config = backend.estimate(photo, masks, labels, stage.GetTimeCodesPerSecond() or 30.0)
    sizes = compare_sizes(prims, labels, config.objects)
    config.warnings.extend(sizes.pop("_warnings"))
    for w in config.warnings:
        echo(f"estimate: {w}")
    with timer.step("write"):
        objects = []
        for name, cfg in zip(names, config.objects):
            c = controls.get(name, {})
            delayed = None
            if c.get("initial_velocity") is not None or c.get("initial_angular_velocity") is not None:
                delayed = (c.get("initial_velocity"), c.get("start") or 0.0)
            objects.append(PhysicsObject(
                name, cfg.material, check_params(cfg.material, cfg.params), config.source,
                velocity=c.get("velocity"), angular_velocity=c.get("angular_velocity"),
                fixed=bool(c.get("fixed")) or cfg.fixed, delayed_velocity=delayed,
                delayed_angular_velocity=c.get("initial_angular_velocity")))
        kept = [(f, "user") for f in user_fields]
        write_physics_layer(folder / layers.PHYSICS, folder / layers.SCENE,
                            fps=stage.GetTimeCodesPerSecond() or 30.0, objects=objects, ground=GROUND_MATERIAL,
                            solver=solver.get("solver") or "xpbd", substeps=solver.get("substeps") or DEFAULT_SUBSTEPS,
                            iterations=solver.get("iterations") or DEFAULT_ITERATIONS, forces=config.forces,
                            force_source=config.source, extra_forces=kept + [(f, "user") for f in new_fields])
        done = apply_sets(folder, set_values)
    for line in done:
        echo(f"estimate: set {line} in edits.usda")
    section = material_report(layers.open_shot(folder, mute_sim=True), estimator)
    section["backend"] = registry.describe(backend)
    section.update({"warnings": config.warnings, "set": done, "sizes": sizes, "seconds": timer.seconds,
                    "total_seconds": timer.total,
                    "force_fields": [f"{f.kind} ({config.source})" for f in config.forces]
                    + [f"{f.kind} (user)" for f in user_fields + new_fields]})
    update_report(folder, estimate=section)
    return section
