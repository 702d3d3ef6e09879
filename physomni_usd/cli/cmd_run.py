"""``run`` (build + simulate + render in one go) and ``batch`` (many ``run`` lines as Ray tasks). A shot list's
line is parsed by ``run``'s own parser (:func:`parse_run`) and becomes the keyword arguments of
:func:`physomni_usd.run` by the same function as the command's (:func:`run_call`): the options of the two
cannot drift apart."""

from __future__ import annotations

import pathlib
import sys
from contextlib import ExitStack, contextmanager

import click

from ..batch.runner import LIMITS as BATCH_LIMITS
from ..settings import DEFAULT_SECONDS
from .options import (RENDER, SIMULATE, backend_options, backends, build_options, build_settings, camera_options,
                      limit_option, output_folder_option, push_option, quiet_option)
from .shell import errors, progress, said, say

#: ``run``'s default length in words: :func:`physomni_usd.run` ends a take whose length was not asked for at rest.
RUN_SECONDS = f"{DEFAULT_SECONDS:g}, ended once nothing has moved for a second"


@click.command()
@click.argument("photo", type=click.Path(dir_okay=False, path_type=pathlib.Path))
@output_folder_option
@build_options
@backend_options
@push_option
@SIMULATE(skip=("fps",), defaults={"seconds": RUN_SECONDS})  # --fps is the shot's, from the build's
@camera_options
@RENDER()
@quiet_option
def run(quiet, **params):
    """build + simulate + render in one go; writes DIR/shot.usda, DIR/video.mp4, DIR/report.json.

    \b
    Example:
      physomni-usd run examples/motorcycle/photo.png -o out/ \\
          --mask examples/motorcycle/motorcycle.png --push motorcycle=0,2,0
    """
    with errors():
        import physomni_usd

        call = run_call(params)
        with run_display(quiet) as display:
            done = physomni_usd.run(**call, echo=say(quiet), **display)
        if not quiet:
            result = done["build"]
            click.echo(f"done in {done['total_seconds']:.1f} s: {result.shot}, {done['render']['video']}, "
                       f"{result.folder / 'report.json'}", err=True)


def run_call(params: dict) -> dict:
    """``run``'s parameters (as its parser makes them) → the keyword arguments of :func:`physomni_usd.run`:
    the settings models of the build, simulate and render options, the backends, and the rest by name."""
    p = {k: v for k, v in params.items() if k != "quiet"}
    call = dict(backends=backends(p), settings=build_settings(p), simulate_settings=SIMULATE.settings(p),
                render_settings=RENDER.settings(p))
    return {**p, **call}


def parse_run(args: list[str]) -> dict:
    """``run``'s own option parser on one shot's arguments (nothing runs); raises InputError."""
    from ..errors import InputError

    try:
        return run.make_context("run", list(args)).params
    except click.ClickException as exc:
        raise InputError(exc.format_message()) from None


def run_arguments(args: list[str]) -> dict:
    """One shot line of ``batch`` → the keyword arguments of :func:`physomni_usd.run` (raises like ``run``)."""
    return run_call(parse_run(args))


@contextmanager
def run_display(quiet: bool):
    """``progress`` and ``on_stage`` for :func:`physomni_usd.run`: one bar (or log lines) per stage, and the
    line each stage ends with, as the commands ``simulate`` and ``render`` print them."""
    bars = ExitStack()
    current = {}

    def follow(stage, done, total):
        if stage not in current:
            current[stage] = bars.enter_context(progress("render  " if stage == "render" else stage, not quiet))
        current[stage](done, total)

    def on_stage(stage, result):
        if result is not None and stage in ("simulate", "render"):
            bars.close()  # the bar ends before its stage's line
            said(stage, result, quiet)

    with bars:
        yield {"progress": follow, "on_stage": on_stage}


EPILOG_BATCH = """
\b
SHOTS, one `physomni-usd run` argument list per line (paths relative to SHOTS):
  # shots.txt
  cup/photo.png -o out/cup --mask cup/cup.png:cup --push cup=0.5,0,0
  'bike shed/photo.png' -o out/bike --mask 'bike shed/bike.png' --seconds 2
or a YAML (.yaml, .yml) or JSON (.json) list of such lines or of mappings:
  - {photo: cup/photo.png, output: out/cup, mask: [cup/cup.png:cup], push: cup=0.5,0,0}

\b
Examples:
  physomni-usd batch shots.txt --summary out/summary.json
  physomni-usd batch shots.txt --address 10.0.0.5:6379 --gpus-per-shot 0.25
\b
A shot whose folder holds a finished run of the same inputs (photo, mask and
mesh bytes, options, version; a hash in report.json) is skipped unless --force.
Each attempt's output goes to DIR/batch.log. Exit codes: 0 every shot ok or
skipped, 1 some shot failed, 2 a bad shot list (the line is named). On a cluster
every node must see SHOTS' folder and the outputs at the same paths (shared
storage), or give --upload; every node needs physomni-usd installed.
"""


@click.command(epilog=EPILOG_BATCH)
@click.argument("shots", type=click.Path(dir_okay=False, path_type=pathlib.Path))
@click.option("--address", envvar="RAY_ADDRESS", default=None, metavar="HOST:PORT",
              help="Ray cluster to run on [env: RAY_ADDRESS; default: start Ray on this machine with its CPUs].")
@limit_option(BATCH_LIMITS, "workers")
@limit_option(BATCH_LIMITS, "retries")
@click.option("--force", is_flag=True, help="Run finished shots again.")
@click.option("--summary", "summary_path", type=click.Path(dir_okay=False, path_type=pathlib.Path), default=None,
              help="Write a JSON summary here (one entry per shot: output, status, seconds, attempts, node, "
                   "reason); updated as shots finish.")
@limit_option(BATCH_LIMITS, "cpus_per_shot")
@limit_option(BATCH_LIMITS, "gpus_per_shot")
@click.option("--upload", is_flag=True,
              help="Send each shot's input files with its task and its output folder back, through Ray's "
                   "object store: for a cluster whose nodes do not share storage with this machine.")
@click.option("-q", "--quiet", is_flag=True, help="Print nothing but errors and the final line.")
def batch(shots, address, workers, retries, force, summary_path, cpus_per_shot, gpus_per_shot, upload, quiet):
    """Run many shots (each a `physomni-usd run`) as Ray tasks; resumable, one failure never stops the rest."""
    with errors():
        from ..batch.runner import check_batch

        check_batch(summary_path, workers=workers, retries=retries, cpus_per_shot=cpus_per_shot,
                    gpus_per_shot=gpus_per_shot)
        from ..batch.progress import Progress
        from ..batch.runner import Quiet, run_batch
        from ..batch.shots import read_shot_list

        shot_list = read_shot_list(shots, parse_run)
        summary = run_batch(shot_list, address=address, workers=workers, retries=retries, force=force,
                            cpus_per_shot=cpus_per_shot, gpus_per_shot=gpus_per_shot,
                            progress=Quiet() if quiet else Progress(), summary_path=summary_path,
                            upload=run if upload else None, call=run_arguments)
        click.echo(f"batch: {summary['ok']} ok, {summary['skipped']} skipped, {summary['failed']} failed "
                   f"in {summary['seconds']:.1f} s" + (f"; summary: {summary_path}" if summary_path else ""),
                   err=True)
        if summary["failed"]:
            sys.exit(1)
