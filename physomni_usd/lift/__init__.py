"""Lift: one closed, watertight mesh per object from its silhouette.

Its own floor between perceive (masks, who hides whom) and texture and align (the plate and textures; camera,
scale, placement), which use it: ``silhouette.py`` lofts a side view, ``footprint.py`` a view from above,
``sections.py`` the cross-sections both share.
"""
