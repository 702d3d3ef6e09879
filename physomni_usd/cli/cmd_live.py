"""The commands that serve a page: ``preview`` (a shot simulated live in the browser) and ``studio`` (a shot
set up on its photo)."""

from __future__ import annotations

import pathlib

import click

from ..preview.limits import PREVIEW as PREVIEW_LIMITS, STUDIO as STUDIO_LIMITS
from .options import limit_option
from .shell import errors


@click.command()
@click.argument("shot", type=click.Path(path_type=pathlib.Path))
@click.option("--host", default="127.0.0.1", show_default=True, help="Address to serve the page on.")
@limit_option(PREVIEW_LIMITS, "port")
@limit_option(PREVIEW_LIMITS, "duration", metavar="SECONDS")
@click.option("--record", is_flag=True, help="On exit, write the take since the last reset to sim.usdc.")
@click.option("--open/--no-open", "open_browser", default=None,
              help="Open the page in a web browser [default: where one is available].")
@click.option("-o", "--output", "out_dir", default=None, type=click.Path(path_type=pathlib.Path),
              help="Given a photo instead of a shot: the folder the set-up page (`studio`) builds the shot into.")
@click.option("--play", is_flag=True,
              help="Start the simulation at once [default: the page opens paused on frame 0, the photo, "
                   "until Play or a drag on an object].")
def preview(shot, host, port, duration, record, open_browser, out_dir, play):
    """Simulate the composed shot live in the browser: push objects with the mouse, change fields,
    materials and gravity from the panel, keep the take (sim.usdc) or the settings (edits.usda).

    \b
    In the page: a left-drag that starts on an object pulls it toward the cursor (a spring-damper);
    a drag on empty space orbits the view and "Photo view" brings back the photo's camera. "Save take"
    writes the motion since the last reset to sim.usdc as `simulate` would; "Keep settings" adds the
    changed parameters to edits.usda, keeping everything already there. Nothing is written unless asked.
    The rate (frames a second) is printed on stderr every few seconds and shown on the page.

    \b
    Examples:
      physomni-usd preview shot/shot.usda
      physomni-usd preview shot/shot.usda --port 8090 --duration 20 --record
      physomni-usd preview photo.png -o shot/     (a photo: the set-up page, as `studio`)

    \b
    Limits: rigid bodies are pulled by the mouse; cloth, soft bodies and MPM materials move live but
    are not grabbed. A take keeps at most 3600 frames.
    """
    with errors():
        from ..preview.app import Options
        from ..studio import preview_or_set_up

        options = Options(host=host, port=port, duration=duration, record=record, open_browser=open_browser,
                          play=play)
        result = preview_or_set_up(shot, options, out_dir)  # a photo: set up on the studio's page first
        if result is not None:
            click.echo(f"preview: stopped after {result['frames']} frames", err=True)


@click.command()
@click.argument("photo", type=click.Path(dir_okay=False, path_type=pathlib.Path))
@click.option("-o", "--output", "out_dir", required=True, type=click.Path(path_type=pathlib.Path),
              help="Shot folder the page builds into (created at the first Build).")
@click.option("--host", default="127.0.0.1", show_default=True,
              help="Address to serve the page on. On any but a loopback address the printed URL carries a "
                   "per-run token, without which every request is refused.")
@limit_option(STUDIO_LIMITS, "port")
@click.option("--segmenter", default="grabcut", show_default=True, metavar="NAME",
              help="What cuts the masks as you pick (see `physomni-usd plugins`; sam takes clicks natively).")
@limit_option(STUDIO_LIMITS, "duration", metavar="SECONDS")
@click.option("--open/--no-open", "open_browser", default=None,
              help="Open the page in a web browser [default: where one is available].")
def studio(photo, out_dir, host, port, segmenter, duration, open_browser):
    """Set up a shot in the browser: pick objects on the photo, push them, build, preview and render.

    \b
    In the page: drag a box around an object and type its label; its mask shows at once (GrabCut, or
    the segmenter chosen). "Click on object (+)" and "Click off object (−)" correct the selected mask;
    ↑ ↓ reorder and ✕ deletes. "Push arrow": drag from an object's mask (where masks overlap, the
    smallest object's); a quarter of the photo's width is 1 m/s, right is +X, up is +Y (away from the
    camera); each push shows on its object and in the list, where it is edited or removed alone.
    Choose a force field and a camera move from the lists. "Build" builds the shot and shows its live
    preview, paused on frame 0; "Render" simulates the video length the page shows (default: the
    shot's own, 3 s for a shot never simulated), writes video.mp4 and shows it. Each stage and frame
    shows in the page as it happens.

    \b
    Everything is written beside the shot: studio.json (what the page holds, and its command lines)
    and studio.sh (the same as `physomni-usd build ... --box X0,Y0,X1,Y1:LABEL:+X,Y:-X,Y ...`), so a
    TD can batch what was set up here. Opening the page again on the same folder resumes it.
    Only the page itself can drive the studio: a request from another site's page, or by another
    name than a loopback one (or, served beyond loopback with --host, without its token), is refused.

    \b
    Example:
      physomni-usd studio photo.png -o shot/
    """
    with errors():
        from ..studio import Options, Studio

        page = Studio(photo, out_dir, Options(host=host, port=port, duration=duration, open_browser=open_browser),
                      segmenter=segmenter)
        page.start()
        page.wait()
        click.echo("studio: stopped", err=True)
