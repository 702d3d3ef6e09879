"""Perceive: masks of the objects, the background plate, and one mesh per object.

Built-in backends are classical and need no weights: masks from files or from
boxes (OpenCV GrabCut), the plate by OpenCV inpainting, meshes lifted from
silhouettes.
"""
