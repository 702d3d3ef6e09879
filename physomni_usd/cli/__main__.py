"""``python -m physomni_usd.cli``: the ``physomni-usd`` command."""

from . import main

main(prog_name="physomni-usd")
