"""Perceive: masks of the objects, the background plate, and who hides whom.

Built-in backends are classical and need no weights: masks from files or from
boxes (OpenCV GrabCut), the plate by OpenCV inpainting. Meshes are lifted from
the masks one floor up, in ``lift/``.
"""
