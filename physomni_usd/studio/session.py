"""What the set-up page does, as plain functions over its state: the mask of one object as build will cut
it, the command lines that replay the page, ``studio.json``, and build and render through the public API.

The state is a dict (what ``studio.json`` holds)::

    {"photo": "/abs/photo.png", "output": "/abs/shot", "segmenter": "grabcut",
     "objects": [{"label": "cup", "box": [x0, y0, x1, y1], "clicks": [[x, y, true], ...]}, ...],
     "pushes": [{"object": 0, "velocity": [vx, vy, vz], "at": [x, y]}],  # m/s, world axes (Z up, +Y away);
                                                                       # at: where the arrow starts, pixels
     "force": "wind:direction=1,0,0,strength=5" | null,
     "camera": "static" | "orbit-left" | ...,
     "seconds": 3.0 | null}                                    # the video's length; null: the shot's own

Pixels are the photo's (x right, y down); a box's x1, y1 are exclusive, as ``--box`` has them.
"""

from __future__ import annotations

import json
import pathlib
import shlex

import numpy as np

from .._files import write_bytes
from ..errors import InputError
from ..fields import FIELD_KINDS

#: Written beside the shot: the page's state, and the command lines that replay it.
STATE_FILE = "studio.json"
COMMANDS_FILE = "studio.sh"
#: The force fields the page offers, one preset each (every value can be edited in the page's text box).
FORCE_PRESETS = {k.name: f"{k.name}:{k.preset}" for k in FIELD_KINDS}
#: The video's length when neither the page nor the shot states one: what ``simulate`` takes then.
RENDER_SECONDS = 3.0


def empty_state(photo, output, segmenter: str = "grabcut") -> dict:
    return {"photo": str(pathlib.Path(photo).resolve()), "output": str(pathlib.Path(output).resolve()),
            "segmenter": segmenter, "objects": [], "pushes": [], "force": None, "camera": "static", "seconds": None}


def render_seconds(state: dict) -> float:
    """The length Render simulates and the page shows: the page's field where set, else the shot's own
    length (its last simulation), else ``RENDER_SECONDS`` (what ``simulate`` takes for a shot never
    simulated)."""
    from ..usd import layers

    if state.get("seconds"):
        return float(state["seconds"])
    shot = pathlib.Path(state["output"]) / "shot.usda"
    return (layers.shot_seconds(shot) if shot.is_file() else None) or RENDER_SECONDS


def check_seconds(value) -> float | None:
    """The page's length field as simulate --seconds takes it; None for an empty field."""
    import math

    if value is None or value == "":
        return None
    try:
        seconds = float(value)
    except (TypeError, ValueError):
        raise InputError(f"video length {value!r}: a number of seconds") from None
    if not (math.isfinite(seconds) and 0 < seconds <= 600):
        raise InputError(f"video length {value!r}: more than 0 and at most 600 seconds")
    return seconds


def box_specs(state: dict) -> list[str]:
    """The ``--box`` spec of each object of ``state``, in order."""
    from ..perceive.masks import box_spec

    return [box_spec(o["box"], o.get("label") or None, [tuple(c) for c in o.get("clicks", ())])
            for o in state["objects"]]


def prim_names(state: dict) -> list[str]:
    """The prim name build gives each object (``cup_0``): the label as an identifier, then its index."""
    from ..perceive.masks import identifier

    return [f"{identifier(o.get('label') or f'object{i}')}_{i}" for i, o in enumerate(state["objects"])]


def push_specs(state: dict) -> list[str]:
    """``--push`` specs: by label where only that object has it, else by prim name."""
    labels = [o.get("label") or f"object{i}" for i, o in enumerate(state["objects"])]
    names = prim_names(state)
    out = []
    for p in state.get("pushes", ()):
        i = int(p["object"])
        if not 0 <= i < len(labels):
            raise InputError(f"push on object {i}: the page has {len(labels)} objects")
        who = labels[i] if labels.count(labels[i]) == 1 else names[i]
        out.append(f"{who}=" + ",".join(f"{float(v):.3g}" for v in p["velocity"]))
    return out


def commands(state: dict, take: dict | None = None) -> dict[str, list[str]]:
    """The command lines (argv, without the program) that do what the page did: build, simulate, render;
    with a ``take`` kept in the preview, no simulate (it would write over the take in ``sim.usdc``)."""
    out = state["output"]
    shot = str(pathlib.Path(out) / "shot.usda")
    build = ["build", state["photo"], "-o", out]
    for spec in box_specs(state):
        build += ["--box", spec]
    for spec in push_specs(state):
        build += ["--push", spec]
    if state.get("force"):
        build += ["--force", state["force"]]
    if state.get("segmenter") and state["segmenter"] != "grabcut":
        build += ["--segmenter", state["segmenter"]]
    render = ["render", shot] + (["--camera", state["camera"]] if state.get("camera") else [])
    if take is not None:
        return {"build": build, "render": render}
    return {"build": build, "simulate": ["simulate", shot, "--seconds", f"{render_seconds(state):g}"],
            "render": render}


def command_text(state: dict, take: dict | None = None) -> str:
    """``studio.sh``: the command lines, one a line, quoted for a POSIX shell. With a ``take`` kept in the
    preview the build line is a comment, since build writes an empty ``sim.usdc`` and the take with it would
    go: what the script runs is the render of the take on disk."""
    c = commands(state, take)
    lines = ["# physomni-usd studio: the set-up page's work as commands (run from the folder it was run in)"]
    if take is None:
        lines += ["physomni-usd " + shlex.join(c["build"]),
                  "# the video, as the page's Render made it: simulate the length it showed, then render",
                  "physomni-usd " + shlex.join(c["simulate"])]
    else:
        lines += ["# the shot was built by (not run here: it would empty sim.usdc, where the kept take is):",
                  "# physomni-usd " + shlex.join(c["build"]),
                  f"# the video, as the page's Render made it: the take kept in the live preview ({take['frames']} "
                  f"frames, {take['seconds']:.2f} s) in sim.usdc. What was done in the preview (drags, sliders) "
                  "cannot be replayed by commands: this renders that sim.usdc"]
    lines.append("physomni-usd " + shlex.join(c["render"]))
    return "\n".join(lines) + "\n"


def take_summary(take: dict | None) -> dict | None:
    """What ``studio.json`` says of a kept take: its frames and seconds."""
    return None if take is None else {"frames": take["frames"], "seconds": take["seconds"]}


def write_state(state: dict, take: dict | None = None) -> pathlib.Path:
    """``studio.json`` (the state, its command lines and the kept take if Render used one) and ``studio.sh``
    beside the shot; returns the JSON's path. Each file is written whole or not at all."""
    folder = pathlib.Path(state["output"])
    record = dict(state, commands=commands(state, take), take=take_summary(take))
    write_bytes(folder / STATE_FILE, (json.dumps(record, indent=2) + "\n").encode())
    write_bytes(folder / COMMANDS_FILE, command_text(state, take).encode())
    return folder / STATE_FILE


def read_state(path) -> dict:
    """A ``studio.json`` as the state it was written from (its command lines left out)."""
    data = json.loads(pathlib.Path(path).read_text())
    data.pop("commands", None)
    data.pop("take", None)  # a take is the preview's, not the page's: a new studio starts without one
    return data


def object_mask(photo: np.ndarray, obj: dict, index: int, segmenter) -> dict:
    """The mask build makes of one object of the page: ``{"mask": (H, W) bool, "pixels": int,
    "warning": str | None, "spec": the --box spec}``; the same call build makes, so what the page shows is
    what build gets. Bad boxes and clicks raise :class:`InputError` with build's own message."""
    from ..backends.steps import collect_objects
    from ..perceive.masks import box_spec

    spec = box_spec(obj["box"], obj.get("label") or None, [tuple(c) for c in obj.get("clicks", ())])
    found = collect_objects(photo, (), [spec], segmenter)[0]
    warning = (found.quality or {}).get("warning")
    return {"mask": found.mask, "pixels": int(found.mask.sum()), "warning": warning, "spec": spec}


def build(state: dict, echo=lambda m: None):
    """Build the shot the page describes (``physomni_usd.build``); writes ``studio.json`` and ``studio.sh``
    once the build has succeeded. Returns the build result."""
    import physomni_usd

    if not state["objects"]:
        raise InputError("no objects yet: drag a box around an object first")
    c = commands(state)
    result = physomni_usd.build(state["photo"], state["output"], (), box_specs(state), None,
                                pushes=push_specs(state), forces=[state["force"]] if state.get("force") else (),
                                backends={"segmenter": state.get("segmenter") or None}, echo=echo)
    write_state(state)
    echo("studio: physomni-usd " + shlex.join(c["build"]))
    return result


def push_key(pushes) -> list:
    """Pushes as ``[[object, [vx, vy, vz]], ...]`` in object order: what a kept take is compared by (where an
    arrow was drawn does not change what is simulated)."""
    return sorted([int(p["object"]), [float(v) for v in p["velocity"]]] for p in pushes or ())


def take_on_disk(state: dict, take: dict) -> str | None:
    """Why ``sim.usdc`` is no longer the kept ``take`` (another simulate wrote it), or None when it is."""
    from pxr import Sdf

    from ..usd import layers

    path = pathlib.Path(state["output"]) / layers.SIM
    layer = Sdf.Layer.FindOrOpen(str(path)) if path.is_file() else None
    if layer is None:
        return f"{path} is gone"
    layer.Reload()  # the preview wrote it after any earlier open in this process
    source = layer.customLayerData.get("physomni:source")
    frames = int(round(layer.endTimeCode - layer.startTimeCode)) + 1 if layer.HasEndTimeCode() else 0
    if source != "preview" or frames != take["frames"]:
        return f"{path} now holds {frames} frames written by {source or 'simulate'}"
    return None


def render(state: dict, max_size: int = 960, echo=lambda m: None, progress=None, take: dict | None = None) -> dict:
    """The video of the shot with the page's camera move, as ``studio.sh`` makes it: simulate the stated
    length (:func:`render_seconds`), then render; never whatever a preview happened to step, unless the user
    kept it: with a ``take`` (its ``sim.usdc`` checked by :func:`take_on_disk`) it renders that, unsimulated.
    ``progress`` is called ``(stage, done, total)`` per simulated and rendered frame. Returns the report's
    render section."""
    import physomni_usd
    from ..settings import RenderSettings, SimulateSettings

    shot = pathlib.Path(state["output"]) / "shot.usda"
    if not shot.is_file():
        raise InputError("nothing to render yet: press Build first")
    report = progress or (lambda stage, done, total: None)
    write_state(state, take)  # studio.sh says what is being made before the minutes it takes
    if take is None:
        physomni_usd.simulate(shot, SimulateSettings(seconds=render_seconds(state)), echo=echo,
                              progress=lambda done, total: report("simulate", done, total))
    camera = state.get("camera") or None
    section = physomni_usd.render(shot, None, RenderSettings(max_size=max_size), camera=camera,
                                  progress=lambda done, total: report("render", done, total))
    write_state(state, take)
    return section
