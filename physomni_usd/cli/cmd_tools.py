"""``validate`` (a stage against every USD validator and our contract), ``plugins`` (every backend and its
state) and ``rerender`` (the rendered frames through a video model)."""

from __future__ import annotations

import pathlib
import sys

import click

from ..rerender import LIMITS as RERENDER_LIMITS
from .options import limit_option, quiet_option
from .shell import errors, progress


@click.command()
@click.argument("stage", type=click.Path(path_type=pathlib.Path))
@click.option("--warnings/--no-warnings", default=True, show_default=True, help="Also print warnings.")
def validate(stage, warnings):
    """Check a stage with every pxr.UsdValidation validator and our USD contract.

    Prints one finding per line; exits 1 if any is an error.
    """
    with errors():
        from ..validate import validate_stage

        findings = validate_stage(stage)
        failed = [f for f in findings if f.severity == "error"]
        for f in findings:
            if f.severity == "error" or warnings:
                click.echo(str(f))
        click.echo(f"{stage}: {len(failed)} error(s), {len(findings) - len(failed)} warning(s)", err=True)
        if failed:
            sys.exit(1)


@click.command("plugins")
def plugins_command():
    """List every backend by kind: built in or from a plugin, its package and version, and its state.

    \b
    States: "ready" — it runs here as it is (modules installed, weights found);
    "needs setting up" — it runs once the variables or options named are given
    (the vlm estimator without a server); "not ready" — what to install or set.

    \b
    Plugins are packages that register under the entry-point group physomni_usd.backends; install one
    and point it at its weights, e.g.
      pip install -e plugins/physomni-lama && export PHYSOMNI_LAMA_WEIGHTS=/models/big-lama.pt
      physomni-usd build photo.png -o shot/ --box 120,40,380,300:box --inpainter lama
    """
    with errors():
        from ..errors import redact
        from ..swappable import registry

        entries = registry.entries()
        for kind in registry.KINDS:
            click.echo(f"{kind}:")
            found = [e for e in entries if e.kind == kind]
            if not found:
                hint = registry.SUGGESTED.get(kind)
                click.echo("  (none installed" + (f"; plugin: {hint})" if hint else ")"))
            for e in found:
                ready, note = registry.status(e)
                default = " (default)" if registry.DEFAULTS.get(kind) == e.name else ""
                origin = "built-in" if e.builtin else "plugin"
                # a backend that can run but waits for a setting (a server's address) is not "ready"
                state = "not ready" if not ready else ("needs setting up" if note.startswith("needs ") else "ready")
                note = note[len("needs "):] if state == "needs setting up" else note
                click.echo(redact(f"  {e.name}{default}: {origin}, {e.package} {e.version}, {state}"
                           + (f": {note}" if note else "")))


@click.command()
@click.argument("shot", type=click.Path(path_type=pathlib.Path))
@click.option("--model", default=None, metavar="NAME",
              help="Re-renderer backend, e.g. wan-vace (plugin physomni-wan) [default: the one installed].")
@limit_option(RERENDER_LIMITS, "strength")
@limit_option(RERENDER_LIMITS, "steps")
@click.option("--prompt", default=None, help="Text prompt [default: made from the objects' labels].")
@limit_option(RERENDER_LIMITS, "seed")
@limit_option(RERENDER_LIMITS, "max_size")
@click.option("-o", "--output", type=click.Path(path_type=pathlib.Path), default=None,
              help="Video file (.mp4) [default: rerender.mp4 beside the shot].")
@quiet_option
def rerender(shot, model, strength, steps, prompt, seed, max_size, output, quiet):
    """Render the shot, then re-render its frames with a video model, the photo as reference.

    The renderer's control passes of each frame (depth, object ids, forward motion; see render --passes) go
    to the model with the frames; the objects' pixels are its masks. Needs a re-renderer plugin; without one
    this says which to install and exits 2.

    \b
    Example (Wan VACE; weights: a diffusers WanVACEPipeline folder):
      pip install -e plugins/physomni-wan && export PHYSOMNI_WAN_WEIGHTS=/models/Wan2.1-VACE-1.3B-diffusers
      physomni-usd rerender shot/shot.usda --model wan-vace --strength 0.5 --steps 20 -o shot/wan.mp4
    """
    with errors():
        from ..rerender import rerender_shot

        with progress("render  ", not quiet) as bar:
            section = rerender_shot(shot, model, strength, steps, output, prompt, seed, max_size, progress=bar)
        if not quiet:
            click.echo(f"rerender: {section['video']} ({section['frames']} frames, "
                       f"{section['width']}×{section['height']}, {section['seconds']['model']:.1f} s in the model)",
                       err=True)
