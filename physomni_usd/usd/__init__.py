"""The only code that writes USD: schema registration, layer layout, authoring helpers.

Everything else in the package reads composed stages and hands plain arrays to
these helpers.
"""
