"""The built-in backends and the running of the chosen ones inside ``build``.

``builtin`` adapts the protocols of :mod:`physomni_usd.swappable.protocols` to
the classical code in perceive/, lift/, align/ and materials/; ``steps`` runs
the backends ``build`` chose (objects from prompts, the plate, lifting).
The protocols and the registry that finds plugins are in
:mod:`physomni_usd.swappable`.

A plugin written when the protocols and the registry lived here imports
``physomni_usd.backends.registry`` or ``.protocols``: both names stay bound to
the modules of :mod:`physomni_usd.swappable` themselves (the same module
objects, not copies), so such a plugin keeps working unchanged.
"""

import sys

from ..swappable import protocols, registry

sys.modules[f"{__name__}.protocols"] = protocols
sys.modules[f"{__name__}.registry"] = registry
