"""The layer layout of a shot, and how layers reach the disk.

A shot folder holds one layer per stage plus the artist's layer::

    shot.usda     root: subLayers [edits.usda, (render.usda,) sim.usdc, physics.usda, scene.usda]
    edits.usda    the artist's; created empty (with the shot's time codes) once, never rewritten by us
    render.usda   render: the camera move, once `render --camera` has written one
    sim.usdc      simulate: time samples, and the Points prims of particle objects it defines
    physics.usda  estimate: physics materials and flags, as overs
    scene.usda    build: camera, ground, background, object meshes

Every write goes to a temporary file in the same folder and is renamed over
the target, so a crash never leaves a half-written layer.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import pathlib

from pxr import Sdf, Usd, UsdGeom, UsdPhysics

from .._files import atomic_path
from ..errors import InputError

SHOT = "shot.usda"
EDITS = "edits.usda"
SIM = "sim.usdc"
PHYSICS = "physics.usda"
SCENE = "scene.usda"
RENDER = "render.usda"

#: Strongest first, as USD orders subLayers.
SUBLAYERS = (EDITS, SIM, PHYSICS, SCENE)


def save_layer(layer: Sdf.Layer, path: os.PathLike | str) -> pathlib.Path:
    """Write ``layer`` to ``path`` through a temporary file and a rename.

    The temporary file keeps the target's extension so that USD picks the same
    file format (usda or usdc). A layer already open under ``path`` in this
    process is reloaded so later stages see the new content.
    """
    # the folder resolved (it may be a link the user made), the file not: a layer that is a link is refused,
    # never written through (atomic_path)
    path = pathlib.Path(path)
    path = path.parent.resolve() / path.name
    with atomic_path(path) as tmp:
        if not layer.Export(str(tmp)):
            raise OSError(f"USD could not write {path.name}")
    cached = Sdf.Layer.Find(str(path))
    if cached is not None and cached is not layer:
        cached.Reload(force=True)
    return path


def read_again(folder: os.PathLike | str, skip=(), only=None) -> None:
    """Read again each layer of ``folder`` that this process already has open and whose file changed since.

    USD hands out the layer it opened first for as long as anything holds it, and the preview holds the shot's
    stage for its whole session: its "Keep settings" would otherwise check and compose the shot as it was when
    the page opened, and write ``edits.usda`` from that copy, dropping what an editor or `estimate --set` put
    there meanwhile (a sublayer, a value). Layers changed in memory and not saved are left as they are, and those
    named in ``skip`` or not in ``only`` (file names); one damaged since is refused in one line, as
    :func:`check_layer` refuses it."""
    from pxr import Tf

    here = os.path.realpath(folder)
    for layer in Sdf.Layer.GetLoadedLayers():
        name = os.path.basename(layer.realPath)
        if layer.anonymous or layer.dirty or not name or name in skip or (only is not None and name not in only):
            continue
        if os.path.realpath(os.path.dirname(layer.realPath)) != here:
            continue
        # another stage on the layer is composed again: its warnings (a cycle now on disk) are not ours to print,
        # the caller's own check says what is wrong in one line
        with contextlib.ExitStack() as scope:
            trap = scope.enter_context(Tf.DiagnosticTrap()) if hasattr(Tf, "DiagnosticTrap") else None
            try:
                layer.Reload()  # only where the file's time changed
            except Tf.ErrorException as exc:  # damaged since: never written over from the copy read before
                raise InputError(_unreadable(pathlib.Path(layer.realPath), exc)) from None
            finally:
                if trap is not None:
                    trap.Clear()


def set_stage_metadata(layer: Sdf.Layer, fps: float, frames: int | None = None) -> None:
    """Author the contract's stage metadata on ``layer`` (Z up, metres, kilograms, time)."""
    layer.defaultPrim = "World"
    pseudo = layer.pseudoRoot
    pseudo.SetInfo(UsdGeom.Tokens.upAxis, UsdGeom.Tokens.z)
    pseudo.SetInfo(UsdGeom.Tokens.metersPerUnit, 1.0)
    pseudo.SetInfo(UsdPhysics.Tokens.kilogramsPerUnit, 1.0)
    layer.timeCodesPerSecond = float(fps)
    layer.framesPerSecond = float(fps)
    if frames is not None:
        layer.startTimeCode = 0.0
        layer.endTimeCode = float(max(frames - 1, 0))


def write_shot_layer(folder: pathlib.Path, fps: float, frames: int | None = None,
                     extra: dict | None = None) -> pathlib.Path:
    """Write the root ``shot.usda`` that composes the stage layers (strongest first)."""
    layer = Sdf.Layer.CreateAnonymous(".usda")
    layer.subLayerPaths[:] = [f"./{name}" for name in SUBLAYERS]
    set_stage_metadata(layer, fps, frames)
    layer.comment = "physomni-usd shot: edits.usda is yours; the other layers are regenerated by their stage."
    if extra:
        data = dict(layer.customLayerData)
        data.update(extra)
        layer.customLayerData = data
    return save_layer(layer, folder / SHOT)


def ensure_edits_layer(folder: pathlib.Path, fps: float) -> pathlib.Path:
    """Create an empty ``edits.usda`` if there is none; never touch an existing one.

    The new layer carries the shot's ``timeCodesPerSecond`` / ``framesPerSecond``: without them USD reads
    its samples at 24 per second and rescales them under the root's rate (keys at frames 10 and 20 would
    land at 12.5 and 25 in a 30 fps shot). An existing layer without them is left alone here; only
    ``estimate --set`` adds them (see :func:`add_edits_time_codes`).
    """
    path = folder / EDITS
    if path.exists():
        return path
    layer = Sdf.Layer.CreateAnonymous(".usda")
    layer.comment = "Your layer: overrides authored here win over every generated layer."
    layer.timeCodesPerSecond = float(fps)
    layer.framesPerSecond = float(fps)
    return save_layer(layer, path)


def add_edits_time_codes(edits: Sdf.Layer, fps: float) -> bool:
    """Author the root's frame rate on the artist's layer where it has none (only its writers, ``estimate
    --set`` and the preview's Keep settings, which author on that layer anyway, call this); returns whether
    it did."""
    if edits.HasTimeCodesPerSecond() or edits.HasFramesPerSecond():
        return False
    edits.timeCodesPerSecond = float(fps)
    edits.framesPerSecond = float(fps)
    return True


def orphan_overs(stage: Usd.Stage, folder: pathlib.Path) -> list[str]:
    """Prims that only ``edits.usda`` mentions (overs of objects, materials, … no other layer defines any
    more, e.g. after a rebuild with fewer objects): USD ignores them. The topmost of each such subtree."""
    edits = Sdf.Layer.Find(str((folder / EDITS).resolve())) or Sdf.Layer.FindOrOpen(str(folder / EDITS))
    if edits is None:
        return []
    paths = []
    edits.Traverse(Sdf.Path.absoluteRootPath, lambda p: paths.append(p) if p.IsPrimPath() else None)
    orphans: list[Sdf.Path] = []
    for path in sorted(paths, key=lambda p: p.pathElementCount):
        if any(path.HasPrefix(o) for o in orphans):
            continue
        spec = edits.GetPrimAtPath(path)
        prim = stage.GetPrimAtPath(path)
        if spec and spec.specifier == Sdf.SpecifierOver and (not prim or not prim.IsDefined()):
            orphans.append(path)
    return [str(o) for o in orphans]


_ORPHANS_SAID: set[tuple[str, tuple[str, ...]]] = set()


def warn_orphan_overs(stage: Usd.Stage, folder: pathlib.Path, echo) -> list[str]:
    """Say (one line, once per process: `run` reaches it from several stages) which overs of ``edits.usda``
    USD ignores because nothing defines their prim."""
    orphans = orphan_overs(stage, folder)
    key = (str(pathlib.Path(folder).resolve()), tuple(orphans))
    if orphans and key not in _ORPHANS_SAID:
        _ORPHANS_SAID.add(key)
        echo(f"warning: edits.usda has overs for prims no layer defines any more, which are ignored: "
             f"{', '.join(orphans)}")
    return orphans


def ensure_render_sublayer(folder: pathlib.Path) -> bool:
    """Put ``render.usda`` in the root's subLayers, just below ``edits.usda`` (shots start without it);
    rewrites only ``shot.usda``. Returns whether it had to be added."""
    path = pathlib.Path(folder) / SHOT
    layer = Sdf.Layer.FindOrOpen(str(path))
    subs = list(layer.subLayerPaths)
    if any(pathlib.Path(sub).name == RENDER for sub in subs):
        return False
    at = next((i + 1 for i, sub in enumerate(subs) if pathlib.Path(sub).name == EDITS), 0)
    copy = Sdf.Layer.CreateAnonymous(".usda")
    copy.TransferContent(layer)
    copy.subLayerPaths.insert(at, f"./{RENDER}")
    save_layer(copy, path)
    return True


def reset_sim_layer(folder: pathlib.Path, fps: float) -> pathlib.Path:
    """Write an empty ``sim.usdc``: a new scene makes any earlier simulation meaningless."""
    path = folder / SIM
    layer = Sdf.Layer.CreateAnonymous(".usdc")
    layer.timeCodesPerSecond = float(fps)
    layer.framesPerSecond = float(fps)
    return save_layer(layer, path)


def shot_folder(shot_path: os.PathLike | str) -> pathlib.Path:
    """Folder of a shot given its ``shot.usda`` path or the folder itself."""
    p = pathlib.Path(shot_path)
    return p if p.is_dir() else p.parent


#: What to do about a missing layer, by name.
_MISSING_HINT = {
    SIM: "run `physomni-usd simulate` to write it",
    EDITS: "build again (it writes an empty one and keeps an existing one) or restore yours",
}


def shot_file(shot_path: os.PathLike | str) -> pathlib.Path:
    """``shot.usda`` of a shot given by that file or by its folder."""
    p = pathlib.Path(shot_path)
    return p / SHOT if p.is_dir() else p


def check_shot_layers(shot_path: os.PathLike | str, *, skip_sim: bool = False) -> pathlib.Path:
    """Refuse a shot whose root or any sublayer is missing or damaged, with one line naming the file.

    ``skip_sim``: the simulation layer may be missing or damaged (``simulate`` replaces it, ``estimate``
    never reads it). Returns the root layer's path.
    """
    p = shot_file(shot_path)
    if not p.is_file():
        raise InputError(f"no shot at {p}: run `physomni-usd build PHOTO -o DIR` first")
    root = check_layer(p)
    for sub in root.subLayerPaths:
        layer_path = pathlib.Path(sub) if os.path.isabs(sub) else (p.parent / sub)
        if skip_sim and layer_path.name == SIM:
            continue
        if not layer_path.is_file():
            hint = _MISSING_HINT.get(layer_path.name, "build the shot again")
            raise InputError(f"{layer_path} is missing (a sublayer of {p.name}): {hint}")
        check_layer(layer_path)
    return p


def open_shot(shot_path: os.PathLike | str, *, mute_sim: bool = False, mute_edits: bool = False) -> Usd.Stage:
    """Open a shot's composed stage; with ``mute_sim`` the old simulation layer is left out (and may be
    missing or damaged); with ``mute_edits`` the artist's edits layer is muted too (the build's own layers
    alone, as the build's settle measures them).

    Raises :class:`InputError` with one line when the root or a sublayer is missing or is no readable
    USD layer; USD's own diagnostics about it are kept off the terminal.
    """
    from pxr import Tf

    read_again(shot_folder(shot_path), skip=(SIM,) if mute_sim else ())
    p = check_shot_layers(shot_path, skip_sim=mute_sim)
    sim = str((p.parent / SIM).resolve())
    with contextlib.ExitStack() as scope:
        # USD reports a sublayer it cannot load as warnings on stderr; we say it in one line instead
        trap = scope.enter_context(Tf.DiagnosticTrap()) if hasattr(Tf, "DiagnosticTrap") else None
        if mute_sim and not _readable(p.parent / SIM):
            # compose without it at all: a muted layer that failed to load stays a composition error
            stage = Usd.Stage.Open(_root_without(p, SIM), Usd.Stage.LoadAll)
        else:
            stage = Usd.Stage.Open(str(p), Usd.Stage.LoadAll)
        if trap is not None:
            def about_layers(d):
                said = str(d.commentary).lower()
                return "sublayer" in said or "could not open" in said or "cycle" in said

            problems = [str(d.commentary) for d in trap.GetWarnings() if about_layers(d)]
            if mute_sim:
                problems = [m for m in problems if sim not in m and SIM not in m]
            refusal = (composition_refusal(p, stage, skip=(sim, SIM) if mute_sim else ()) if stage is not None
                       else None)
            if refusal is not None:
                trap.Clear()
                raise InputError(refusal)
            if problems:
                trap.Clear()
                raise InputError(f"{p.name}: {problems[0].split(' -- ')[0].split('; skipping')[0]}")
            trap.EraseMatching(about_layers)
        elif stage is not None and (refusal := composition_refusal(p, stage, skip=(sim, SIM) if mute_sim else ())):
            raise InputError(refusal)
    if stage is None:
        raise InputError(f"{p} is not a readable USD stage")
    if mute_sim:
        for layer in stage.GetLayerStack(includeSessionLayers=False):
            if layer.realPath and str(pathlib.Path(layer.realPath).resolve()) == sim:
                stage.MuteLayer(layer.identifier)
    if mute_edits:
        edits = str((p.parent / EDITS).resolve())
        for layer in stage.GetLayerStack(includeSessionLayers=False):
            if layer.realPath and str(pathlib.Path(layer.realPath).resolve()) == edits:
                stage.MuteLayer(layer.identifier)
    if not stage.GetPrimAtPath("/World"):
        raise InputError(f"{p} has no /World prim: it is not a physomni-usd shot")
    return stage


def composition_refusal(root: pathlib.Path, stage: Usd.Stage, skip=()) -> str | None:
    """One line naming the file when ``stage`` could not be composed as its layers say (a sublayer cycle, a
    missing or unreadable sublayer, reference or payload), else None. Errors naming any of ``skip`` (the
    muted simulation layer) do not count. Such a shot is bad input (exit 2) in every command: composed
    without the layer, it would be simulated or rendered as something it does not say."""
    import re

    from pxr import Pcp

    for err in stage.GetCompositionErrors():
        text = " ".join(str(err).split())
        if any(s and s in text for s in skip):
            continue
        named = re.findall(r"@([^@]+)@", text)
        if err.errorType == Pcp.ErrorType_SublayerCycle and named:
            return (f"{named[-1]}: its subLayers lead back to itself (a cycle), so {root} cannot be composed; "
                    "remove the sublayer that closes the cycle")
        if err.errorType == Pcp.ErrorType_InvalidSublayerPath and len(named) >= 2:
            return (f"{named[1]}: its sublayer {named[0]} is missing or not a readable USD layer, so {root} "
                    "cannot be composed")
        return f"{root} cannot be composed: {text.split(' -- ')[0].split('; skipping')[0]}"
    return None


def content_digest(stage: Usd.Stage) -> str:
    """A digest of everything ``stage`` is composed of: the text of each layer it uses (anonymous ones by
    text alone, their names being new each time) and which layers are muted, with the root layer's frame
    range left out (a run's length, which ``simulate`` writes there, composes nothing). Two stages with the
    same digest compose alike; reading layer by layer costs a fifth of flattening the stage."""
    root = stage.GetRootLayer()
    parts = []
    for layer in stage.GetUsedLayers():
        if layer == root:
            copy = Sdf.Layer.CreateAnonymous(".usda")
            copy.TransferContent(layer)
            copy.startTimeCode = copy.endTimeCode = 0.0
            layer_text = copy.ExportToString()
        else:
            layer_text = layer.ExportToString()
        name = "anonymous" if layer.anonymous else layer.identifier
        parts.append(f"{name}\n{hashlib.sha256(layer_text.encode()).hexdigest()}")
    parts += [f"muted {m}" for m in stage.GetMutedLayers()]
    return hashlib.sha256("\n".join(sorted(parts)).encode()).hexdigest()


def _readable(path: pathlib.Path) -> bool:
    try:
        return path.is_file() and Sdf.Layer.FindOrOpen(str(path)) is not None
    except Exception:  # Tf.ErrorException: damaged
        return False


def _root_without(root_path: pathlib.Path, name: str) -> Sdf.Layer:
    """An in-memory copy of a root layer without the sublayer ``name`` (its other sublayers made absolute)."""
    root = Sdf.Layer.FindOrOpen(str(root_path))
    copy = Sdf.Layer.CreateAnonymous(".usda")
    copy.TransferContent(root)
    folder = root_path.resolve().parent
    copy.subLayerPaths[:] = [str(folder / sub) if not os.path.isabs(sub) else sub
                             for sub in root.subLayerPaths if pathlib.Path(sub).name != name]
    return copy


def _unreadable(path: pathlib.Path, exc: Exception) -> str:
    """One line for USD's parse error ``exc`` about the layer at ``path``: the file, line and column."""
    import re

    text = " ".join(str(exc).split())
    where = re.search(r"\.usd[ac]?:(\d+):(\d+): (.*?)(?: in <[^>]*>)?'?\s*$", text)
    detail = f" (line {where.group(1)}, column {where.group(2)}: {where.group(3)})" if where else ""
    if not detail and ("corrupt" in text or "truncated" in text):
        detail = " (the file is damaged or truncated)"
    return f"{path} is not a valid USD layer{detail}"


def check_layer(path: pathlib.Path) -> Sdf.Layer:
    """Open one layer file and turn USD's parse errors into one line with the file, line and column."""
    from pxr import Tf

    try:
        layer = Sdf.Layer.FindOrOpen(str(path))
    except Tf.ErrorException as exc:
        raise InputError(_unreadable(path, exc)) from None
    if layer is None:
        raise InputError(f"{path} is not a valid USD layer")
    return layer


def set_shot_time(folder: pathlib.Path, fps: float, frames: int) -> pathlib.Path:
    """Set the root layer's frame rate and frame range, keeping everything else in it."""
    path = pathlib.Path(folder) / SHOT
    read_again(folder, only=(SHOT,))  # what is in the file now is kept, not what a preview read at its start
    layer = Sdf.Layer.FindOrOpen(str(path))
    copy = Sdf.Layer.CreateAnonymous(".usda")
    copy.TransferContent(layer)
    copy.timeCodesPerSecond = float(fps)
    copy.framesPerSecond = float(fps)
    copy.startTimeCode = 0.0
    copy.endTimeCode = float(max(frames - 1, 0))
    return save_layer(copy, path)


def shot_seconds(shot_path: os.PathLike | str) -> float | None:
    """The shot's own length in seconds (its frame range over its time codes per second), or None when
    its root layer has no frame range yet (a shot built but never simulated)."""
    root = check_layer(shot_file(shot_path))
    if not root.HasEndTimeCode():
        return None
    rate = root.timeCodesPerSecond if root.HasTimeCodesPerSecond() else 24.0
    return max(root.endTimeCode - (root.startTimeCode if root.HasStartTimeCode() else 0.0), 0.0) / rate


def transform_may_vary(prim: Usd.Prim) -> bool:
    """Whether ``prim``'s world transform may change over time: its own or an ancestor's ops are animated."""
    while prim and not prim.IsPseudoRoot():
        if prim.IsA(UsdGeom.Xformable) and UsdGeom.Xformable(prim).TransformMightBeTimeVarying():
            return True
        prim = prim.GetParent()
    return False
