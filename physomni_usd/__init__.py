"""physomni-usd: one photograph to a physically simulated, layered USD shot.

Importing the package registers the PhysOmni USD schema with OpenUSD. Nothing
heavy (warp, Newton, torch) is imported here; each stage imports what it needs
when it runs.

The public API is one function per stage, paths in and the stage's section of
``report.json`` out: :func:`build`, :func:`estimate`, :func:`simulate`,
:func:`render`. Bad input raises :class:`physomni_usd.errors.InputError` with
one line naming the option or file; nothing the user made is overwritten then.
"""

import sys
import types

from ._version import __version__
from .usd.schema import register_schema

register_schema()


class _Package(types.ModuleType):
    """The package, keeping :func:`build` and :func:`render` under their names: importing the submodules
    ``physomni_usd.build`` and ``physomni_usd.render`` would otherwise set those attributes to the modules
    (the import system binds each submodule on its parent). The modules stay in ``sys.modules``."""

    def __setattr__(self, name, value):
        if name in ("build", "render") and isinstance(value, types.ModuleType) and name in self.__dict__:
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package


def build(photo, out_dir, masks=(), boxes=(), settings=None, **options):
    """Build a shot from ``photo`` (a path) into ``out_dir``: plate, textures, ``scene.usda``, ``physics.usda``
    and an empty ``edits.usda``. ``masks`` are ``PATH[=LABEL]`` specs, ``boxes`` ``x0,y0,x1,y1[=LABEL]`` in
    pixels; ``settings`` a :class:`physomni_usd.settings.BuildSettings` (defaults when None); ``options`` as
    :func:`physomni_usd.build.build_shot` takes them (pushes, forces, fixed, meshes_dir, sizes, backends, echo).
    Returns the build result; its ``shot`` is the path of ``shot.usda``."""
    from .build import build_shot
    from .settings import BuildSettings

    return build_shot(photo, out_dir, masks, boxes, settings or BuildSettings(), **options)


def estimate(shot, estimator: str = "rules", vlm=None, sets=(), forces=(), echo=lambda m: None) -> dict:
    """Estimate the materials of ``shot`` (``shot.usda`` or its folder) with ``estimator`` (``rules`` or a
    VLM), then apply ``sets`` (``NAME.KEY=VALUE``, written to ``edits.usda``) and ``forces``
    (``KIND:key=value,...``). Rewrites ``physics.usda``; returns the report's ``estimate`` section."""
    from .materials.estimate import estimate_shot

    return estimate_shot(shot, estimator, vlm, sets, forces, echo=echo)


def simulate(shot, settings=None, progress=None, echo=lambda m: None) -> dict:
    """Simulate the composed stage of ``shot`` and write ``sim.usdc`` beside it; ``settings`` a
    :class:`physomni_usd.settings.SimulateSettings` (seconds, fps, substeps; defaults when None). Returns the
    report's ``simulate`` section. A rigid-only shot imports no torch."""
    from .physics.simulate import simulate_shot
    from .settings import SimulateSettings

    return simulate_shot(shot, settings or SimulateSettings(), progress=progress, echo=echo)


def render(shot, output=None, settings=None, progress=None, **options) -> dict:
    """Render every frame of ``shot`` to ``output`` (default ``video.mp4`` beside it); ``settings`` a
    :class:`physomni_usd.settings.RenderSettings` (defaults when None); ``options``: ``passes``,
    ``passes_dir``, ``camera`` (a move of :data:`physomni_usd.render.moves.MOVES`) and ``camera_amount``.
    Returns the report's ``render`` section."""
    from .render.video import render_shot
    from .settings import RenderSettings

    return render_shot(shot, output, settings or RenderSettings(), progress=progress, **options)


__all__ = ["__version__", "register_schema", "build", "estimate", "simulate", "render"]
