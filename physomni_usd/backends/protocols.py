"""Where the protocols lived before :mod:`physomni_usd.swappable`; plugins written then still import it from here.

Every name is :mod:`physomni_usd.swappable.protocols`'s own object, not a copy.
"""

from ..swappable.protocols import *  # noqa: F401,F403  (the whole public interface, whatever it grows to)
