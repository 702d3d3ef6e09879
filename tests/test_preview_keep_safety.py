"""The preview's "Keep settings" and "Save take" on a shot folder from someone else (a planted lock journal, a
lock or layer that is a link to a file outside) or changed while the preview runs (a sublayer cycle, a hand edit):
each press answers in one line and the session goes on, nothing outside the folder changes (a decoy tree beside
it hashed before and after), edits.usda is kept. In process: the functions the page's buttons run, on an engine
opened as the preview opens the shot, no browser. ``bench faults`` runs the same trials as its "preview keep" case."""

from __future__ import annotations

import pytest

from physomni_usd.bench import hostile_folders as faults


@pytest.fixture(scope="module")
def base(shot):
    return {"dir": shot["dir"]}


@pytest.mark.parametrize("name", list(faults.KEEP_TRIALS))
def test_keep_is_refused_or_kept_inside_the_folder(name, base, tmp_path):
    ok, detail = faults.keep_trial(base, tmp_path, name)
    assert ok, detail


def test_a_keep_reads_edits_usda_as_it_is_on_disk_now(base, tmp_path):
    """Two presses of Keep settings with an edit on disk between them: the second keeps the first's value, the
    edit and its own (USD hands out the layer it opened first; the preview holds it for the whole session)."""
    from physomni_usd.preview.app import keep_settings
    from physomni_usd.preview.engine import Engine

    folder = faults.copy_shot(base, tmp_path / "shot")
    engine = Engine(folder / "shot.usda", capture=False)
    engine.set_gravity(5.0)
    assert keep_settings(engine) == (True, "kept 1 setting(s) in edits.usda")
    faults._noted("edits.usda")(folder, None)
    engine.set_gravity(6.0)
    assert keep_settings(engine)[0]
    text = (folder / "edits.usda").read_text()
    assert "handEdit" in text and "gravityMagnitude = 6" in text and "gravityMagnitude = 5" not in text


def test_a_shot_reached_through_a_linked_folder_is_kept_without_waiting_on_its_own_lock(base, tmp_path, monkeypatch):
    """The shot folder may be a link the user made: the lock taken before the read and the one the write takes are
    the same lock (one was taken by the link's name, the other by the folder's, and the press waited on itself)."""
    from physomni_usd import _files
    from physomni_usd.preview.app import keep_settings, save_take
    from physomni_usd.preview.engine import Engine

    monkeypatch.setattr(_files, "LOCK_WAIT_S", 2.0)
    faults.copy_shot(base, tmp_path / "real")
    (tmp_path / "link").symlink_to(tmp_path / "real")
    engine = Engine(tmp_path / "link" / "shot.usda", capture=False)
    engine.set_gravity(5.0)
    engine.step()
    assert keep_settings(engine) == (True, "kept 1 setting(s) in edits.usda")
    assert save_take(engine, 1)[0] is not None
    assert b"gravityMagnitude = 5" in (tmp_path / "real" / "edits.usda").read_bytes()
    assert not (tmp_path / "real" / ".physomni.lock").exists()
