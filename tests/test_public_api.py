"""The package's public API: one function per stage and ``run``, importable without anything heavy."""

import subprocess
import sys

import pytest

import physomni_usd
from physomni_usd.errors import InputError


def test_importing_the_package_imports_no_stage_and_nothing_heavy():
    code = ("import sys, physomni_usd\n"
            "assert callable(physomni_usd.build) and callable(physomni_usd.simulate)\n"
            "assert callable(physomni_usd.run)\n"
            "heavy = [m for m in ('torch', 'warp', 'newton', 'cv2', 'physomni_usd.building',"
            " 'physomni_usd.physics', 'physomni_usd.rendering') if m in sys.modules]\n"
            "print(heavy)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


@pytest.mark.parametrize("stage", ["estimate", "simulate", "render"])
def test_a_stage_on_a_missing_shot_is_bad_input_naming_it(tmp_path, stage):
    missing = tmp_path / "nowhere" / "shot.usda"
    with pytest.raises(InputError, match="nowhere"):
        getattr(physomni_usd, stage)(missing)
    assert not (tmp_path / "nowhere").exists()


def test_build_of_a_missing_photo_is_bad_input_naming_it(tmp_path):
    with pytest.raises(InputError, match="absent.png"):
        physomni_usd.build(tmp_path / "absent.png", tmp_path / "out", boxes=["1,1,5,5:box"])
    assert not (tmp_path / "out").exists()


def test_build_reads_labels_after_a_colon_as_its_docstring_says(tmp_path, photo):
    """The specs reach the parsers (the photo exists): ``PATH:LABEL`` and ``X0,Y0,X1,Y1:LABEL`` are read as
    documented, and the ``=`` form, once documented by mistake, is refused naming the box."""
    assert "PATH[:LABEL]" in physomni_usd.build.__doc__ and "=LABEL" not in physomni_usd.build.__doc__
    with pytest.raises(InputError, match="mask not found: nothere.png$"):
        physomni_usd.build(photo["photo"], tmp_path / "out", masks=["nothere.png:cup"])
    with pytest.raises(InputError, match="smaller than 4×4"):
        physomni_usd.build(photo["photo"], tmp_path / "out", boxes=["10,10,12,12:box"])
    with pytest.raises(InputError, match="expected X0,Y0,X1,Y1"):
        physomni_usd.build(photo["photo"], tmp_path / "out", boxes=["10,10,50,50=box"])
    assert not (tmp_path / "out").exists()


def test_the_stage_functions_survive_their_modules_being_imported():
    code = ("import physomni_usd, physomni_usd.building, physomni_usd.rendering.video\n"
            "from physomni_usd.building import build_shot\n"
            "assert callable(physomni_usd.build) and callable(physomni_usd.render), (physomni_usd.build,)\n"
            "import sys; assert sys.modules['physomni_usd.building'].build_shot is build_shot\n")
    subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)


def test_no_submodule_is_named_as_a_public_function():
    """Importing ``physomni_usd.X`` binds the module X on the package: a module named as one of the API's
    functions would replace the function wherever it was imported."""
    import pathlib

    root = pathlib.Path(physomni_usd.__file__).parent
    clash = [name for name in physomni_usd.__all__
             if (root / f"{name}.py").exists() or (root / name / "__init__.py").exists()]
    assert clash == []
