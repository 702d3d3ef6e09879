"""The only code that writes USD: schema registration, layer layout, authoring helpers, the shot's
contract (which prims are its objects, which material each is bound to: ``contract.py``) and the
artist's values added to ``edits.usda`` (``overrides.py``).

Everything else in the package reads composed stages and hands plain arrays to
these helpers.
"""
