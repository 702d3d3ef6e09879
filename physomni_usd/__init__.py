"""physomni-usd: one photograph to a physically simulated, layered USD shot.

Importing the package registers the PhysOmni USD schema with OpenUSD. Nothing
heavy (warp, Newton, torch) is imported here; each stage imports what it needs
when it runs.
"""

from ._version import __version__
from .usd.schema import register_schema

register_schema()

__all__ = ["__version__", "register_schema"]
