"""Options declared once and shared by the commands that take them: the settings models' fields (each
field that carries a :class:`physomni_usd.settings.Option` is one option, its type, range, default and help
read from the field; a number outside them, from its owner's :class:`~physomni_usd.limits.Limits` table),
and the build's inputs, backends, pushes and camera moves (``build`` and ``run``,
``render`` and ``run``). Each group adds its options to a command and takes its values back out of the
command's parameters, so that ``run``, ``batch`` and the stage commands cannot drift apart."""

from __future__ import annotations

import functools
import pathlib
import typing

import click

from ..limits import Limits
from ..settings import BuildSettings, CameraSettings, LiftSettings, RenderSettings, SimulateSettings, option

PUSH_HELP = ("Give an object this velocity in m/s (each component at most 1000 in size) at T seconds "
             "(default 0, T ≥ 0); world axes: Z up, +Y away from the camera, +X to the image's right. A label "
             "shared by several objects pushes them all (and says which); a prim name (toy_1) pushes one. "
             "Repeatable.")


def limits(model, field: str) -> str:
    """The valid range of a settings field as help text, e.g. ``0 < value ≤ 600``, from its declaration."""
    lo = hi = ""
    for m in model.model_fields[field].metadata:
        for attr, fmt in (("gt", "{} <"), ("ge", "{} ≤")):
            if getattr(m, attr, None) is not None:
                lo = fmt.format(f"{getattr(m, attr):g}") + " "
        for attr, fmt in (("lt", "< {}"), ("le", "≤ {}")):
            if getattr(m, attr, None) is not None:
                hi = " " + fmt.format(f"{getattr(m, attr):g}")
    finite = ", finite" if "float" in str(model.model_fields[field].annotation) else ""
    return f"{lo}value{hi}{finite}" if (lo or hi) else ""


def _click_type(annotation):
    """The click type of a field's annotation: a choice of a Literal's values, else int, float or str."""
    if typing.get_origin(annotation) is typing.Literal:
        return click.Choice(list(typing.get_args(annotation)))
    args = [a for a in typing.get_args(annotation) if a is not type(None)] or [annotation]
    for kind in (int, float, str):
        if kind in args:
            return kind
    raise TypeError(f"no command-line type for {annotation}")


def limit_option(table: Limits, name: str, **kwargs):
    """The option of the number ``name`` of a function's :class:`~physomni_usd.limits.Limits` table: flag,
    default and help with its range, read from the table; the function itself refuses a value out of range."""
    found = table[name]
    text = found.text if found.default is not None else f"{found.text} [default: {found.default_text}]."
    return click.option(found.flag, name, type=int if found.whole else float, default=found.default,
                        show_default=found.default is not None,
                        help=f"{text} Range: {found.span()}." if found.span() else text, **kwargs)


class SettingsOptions:
    """The options of ``model``'s fields that carry an :class:`~physomni_usd.settings.Option`, in the
    model's order; a command's parameter is named as its field."""

    def __init__(self, model):
        self.model = model
        self.fields = [name for name in model.model_fields if option(model, name) is not None]

    def click_option(self, name: str, default_text: str | None = None):
        """The click option of field ``name``; ``default_text`` replaces the field's default in words."""
        found, info = option(self.model, name), self.model.model_fields[name]
        kind, span = _click_type(info.annotation), limits(self.model, name)
        if info.default is None:  # a choice made later, said in words
            text = f"{found.text} [default: {default_text or found.default}]."
            help_text = text + (f" Range: {span}{found.limit}." if span else "")
            return click.option(found.flag, name, type=kind, default=None, metavar=found.metavar, help=help_text)
        help_text = f"{found.text} Range: {span}{found.limit}." if span else found.text
        return click.option(found.flag, name, type=kind, default=info.default, show_default=True,
                            metavar=found.metavar, help=help_text)

    def __call__(self, skip=(), defaults=None):
        """A decorator adding the options (but those of ``skip``); ``defaults``: field → its default in
        words for this command, where it differs."""
        defaults = defaults or {}

        def add(f):
            for name in reversed([n for n in self.fields if n not in skip]):
                f = self.click_option(name, defaults.get(name))(f)
            return f

        return add

    def values(self, params: dict) -> dict:
        """The values given for this model's options, taken out of ``params``; None (not given) left out, so
        that the model's defaults stand."""
        taken = {name: params.pop(name) for name in self.fields if name in params}
        return {name: value for name, value in taken.items() if value is not None}

    def settings(self, params: dict):
        """The settings model of the values given, taken out of ``params`` (pydantic checks them)."""
        return self.model(**self.values(params))


CAMERA = SettingsOptions(CameraSettings)
LIFT = SettingsOptions(LiftSettings)
BUILD = SettingsOptions(BuildSettings)
SIMULATE = SettingsOptions(SimulateSettings)
RENDER = SettingsOptions(RenderSettings)


def build_settings(params: dict) -> BuildSettings:
    """The build's settings from a command's parameters (the camera's, the lift's and the build's own
    options, taken out of ``params``)."""
    camera, lift = CAMERA.values(params), LIFT.values(params)
    return BuildSettings(camera=CameraSettings(**camera), lift=LiftSettings(**lift), **BUILD.values(params))


def build_options(f):
    """What ``build`` and ``run`` take to build a shot: the objects (masks, boxes, phrases, meshes), the
    camera, sizes, shape, frame rate, fixed objects, force fields and the photo's size limit."""
    from ..fields import KINDS

    opts = [
        click.option("--mask", "masks", multiple=True, metavar="PNG[:LABEL]",
                     help="Object mask at the photo's resolution; non-zero pixels are the object. "
                          "Repeat per object; LABEL defaults to the file's name."),
        click.option("--box", "boxes", multiple=True, metavar="X0,Y0,X1,Y1[:LABEL][:±X,Y...]",
                     help="Pixel box around an object; the segmenter (OpenCV GrabCut by default) cuts its mask. "
                          "Clicks after it correct the mask: +X,Y a pixel on the object, -X,Y one off it "
                          "(e.g. 120,40,380,300:cup:-130,60). `physomni-usd studio` writes these for you. "
                          f"Repeatable; at most {BuildSettings().max_objects} objects, --mask and --box together."),
        click.option("--find", default=None, metavar="PHRASES",
                     help="Find every instance of each phrase with a text-promptable finder, e.g. "
                          "'cup, saucer, spoon'; each is labelled by its phrase and numbered after the masks "
                          "and boxes (cup_2, cup_3). Needs a finder plugin (physomni-sam3)."),
        click.option("--finder", default=None, metavar="NAME",
                     help="The finder --find uses [default: sam3]. See `physomni-usd plugins`."),
        click.option("--meshes", "meshes_dir", type=click.Path(file_okay=False, path_type=pathlib.Path),
                     default=None, help="Folder with one mesh per object (OBJ, GLB, PLY) and poses.json "
                                        "(label → mesh, rotation_wxyz, translation, scale in OpenCV camera "
                                        "coordinates); replaces silhouette lifting."),
        CAMERA(),
        click.option("--size", "sizes", multiple=True, metavar="LABEL=METRES",
                     help="An object's real longest dimension, e.g. 'coin=0.024'; fixes the scene's scale "
                          "(over --camera-height and the typical sizes). Repeatable."),
        LIFT(),
        BUILD(),
        click.option("--fix", "fixed", multiple=True, metavar="LABEL",
                     help="Keep this object where it is (it still collides); a label shared by several objects "
                          "fixes them all. Repeatable."),
        click.option("--force", "forces", multiple=True, metavar="KIND:key=value,...",
                     help=f"A force field ({', '.join(KINDS)}), e.g. "
                          "'wind:direction=1,0,0,strength=30'. Accelerations in m/s²; times in seconds. Repeatable."),
    ]
    for opt in reversed(opts):
        f = opt(f)
    return f


#: The swappable steps a build takes a backend for, and the help of each option.
BACKEND_HELP = {
    "segmenter": "How --box becomes a mask [default: grabcut; plugin: sam].",
    "inpainter": "What fills the objects' holes in the plate [default: builtin; plugin: lama].",
    "outpainter": "What extends the plate beyond the photo's frame for camera moves "
                  "[default: exemplar; built in: mirror].",
    "lifter": "How masks become meshes [default: silhouette; plugin: sam3d].",
    "depth": "A depth model whose ground plane sets the camera's pitch when --pitch is not given "
             "[default: none; plugin: depth-anything].",
    "estimator": "Materials from rules or a model [default: rules; built in: vlm, which reads "
                 "PHYSOMNI_VLM_URL and PHYSOMNI_VLM_MODEL]."}


def backend_options(f):
    """--segmenter/--inpainter/--outpainter/--lifter/--depth/--estimator, one option per kind."""
    for kind, text in reversed(BACKEND_HELP.items()):
        f = click.option(f"--{kind}", kind, default=None, metavar="NAME",
                         help=text + " See `physomni-usd plugins`.")(f)
    return f


def backends(params: dict) -> dict:
    """The backend options' values as one ``backends`` dict (kind → name or None), taken out of ``params``."""
    return {kind: params.pop(kind, None) for kind in BACKEND_HELP}


def push_option(f):
    return click.option("--push", "pushes", multiple=True, metavar="LABEL=VX,VY,VZ[@T]", help=PUSH_HELP)(f)


def quiet_option(f):
    return click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors.")(f)


def output_folder_option(f):
    return click.option("-o", "--output", "out_dir", required=True, type=click.Path(path_type=pathlib.Path),
                        help="Shot folder to write (created if missing).")(f)


@functools.lru_cache(maxsize=1)
def _camera_moves() -> tuple[str, ...]:
    from ..rendering.moves import MOVES

    return tuple(MOVES)


def camera_options(f):
    """--camera and --camera-amount: the camera move ``render`` writes and renders (``run`` too)."""
    from ..rendering.moves import LIMITS as MOVE_LIMITS

    f = limit_option(MOVE_LIMITS, "camera_amount")(f)
    return click.option(
        "--camera", type=click.Choice(list(_camera_moves())), default=None, metavar="MOVE",
        help="Write this camera move to the shot's render.usda, then render it: " + ", ".join(_camera_moves())
             + ". Defaults over the whole shot: orbits left/right 15°, up/down 10° about the objects' centre; "
               "truck 15 % and dolly 25 % of the distance to the objects; crane-down 30 % of the camera's "
               "height. static removes a move. [default: the camera the shot has]")(f)
