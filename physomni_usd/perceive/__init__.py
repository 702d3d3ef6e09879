"""Perceive: masks of the objects, and who hides whom.

Built-in backends are classical and need no weights: masks from files or from
boxes (OpenCV GrabCut). Meshes are lifted from the masks one floor up, in
``lift/``; the background plate and the textures are the texture stage's (``texture/``).
"""
