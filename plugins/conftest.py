"""Every test under plugins/ is a model plugin's: marked ``plugins``, so the default run leaves them out
(``python -m pytest``) and ``python -m pytest -m plugins`` runs only them."""

from __future__ import annotations

import pathlib

import pytest

HERE = pathlib.Path(__file__).resolve().parent


@pytest.hookimpl(tryfirst=True)  # before -m deselects by marker
def pytest_collection_modifyitems(config, items):
    for item in items:
        if HERE in pathlib.Path(str(item.path)).resolve().parents:
            item.add_marker(pytest.mark.plugins)
