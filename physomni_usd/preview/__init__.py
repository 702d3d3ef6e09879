"""``physomni-usd preview``: the shot simulated live in a browser page, pushed with the mouse, changed
from a panel, and kept as a take (``sim.usdc``) or as settings (``edits.usda``)."""
