"""Swappable steps: one protocol per step, built-in backends, and the registry that finds plugins.

``protocols`` says what each kind of backend takes and returns; ``registry``
lists and loads backends by kind and name (built-ins here, plugins through the
``physomni_usd.backends`` entry-point group); ``steps`` runs a chosen backend
inside ``build``. Nothing here imports a plugin's module until it is selected.
"""
