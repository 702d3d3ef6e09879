"""The ``physomni-usd`` group: its help, its version, the signals every command unwinds on, and one
subcommand per command module (click's ``complex`` example: a module per command group)."""

from __future__ import annotations

import click

from . import cmd_bench, cmd_live, cmd_run, cmd_stages, cmd_tools
from .shell import OneLineUsage, exit_without_collecting, stop_on_signals


@click.group(cls=OneLineUsage, context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(package_name="physomni-usd")
def main():
    """Turn one photograph into a physically simulated, layered USD shot and a video.

    \b
    A shot folder holds one layer per stage under a root shot.usda:
      shot.usda = [edits.usda, render.usda, sim.usdc, physics.usda, scene.usda]
    (strongest first; render.usda holds a camera move, written by `render --camera`).
    edits.usda is yours: it is created empty, no command rewrites it (only
    `estimate --set` and the preview's "Keep settings" add your values to it),
    and what you author there (a heavier object, a push, a moved prop) counts
    in the next `simulate`.

    \b
    Quick start:
      physomni-usd run photo.png -o shot/ --mask cup.png:cup --push cup=0.5,0,0
      physomni-usd validate shot/shot.usda
    """
    exit_without_collecting()
    previous = stop_on_signals()
    if previous:  # an in-process caller (a test, a script) gets its own handlers back afterwards
        import signal

        click.get_current_context().call_on_close(lambda: [signal.signal(k, v) for k, v in previous.items()])


for command in (cmd_stages.build, cmd_stages.estimate, cmd_stages.simulate, cmd_stages.render, cmd_run.run,
                cmd_run.batch, cmd_live.preview, cmd_live.studio, cmd_tools.validate, cmd_tools.plugins_command,
                cmd_tools.rerender, cmd_bench.bench):
    main.add_command(command)
