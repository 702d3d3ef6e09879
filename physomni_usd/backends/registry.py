"""Where the registry lived before :mod:`physomni_usd.swappable`; plugins written then still import it from here.

Every name is :mod:`physomni_usd.swappable.registry`'s own object, not a copy.
"""

from ..swappable.registry import *  # noqa: F401,F403  (the whole public interface, whatever it grows to)
