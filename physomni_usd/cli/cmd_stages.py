"""The stage commands: ``build``, ``estimate``, ``simulate`` and ``render``. Each parses its options, calls
the public API (:mod:`physomni_usd`), which owns every default, limit and check, and shows what it did."""

from __future__ import annotations

import pathlib

import click

from .._files import all_or_nothing
from ..materials.vlm import LIMITS as VLM_LIMITS
from .options import (RENDER, SIMULATE, backend_options, backends, build_options, build_settings, camera_options,
                      limit_option, output_folder_option, push_option, quiet_option)
from .shell import errors, progress, said, say, shot_lock

EPILOG_BUILD = """
\b
Examples:
  physomni-usd build photo.png -o shot/ --mask cup.png:cup --mask saucer.png
  physomni-usd build photo.png -o shot/ --box 120,40,380,300:box --fov 60
  physomni-usd build photo.png -o shot/ --box 120,40,380,300:cup:-130,60   (a click off the cup)
  physomni-usd build photo.png -o shot/ --find "cup, saucer, spoon"        (needs physomni-sam3)
"""



@click.command(epilog=EPILOG_BUILD)
@click.argument("photo", type=click.Path(dir_okay=False, path_type=pathlib.Path))
@output_folder_option
@build_options
@backend_options
@push_option
@quiet_option
def build(photo, out_dir, quiet, **params):
    """Photo → scene.usda, physics.usda and the root shot.usda (perceive, align, estimate)."""
    with errors():
        import physomni_usd

        chosen = backends(params)
        settings = build_settings(params)
        result = physomni_usd.build(photo, out_dir, params.pop("masks"), params.pop("boxes"), settings,
                                    echo=say(quiet), backends=chosen, **params)
        if not quiet:
            total = sum(result.seconds.values())
            click.echo(f"wrote {result.shot} ({len(result.objects)} objects, {total:.2f} s)", err=True)


@click.command()
@click.argument("shot", type=click.Path(path_type=pathlib.Path))
@click.option("--estimator", default="rules", show_default=True, metavar="NAME",
              help="rules: label keywords (built in). vlm: ask an OpenAI-compatible vision-language model. "
                   "Plugins add more (see `physomni-usd plugins`).")
@click.option("--vlm-url", envvar="PHYSOMNI_VLM_URL", default=None,
              help="API root of the VLM server, e.g. http://localhost:8000/v1 [env: PHYSOMNI_VLM_URL].")
@click.option("--vlm-model", envvar="PHYSOMNI_VLM_MODEL", default=None,
              help="Model name on that server [env: PHYSOMNI_VLM_MODEL].")
@click.option("--vlm-api-key", envvar="PHYSOMNI_VLM_API_KEY", default=None,
              help="Bearer token, if the server wants one [env: PHYSOMNI_VLM_API_KEY].")
@limit_option(VLM_LIMITS, "timeout_s")
@click.option("--set", "sets", multiple=True, metavar="NAME.KEY=VALUE",
              help="Your value for an object's material (KEY 'material') or parameter (density, friction, "
                   "youngs_modulus, poissons_ratio, …; each within its catalog range, which a refused value's "
                   "message states); written to edits.usda. NAME: a prim name (one object) or a label (every "
                   "object with it). Repeatable.")
@click.option("--force", "forces", multiple=True, metavar="KIND:key=value,...",
              help="Add a force field of yours (kept across later estimates). Repeatable.")
@quiet_option
def estimate(shot, estimator, vlm_url, vlm_model, vlm_api_key, timeout_s, sets, forces, quiet):
    """Estimate physical materials (and force fields) and write physics.usda; --set goes to edits.usda.

    The estimate is made from the photo that `build` keeps in the shot (inputs/photo.png). On a shot
    without one (assembled by a script) nothing is estimated: --set alone is applied and physics.usda kept.

    \b
    Examples:
      physomni-usd estimate shot/shot.usda --set cup.material=mpm_elastic --set cup.youngs_modulus=2e4
      physomni-usd estimate shot/shot.usda --estimator vlm --vlm-url http://localhost:8000/v1 \\
          --vlm-model Qwen2.5-VL-72B-Instruct
    """
    with errors():
        VLM_LIMITS.check(timeout_s=timeout_s)  # whichever estimator: the option's range is the range
    with errors(), all_or_nothing(), shot_lock(shot):
        import physomni_usd

        vlm = None
        if estimator == "vlm":
            from ..materials.vlm import VLMSettings

            vlm = VLMSettings.resolve(vlm_url, vlm_model, vlm_api_key, timeout_s=timeout_s)
        section = physomni_usd.estimate(shot, estimator, vlm, sets, forces, echo=say(quiet))
        if not quiet:
            for name, obj in section["objects"].items():
                params = ", ".join(f"{k}={v['value']:g}" if isinstance(v["value"], float) else f"{k}={v['value']}"
                                   for k, v in obj["params"].items())
                click.echo(f"{name}: {obj['material']} ({obj['source']}) {params}", err=True)



@click.command()
@click.argument("shot", type=click.Path(path_type=pathlib.Path))
@SIMULATE()
@quiet_option
def simulate(shot, quiet, **params):
    """Simulate the composed shot (edits.usda included) and write sim.usdc.

    Each object goes to its material's solver: rigid bodies, cloth (pbd_cloth) and soft bodies
    (pbd_elastic) on XPBD, sand, snow, liquids and elastic solids (mpm_*) on Newton's implicit MPM,
    coupled both ways. Steps come from the materials; a frame whose energy or speed runs away is
    redone at half the step. Newton's contacts use one friction coefficient, dynamic_friction: a
    static_friction unlike it does not act (said for values you set; report.json lists all).

    \b
    Example: make the box heavier and throw it, then simulate again:
      # in shot/edits.usda
      over "World" {
          over "Objects" {
              over "box_0" {
                  float physics:density = 2000
                  vector3f physics:velocity = (0, 2, 1)
              }
          }
      }
      physomni-usd simulate shot/shot.usda --seconds 4

    \b
    Turn the box to sand and simulate with coarser particles:
      physomni-usd estimate shot/shot.usda --set box.material=mpm_sand
      physomni-usd simulate shot/shot.usda --particle-spacing 0.03

    \b
    A quick preview of an elastic shot (4 MPM steps a frame instead of 16):
      physomni-usd simulate shot/shot.usda --mpm-steps 4
    """
    with errors(), all_or_nothing(), shot_lock(shot):
        import physomni_usd

        settings = SIMULATE.settings(params)
        with progress("simulate", not quiet) as bar:
            section = physomni_usd.simulate(shot, settings, progress=bar, echo=say(quiet))
        said("simulate", section, quiet)


@click.command()
@click.argument("shot", type=click.Path(path_type=pathlib.Path))
@click.option("-o", "--output", type=click.Path(path_type=pathlib.Path), default=None,
              help="Video file (.mp4) [default: video.mp4 beside the shot].")
@RENDER()
@quiet_option
@click.option("--passes", default=None, metavar="NAME,NAME,...",
              help="Also write control passes, exact from the stage: depth (channel Z, metres along the optical "
                   "axis), normal (N.X N.Y N.Z, world space), flow (motion.X motion.Y, pixels to the next frame, "
                   "+y down), mask (objectId, 0 = environment); or all. One float32 OpenEXR per frame, "
                   "passes.####.exr, plus passes.json (ids → prim paths) and a preview MP4 per pass.")
@click.option("--passes-dir", type=click.Path(path_type=pathlib.Path), default=None,
              help="Folder for the passes [default: passes/ beside the shot].")
@camera_options
@click.option("--still", is_flag=True,
              help="Render a shot that was never simulated: one frame, the photo's moment [default: refuse it].")
def render(shot, output, quiet, passes, passes_dir, camera, camera_amount, still, **params):
    """Render the composed shot over its background plate into an H.264 MP4.

    A camera move is written as time samples on /World/Camera in render.usda, below edits.usda: Blender or
    usdview play the same move, and keys an artist sets on the camera in edits.usda win over it.

    \b
    Examples:
      physomni-usd render shot/shot.usda
      physomni-usd render shot/shot.usda --camera orbit-left -o shot/orbit.mp4
      physomni-usd render shot/shot.usda --camera dolly-in --camera-amount 0.5
      physomni-usd render shot/shot.usda --passes depth,normal,flow,mask --passes-dir shot/passes
    """
    with errors():
        import physomni_usd
        from ..rendering.passes import parse_passes

        settings = RENDER.settings(params)
        with progress("render  ", not quiet) as bar:
            section = physomni_usd.render(shot, output, settings, progress=bar, passes=parse_passes(passes),
                                          passes_dir=passes_dir, camera=camera, camera_amount=camera_amount,
                                          still=still)
        said("render", section, quiet)
