"""The built-in backends and the running of the chosen ones inside ``build``.

``builtin`` adapts the protocols of :mod:`physomni_usd.swappable.protocols` to
the classical code in perceive/ and materials/; ``steps`` runs the backends
``build`` chose (objects from prompts, the plate, lifting, the depth's ground).
The protocols and the registry that finds plugins are in
:mod:`physomni_usd.swappable`.
"""
