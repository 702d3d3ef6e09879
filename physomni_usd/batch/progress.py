"""What ``batch`` shows while it runs: a progress bar on a terminal, one plain line per event otherwise."""

from __future__ import annotations

import sys
import time

import click

from .shots import LOG


def _clock(seconds: float) -> str:
    seconds = int(round(seconds))
    return f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}"


class Progress:
    """Reports to stderr; a click progress bar when stderr is a terminal."""

    def __init__(self, file=None, bar: bool | None = None):
        self.file = file or sys.stderr
        self.bar_wanted = self.file.isatty() if bar is None else bar
        self.bar = None
        self.t0 = time.perf_counter()
        self.counts = {}

    def _text(self, entries) -> str:
        c = {s: sum(e.status == s for e in entries) for s in ("ok", "skipped", "failed", "running")}
        finished = c["ok"] + c["skipped"] + c["failed"]
        elapsed = time.perf_counter() - self.t0
        ran = sum(e.attempts > 0 and e.status in ("ok", "failed") for e in entries)
        left = ""
        if ran and finished < len(entries):
            # time per shot that ran, over the shots still to go (skips and bad input cost nothing)
            left = f", ~{_clock(elapsed / ran * (len(entries) - finished))} left"
        return (f"ok {c['ok']}, skipped {c['skipped']}, failed {c['failed']}, running {c['running']}; "
                f"{_clock(elapsed)} elapsed{left}")

    def start(self, entries):
        self.entries = entries
        if self.bar_wanted:
            self.bar = click.progressbar(length=len(entries), label="batch", file=self.file, show_pos=True,
                                         show_eta=False, item_show_func=lambda _: self._text(self.entries))
            self.bar.__enter__()
            self.done = 0

    def update(self, entries):
        if self.bar is not None:
            finished = sum(e.status in ("ok", "skipped", "failed") for e in entries)
            self.bar.update(finished - self.done, entries)
            self.done = finished
            self.bar.render_progress()

    def event(self, kind: str, entry):
        if self.bar is not None:
            self.update(self.entries)
            return
        shot = entry.shot
        if kind == "skipped":
            line = f"skipped {shot.where}: {shot.output} is finished"
        elif kind == "ok":
            line = (f"ok      {shot.where}: {shot.output} in {entry.seconds:.1f} s, attempt {entry.attempts}, "
                    f"node {entry.node}")
        elif kind == "retry":
            line = f"retry   {shot.where}: attempt {entry.attempts} failed ({entry.reason}); trying again"
        else:
            line = f"failed  {shot.where}: {entry.reason}" + (f" (log: {shot.output / LOG})" if entry.attempts else "")
        click.echo(line, file=self.file)

    def close(self):
        if self.bar is not None:
            self.update(self.entries)
            self.bar.__exit__(None, None, None)
            self.bar = None
            for e in self.entries:
                if e.status == "failed":
                    log = f" (log: {e.shot.output / LOG})" if e.attempts else ""
                    click.echo(f"failed  {e.shot.where}: {e.reason}{log}", file=self.file)
