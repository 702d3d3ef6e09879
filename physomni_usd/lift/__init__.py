"""Lift: one closed, watertight mesh per object from its silhouette, and the texture of the sides the photo never saw.

Its own floor between perceive (masks, the plate, who hides whom) and align (camera, scale, placement),
which is its only user besides the build's texture stage: ``silhouette.py`` lofts a side view,
``footprint.py`` a view from above, ``sections.py`` the cross-sections both share, ``sides.py`` the
texture of edge-on faces.
"""
