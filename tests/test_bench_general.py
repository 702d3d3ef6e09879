"""``bench general``'s scenes: drawn fresh on every run (the seeds are in each failure's message), so that no
scene can be tuned for.

Without Blender: the generator's truth is consistent (the same seed draws the same scene; objects do not
interpenetrate, stand where they are said to, and are inside the frame), and the command says how to get
Blender's Python. With it (``PHYSOMNI_BLENDER_PYTHON``, as ``.ci/run`` sets it): two fresh scenes are
rendered with Cycles, the object-id render agrees with a ray cast of the true meshes through the true camera,
and each scene built from its visible masks meets every invariant of issue 38: build exits 0 (asserted);
simulate does not refuse it, no start overlap over 2 mm, nothing moves over 1 cm or turns over 5° in 2 s
unpushed (asserted, and marked as failing on some fresh scenes until issue 38's part 1 lands:
:data:`NOT_YET` says how often).
"""

from __future__ import annotations

import os

import numpy as np
import pytest

from physomni_usd.bench import general
from physomni_usd.metrics.geometry import overlaps

from .conftest import cli

FRESH = [int(s) for s in np.random.default_rng().integers(1, 10**8, 3)]


@pytest.mark.parametrize("seed", FRESH)
def test_the_same_seed_draws_the_same_scene_and_its_truth_holds_together(seed):
    a, b = general.describe_scene(seed), general.describe_scene(seed)
    assert [o["name"] for o in a["objects"]] == [o["name"] for o in b["objects"]], f"seed {seed}"
    assert all(np.array_equal(x["mesh"].vertices, y["mesh"].vertices) for x, y in zip(a["objects"], b["objects"]))
    assert a["objects"], f"seed {seed}: nothing visible drawn"
    cam = a["camera"]
    assert 0.0 <= cam.pitch_deg <= 90.0 and 25.0 <= cam.fov_deg <= 80.0
    meshes = {o["name"]: o["mesh"] for o in a["objects"]}
    deep = {pair: d for pair, d in overlaps(meshes).items() if d > 0.001}
    assert not deep, f"seed {seed}: the truth's meshes interpenetrate {deep}"
    for o in a["objects"]:
        uv, depth = cam.project(o["mesh"].vertices)
        assert depth.min() > 0 and uv.min() >= 0 and (uv <= [cam.width, cam.height]).all(), f"seed {seed}: {o['name']}"
        low = o["mesh"].bounds[0][2]
        if o["place"] == "support":  # on the support or on another object, never below the support's top
            assert low >= -1e-6, f"seed {seed}: {o['name']} sinks {low} m into the support"


def test_without_blender_the_command_says_how_to_get_it():
    env = {k: v for k, v in os.environ.items() if k != "PHYSOMNI_BLENDER_PYTHON"}
    try:
        general.blender_python()
    except general.NoBlender:
        pass
    else:
        if "PHYSOMNI_BLENDER_PYTHON" not in os.environ:
            pytest.skip("this Python has bpy itself, so the command never lacks Blender here")
    proc = cli("bench", "general", "--n", "1", env=env)
    assert proc.returncode == 2, proc.stderr
    assert "PHYSOMNI_BLENDER_PYTHON" in proc.stderr


@pytest.mark.parametrize("seed", FRESH)
def test_the_truth_says_what_holds_each_object_and_it_does(seed):
    scene = general.describe_scene(seed)
    objects = {o["name"]: o for o in scene["objects"]}
    for o in scene["objects"]:
        lo, hi = o["mesh"].bounds
        on = o["on"]
        if on == "support":
            assert abs(lo[2]) <= 1e-6, f"seed {seed}: {o['name']} is said to stand on the support, {lo[2]} m up"
        elif on in ("wall", "shelf"):
            assert lo[2] >= 0.1, f"seed {seed}: {o['name']} is said to be on the {on}, {lo[2]} m up"
        elif on != "hidden":  # on another object (or several): its base between their bottoms and tops, over them
            under = [objects[k]["mesh"].bounds for k in (on if isinstance(on, list) else [on])]
            centre = 0.5 * (lo[:2] + hi[:2])
            assert any(b[0][2] - 1e-6 <= lo[2] <= b[1][2] + 1e-3 for b in under), f"seed {seed}: {o['name']} on {on}"
            assert any(np.all(centre >= b[0][:2] - 0.04) and np.all(centre <= b[1][:2] + 0.04) for b in under), \
                f"seed {seed}: {o['name']} is not over {on}"


def test_support_is_judged_against_what_holds_each_object():
    true, built = ["box1", "box2", "apple1", "lemon1"], ["box_0", "box_1", "apple_2", "lemon_3"]
    assert general._support_ok("support", "ground", true, built)
    assert not general._support_ok("support", "box_0", true, built)
    assert general._support_ok("box1", "box_0", true, built) and not general._support_ok("box1", "ground", true, built)
    assert general._support_ok(["apple1", "lemon1"], "lemon_3", true, built)
    assert general._support_ok("wall", "held", true, built) and not general._support_ok("shelf", "ground", true, built)


def test_a_build_can_be_told_the_field_of_view_alone():
    """``--fov-given`` tells the build the true view and leaves the pitch to the photo; ``--camera-given`` both."""
    truth = {"camera": {"fov_deg": 33.0, "pitch_deg": 61.0}}
    assert general.given_camera(truth, False) is None
    fov = general.given_camera(truth, "fov").camera
    assert fov.fov_deg == 33.0 and fov.pitch_deg is None
    both = general.given_camera(truth, True).camera
    assert both.fov_deg == 33.0 and both.pitch_deg == 61.0
    assert general.GIVEN_SUFFIX["fov"] != general.GIVEN_SUFFIX[True]  # the two builds do not overwrite each other
    with pytest.raises(ValueError):
        general.given_camera(truth, "pitch")


def test_position_error_splits_along_and_across_the_ray():
    """A wrong depth is all along the ray, a turned ray all across it; the two make up the whole error."""
    true = np.array([0.3, 0.4, 1.2])
    dist = np.linalg.norm(true)
    depth, lateral = general.position_split(1.1 * true, true)
    assert depth == pytest.approx(0.1) and lateral == pytest.approx(0.0, abs=1e-12)
    depth, lateral = general.position_split(0.9 * true, true)
    assert depth == pytest.approx(-0.1)
    across = np.cross(true, [0.0, 1.0, 0.0])
    across *= 0.05 * dist / np.linalg.norm(across)
    depth, lateral = general.position_split(true + across, true)
    assert depth == pytest.approx(0.0, abs=1e-12) and lateral == pytest.approx(0.05)
    est = 1.02 * true + across
    depth, lateral = general.position_split(est, true)
    assert np.hypot(depth, lateral) == pytest.approx(np.linalg.norm(est - true) / dist)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """Two fresh scenes rendered and built from their visible masks, simulated 2 s with nothing pushed."""
    try:
        general.blender_python()
    except general.NoBlender as exc:
        pytest.skip(str(exc))
    seed = int(np.random.default_rng().integers(1, 10**6))
    rows, folders = [], [tmp_path_factory.mktemp(f"general{i}") for i in range(2)]
    for i, folder in enumerate(folders):
        rows += general.scene_rows(i, seed, folder, modes=("masks",), echo=lambda m: None)
    assert rows, f"seed {seed}: no scene"
    return seed, rows, folders


def _scenes(rows) -> str:
    return "; ".join(f"scene {r['seed']} ({r['layout']}, pitch {r['pitch_true']}°, "
                     f"{', '.join(o['label'] for o in r['objects']) or r['objects_n']}): "
                     + (", ".join(k for k, v in r['invariants'].items() if not v) or "ok")
                     + (f" [{r['error']}]" if r["error"] else "") for r in rows)


@pytest.mark.slow  # two Cycles renders, two builds and 2 s simulations: about 2 minutes on 2 cores
def test_the_photo_and_its_masks_come_from_the_same_camera(built):
    """The id render's visible masks against a ray cast of the true meshes: Blender's camera is the truth's."""
    import json

    seed, rows, folders = built
    for truth_file in (f / "truth.json" for f in folders if (f / "truth.json").exists()):
        truth = json.loads(truth_file.read_text())
        for o in truth["objects"]:
            assert o["visible_px"] >= general.MIN_VISIBLE_PX - 20, f"seed {seed}: {o}"
            assert o["id_render_iou"] >= 0.9, f"scene {truth['seed']}: {o['name']} id render IoU {o['id_render_iou']}"


#: Invariants that fresh scenes still break (issue 38, part 1, is open), as measured on 2026-12-03 by
#: `bench general` on two runs of ten scenes built from masks (docs/benchmarks.md, *Any photo*): half the
#: scenes have fruit that rolls or a book that slides, and one in ten has a cup or a book built 1-1.5 cm
#: inside what holds it, which simulate refuses. Marked here, not loosened: each is still asserted and
#: reported, and when part 1 lands these marks go. "builds" (20 of 20 from masks) is asserted unmarked.
NOT_YET = {"simulates": "1 in 10 fresh scenes is built with an object 1-1.5 cm inside its support, which "
                        "simulate refuses (issue 38, part 1)",
           "start_overlap": "1 in 10 fresh scenes starts with an overlap over 2 mm (issue 38, part 1)",
           "rest_drift": "unpushed objects of half the fresh scenes move over 1 cm in 2 s (issue 38, part 1)",
           "rest_turn": "unpushed objects of half the fresh scenes turn over 5° in 2 s (issue 38, part 1)"}


@pytest.mark.slow  # the same two scenes (the fixture is the module's)
@pytest.mark.parametrize("invariant", [pytest.param(k, marks=pytest.mark.xfail(reason=NOT_YET[k], strict=False))
                                       if k in NOT_YET else k for k in general.INVARIANTS])
def test_a_fresh_scene_built_from_its_masks_meets_the_invariant(built, invariant):
    seed, rows, _ = built
    failed = [r for r in rows if not r["invariants"][invariant]]
    assert not failed, f"{invariant} fails on {_scenes(failed)} (run seed {seed})"


@pytest.mark.slow  # the same two scenes (the fixture is the module's)
def test_frame_zero_of_every_fresh_scene_is_the_photo(built):
    """Issue 39: frame 0 (composed before encoding) against the photo at least 40 dB, whatever the lift."""
    seed, rows, _ = built
    low = {r["seed"]: r.get("frame0_psnr_db") for r in rows
           if not r.get("frame0_psnr_db", 0.0) >= general.LIMITS["frame0_psnr_db"]}
    assert not low, f"frame 0 PSNR (dB) under {general.LIMITS['frame0_psnr_db']:g}: {low} (run seed {seed})"


def test_the_pass_rates_count_frame_zero():
    """The summary and its table carry the frame-0 pass rate and median (a row without the figure fails it)."""
    row = {"seed": 1, "layout": "table", "mode": "masks", "objects_n": 0, "pitch_true": 30.0, "fov_true": 50.0,
           "built": True, "simulated": True, "error": None, "objects": [], "max_overlap_m": 0.0,
           "max_drift_m": 0.0, "max_turn_deg": 0.0, "thin": [], "pitch_error_deg": 1.0, "fov_error_frac": 0.0}
    rows = [general._judge(dict(row, frame0_psnr_db=99.0)), general._judge(dict(row, seed=2, frame0_psnr_db=31.0)),
            general._judge(dict(row, seed=3))]
    s = general.summarise(rows)["masks"]
    assert s["frame0"] == pytest.approx(1 / 3, abs=1e-3)
    assert s["median"]["frame0_psnr_db"] == pytest.approx(65.0)
    table = general.markdown({"n": 3, "seed": 0, "date": "today", "machine": "here", "size": [320, 240],
                              "samples": 24, "seconds_per_scene": 1.0, "summary": {"masks": s}})
    assert "frame 0 against the photo ≥ 40 dB" in table and "| 33 % |" in table


def test_rest_turn_reads_a_tip_that_barely_moves_any_point():
    """A 2 cm cube turned 30° about its own centre over the take: no point moves 1 cm, the turn is 30°."""
    import trimesh
    from pxr import Usd, UsdGeom

    from physomni_usd.metrics.geometry import rest_drift, rest_turn

    stage = Usd.Stage.CreateInMemory()
    stage.SetStartTimeCode(0)
    stage.SetEndTimeCode(10)
    cube = trimesh.creation.box((0.02, 0.02, 0.02))
    mesh = UsdGeom.Mesh.Define(stage, "/World/Objects/cube")
    mesh.CreatePointsAttr([tuple(map(float, v)) for v in cube.vertices])
    mesh.CreateFaceVertexCountsAttr([3] * len(cube.faces))
    mesh.CreateFaceVertexIndicesAttr([int(i) for i in cube.faces.ravel()])
    turn = UsdGeom.Xformable(mesh).AddRotateXOp()
    for t in range(11):
        turn.Set(3.0 * t, Usd.TimeCode(t))
    assert rest_turn(stage)["cube"] == pytest.approx(30.0, abs=0.01)
    assert rest_drift(stage)["cube"] < 0.01


def test_the_one_scale_follows_most_objects_and_still_sees_a_distorted_scene():
    """A build that is the truth at 0.8 its size, but for one object put 1.8× too far: the common scale is 1/0.8
    (the outlier does not rescale the rest, as a least-squares fit in metres does), the others' errors after
    it vanish and the outlier's stays. Depth stretched unevenly (a wrong pitch) leaves errors the scale
    cannot remove: the measure can still fail."""
    rng = np.random.default_rng(5)
    true = np.c_[rng.uniform(-0.3, 0.3, (6, 2)), rng.uniform(1.2, 2.0, 6)]
    est = 0.8 * true
    est[0] *= 1.8
    k = general.common_scale(est, true)
    assert k == pytest.approx(1.25, rel=1e-6)
    err = np.linalg.norm(k * est - true, axis=1) / np.linalg.norm(true, axis=1)
    assert err[1:].max() < 1e-9 and err[0] > 0.5
    lsq = float((est * true).sum() / (est * est).sum())
    assert np.median(np.linalg.norm(lsq * est[1:] - true[1:], axis=1) / np.linalg.norm(true[1:], axis=1)) > 0.1
    stretched = true * np.c_[np.ones((6, 2)), 1.0 + 0.5 * (true[:, 2] - 1.2)]
    k = general.common_scale(stretched, true)
    err = np.linalg.norm(k * stretched - true, axis=1) / np.linalg.norm(true, axis=1)
    assert err.max() > 0.05


def test_the_shape_from_the_side_takes_out_position_and_keeps_shape():
    """A box built 10 cm off its truth scores 1 on its shape from ±45° (its position is what it got wrong); one
    built twice as deep scores under 0.7 (the measure can fail)."""
    import trimesh

    from physomni_usd.geometry.camera import PinholeCamera

    box = trimesh.creation.box((0.1, 0.06, 0.08))
    box.apply_translation([0.0, 0.0, 0.04])
    look = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])  # columns: right, down, forward = x, -z, y
    camera = PinholeCamera.from_pose(320, 240, 50.0, np.array([0.0, -0.6, 0.04]), look)
    centre = np.array([0.0, 0.0, 0.04])
    assert general._silhouette_alone(box, camera).sum() > 1000  # the box is in view
    off = box.copy()
    off.apply_translation([0.03, 0.1, 0.0])
    assert general.shape_novel_iou(off, box, camera, camera, 1.0, centre) > 0.97
    deep = box.copy()
    deep.vertices[:, 1] *= 2.5
    assert general.shape_novel_iou(deep, box, camera, camera, 1.0, centre) < 0.7


def test_the_sized_shape_takes_out_a_wrong_field_of_view_and_keeps_a_wrong_shape():
    """A box drawn right through a camera whose field of view's tangent is 0.6 of the truth's, its position
    fitted (as the one scale does: along the ray), comes out 0.6 as large: its shape from ±45° fails, and with
    its size taken out scores 1. A box 2.5× too deep still fails with its size taken out (it can fail)."""
    import trimesh

    from physomni_usd.geometry.camera import PinholeCamera

    box = trimesh.creation.box((0.1, 0.06, 0.08))
    box.apply_translation([0.0, 0.0, 0.04])
    look = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])  # columns: right, down, forward = x, -z, y
    camera = PinholeCamera.from_pose(320, 240, 50.0, np.array([0.0, -0.6, 0.04]), look)
    centre = np.array([0.0, 0.0, 0.04])
    small = box.copy()
    small.vertices = centre + 0.6 * (small.vertices - centre)
    assert general.shape_novel_iou(small, box, camera, camera, 1.0, centre) < 0.5
    assert general.sized_shape_novel_iou(small, box, camera, camera, 1.0, centre) > 0.97
    deep = box.copy()
    deep.vertices[:, 1] *= 2.5
    assert general.sized_shape_novel_iou(deep, box, camera, camera, 1.0, centre) < 0.7
    # too deep and drawn right across the ray, it is not shrunk across it (sized by its box's diagonal it was,
    # and scored as one a little too deep)
    assert general.sized_shape_novel_iou(deep, box, camera, camera, 1.0, centre) == pytest.approx(
        general.shape_novel_iou(deep, box, camera, camera, 1.0, centre), abs=1e-6)


def test_the_depth_split_tells_a_box_misplaced_in_depth_from_one_too_deep():
    """A box 8 cm too far along its ray: its depth error is 0.8 of its longest side, its depth extent right,
    and placed at the right depth it scores 1 from ±45° where as built it scores low. A box 2.5× too deep,
    placed right, keeps a low score with its depth error taken out: its extent says why."""
    import trimesh

    from physomni_usd.geometry.camera import PinholeCamera

    box = trimesh.creation.box((0.1, 0.06, 0.08))
    box.apply_translation([0.0, 0.0, 0.04])
    look = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])  # columns: right, down, forward = x, -z, y
    camera = PinholeCamera.from_pose(320, 240, 50.0, np.array([0.0, -0.6, 0.04]), look)
    centre = np.array([0.0, 0.0, 0.04])
    far = box.copy()
    far.apply_translation([0.0, 0.08, 0.0])
    split = general.depth_split(far, box, camera, camera, 1.0, centre)
    assert split["depth_position"] == pytest.approx(0.8, abs=0.01)
    assert split["depth_extent"] == pytest.approx(1.0, abs=0.01)
    assert split["iou_novel_depth_placed"] > 0.97
    assert general._novel_alone(far.vertices, far.faces, box, camera, centre) < 0.5
    deep = box.copy()
    deep.vertices[:, 1] *= 2.5
    split = general.depth_split(deep, box, camera, camera, 1.0, centre)
    assert split["depth_extent"] == pytest.approx(2.5, abs=0.01)
    assert abs(split["depth_position"]) < 0.01 and split["iou_novel_depth_placed"] < 0.7


def test_a_piled_fruit_rests_on_the_three_it_is_said_to_rest_on():
    """The truth of a pile: the fourth fruit touches each of the three under it (within 2 mm, none inside), as a
    photo of a pile shows it; a blob floating 5-7 mm over their hollow showed a gap no builder should bridge."""
    import trimesh

    from physomni_usd.bench import general_render

    piles = []
    for seed in range(200):
        group = general_render._group(np.random.default_rng(seed))
        if len(group) == 4 and group[3].get("on_k") == [0, 1, 2]:
            piles.append((seed, group))
        if len(piles) == 2:
            break
    assert len(piles) == 2
    for seed, group in piles:
        top = group[3]["mesh"]
        for k in range(3):
            inside = float(trimesh.proximity.signed_distance(group[k]["mesh"], top.vertices).max())
            assert -0.002 <= inside <= 0.0, f"group seed {seed}: the top fruit is {-inside * 1000:.1f} mm off fruit {k}"
