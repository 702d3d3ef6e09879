"""The ``physomni-usd`` command: one subcommand per stage (build, estimate, simulate, render), ``run``
for the three of them, and ``preview``, ``validate``, ``batch``, ``bench``, ``plugins``, ``rerender``.

The stage commands and ``run`` parse their options, call the public API (:mod:`physomni_usd`) and show
what it did; the others call the module that owns them. In every command an exception becomes one
``error:`` line and an exit code (:func:`physomni_usd.failure.failure_of`): 0 success, 1 a stage failed
or validation found errors, 2 bad input or usage, 3 an internal error (a bug: please report it), 130
interrupted.

The package holds one module per command group (``cmd_stages``, ``cmd_run``, ``cmd_live``, ``cmd_tools``,
``cmd_bench``), the options they share (``options``: the settings models' fields, declared once) and what
every command does around its work (``shell``: the error line, progress, signals). ``main`` is the group.
"""

from .app import main

__all__ = ["main"]
