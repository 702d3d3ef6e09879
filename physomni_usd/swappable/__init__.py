"""The plugin interface of the swappable steps: what a backend of each kind implements, and how it is found.

``protocols`` says what each kind of backend takes and returns; ``registry``
lists and loads backends by kind and name (the built-ins of
``physomni_usd.backends.builtin``, and plugins through the
``physomni_usd.backends`` entry-point group). Both sit low in the package, next
to the settings, so that any stage may load a backend; nothing here imports a
plugin's module until it is selected.
"""
