"""The built-in backends and the running of the chosen ones inside ``build``.

``builtin`` adapts the protocols of :mod:`physomni_usd.swappable.protocols` to
the classical code in perceive/, lift/, align/ and materials/; ``steps`` runs
the backends ``build`` chose (objects from prompts, the plate, lifting).
The protocols and the registry that finds plugins are in
:mod:`physomni_usd.swappable`.

A plugin written when the protocols and the registry lived here imports
``physomni_usd.backends.registry`` or ``.protocols``: those are two small
modules that re-export the names of :mod:`physomni_usd.swappable`'s (the same
classes and functions, so one registry and ``isinstance`` checks agree), and
such a plugin keeps working unchanged.
"""
