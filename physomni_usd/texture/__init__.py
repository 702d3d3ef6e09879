"""Texture: what the photo shows behind the objects, and how each object is painted.

Its own floor between lift (the meshes) and align (where they stand), as the build runs it: once the objects
are lifted, the background plate behind them (``fill.py``, by exemplar in ``exemplar.py`` and ``grain.py``;
carried to the photo's size from a reduced copy in ``carry.py``) and its widening beyond the frame for camera
moves (``outpaint.py``); once they are placed, each object's texture (``objects.py``): its crop of the photo,
the part others hide painted from its own surface (``hidden.py``), and the sides the photo saw edge-on
(``sides.py``). ``pixels.py`` holds the image operations the fills share.
"""
