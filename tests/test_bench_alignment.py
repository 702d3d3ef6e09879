"""`bench alignment --quick`: every row of both tables, the JSON keys, and the full method's targets."""

from __future__ import annotations

import json

import pytest

from .conftest import cli

KEYS = {"table", "variant", "mask_iou", "penetration_rate", "support_violation_rate", "interaction_success_rate",
        "reprojection_px", "ssim", "seconds"}


@pytest.mark.slow  # 146 s under a load of 26; bench runs in the quick set through bench peer and faults
def test_quick_bench_writes_both_tables(tmp_path):
    out = tmp_path / "align.json"
    proc = cli("bench", "alignment", "--quick", "--only", "ablation", "--json", out, check=True)
    assert "coarse_to_fine" in proc.stdout and "agmf" in proc.stdout
    rows = json.loads(out.read_text())["rows"]
    assert {(r["table"], r["variant"]) for r in rows} == {
        ("scene", v) for v in ("none", "canonical", "ransac", "agmf")} | {
        ("camera", v) for v in ("initial", "global", "local", "coarse_to_fine")}
    assert all(KEYS <= set(r) for r in rows)
    full = next(r for r in rows if r["table"] == "scene" and r["variant"] == "agmf")
    assert full["mask_iou"] >= 0.9 and full["reprojection_px"] <= 3.0
    assert full["mesh_penetration_rate"] == 0.0 and full["support_violation_rate"] == 0.0
    assert full["interaction_success_rate"] == 1.0
    ransac = next(r for r in rows if r["table"] == "scene" and r["variant"] == "ransac")
    assert full["plane_error_deg"] < ransac["plane_error_deg"]


# --- the stacked scenes: issue 21's holistic acceptance on synthetic photos with truth --------------------------

STACKS = ("cup_saucer_spoon", "three_boxes", "bowl_of_spheres", "tray_of_parts")
#: Scenes whose objects miss a target on the code these tests were written on, with what was measured; once a
#: change meets it the test XPASSes and fails the run: remove the scene's entry then.
KNOWN_MISSES: dict = {}


@pytest.fixture(scope="module")
def stacks():
    from physomni_usd.bench.alignment import bench_stacks

    rows = bench_stacks(echo=lambda m: None)
    return {kind: [r for r in rows if r["scene"] == kind] for kind in STACKS}


def _known(kind: str, target: str):
    reason = KNOWN_MISSES.get((kind, target))
    return [pytest.mark.xfail(strict=True, reason=reason)] if reason else []


@pytest.mark.slow  # the stacked scenes' set-up: 281 s under a load of 26
def test_every_stacked_scene_has_a_row_per_true_object(stacks):
    from physomni_usd.bench.synthetic import make_stack

    for kind, rows in stacks.items():
        assert [r["label"] for r in rows] == make_stack(kind, 64, 48).labels, kind
        for r in rows:
            assert r["built"] and r["truth_mask_iou"] >= 0.9, r  # the painted masks agree with the ray-cast truth
            assert 0.0 <= r["iou_photo"] <= 1.0 and r["position_error_frac"] >= 0.0 and r["longest_m"] > 0


@pytest.mark.parametrize("kind,target", [pytest.param(k, t, marks=_known(k, t), id=f"{k}-{t}")
                                         for k in STACKS for t in ("iou", "position", "rest")])
@pytest.mark.slow  # the stacked scenes' set-up: 281 s under a load of 26
def test_stacked_scene_meets_the_holistic_targets(stacks, kind, target):
    from physomni_usd.bench.alignment import STACK_LIMITS as LIM

    for r in stacks[kind]:
        where = f"{kind} {r['object']}"
        if target == "iou":
            assert r["iou_photo"] >= LIM["iou_photo"], f"{where}: photo-view IoU {r['iou_photo']:.2f}"
            assert min(r["iou_left"], r["iou_right"]) >= LIM["iou_novel"], \
                f"{where}: orbited IoU {r['iou_left']:.2f} / {r['iou_right']:.2f}"
        elif target == "position":
            assert r["position_error_frac"] <= LIM["position_error_frac"], \
                f"{where}: position error {100 * r['position_error_frac']:.1f} % of the camera distance"
        else:
            assert r["error"] is None, f"{where}: {r['error']}"
            assert r["rest_drift_m"] <= LIM["rest_drift_m"], f"{where}: moved {1000 * r['rest_drift_m']:.1f} mm"
            assert r["max_overlap_m"] <= LIM["max_overlap_m"], f"{where}: starts {1000 * r['max_overlap_m']:.1f} mm in"


@pytest.mark.slow  # the stacked scenes' set-up: 281 s under a load of 26
def test_saucer_is_whole_behind_its_cup(stacks):
    saucer = next(r for r in stacks["cup_saucer_spoon"] if r["label"] == "saucer")
    assert saucer["full_outline_covered"] >= 0.9, saucer["full_outline_covered"]


def test_an_unknown_stacked_scene_is_named_in_one_line():
    proc = cli("bench", "alignment", "--only", "stacks", "--stack", "teapot")
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip() and not ln.startswith("TORCH_IMPORTED")]
    assert proc.returncode == 2 and len(lines) == 1, proc.stderr
    assert "--stack 'teapot'" in lines[0] and "cup_saucer_spoon" in lines[0]


def test_a_cup_pushed_off_its_saucer_leaves_saucer_where_it_stood(tmp_path):
    """The stacked cup scene, the cup pushed off (0.5 m/s sideways) for 1 s: where the cup stood in the photo and
    the saucer now shows, the frame has the saucer's colour, not the table's."""
    import cv2
    import numpy as np
    from pxr import Usd

    import physomni_usd as api
    from physomni_usd.align.external import visible_silhouettes
    from physomni_usd.bench.alignment import _built_camera
    from physomni_usd.bench.synthetic import make_stack
    from physomni_usd.metrics.geometry import world_meshes
    from physomni_usd.rendering.video import ShotRenderer
    from physomni_usd.settings import SimulateSettings

    scene = make_stack("cup_saucer_spoon")
    specs = []
    cv2.imwrite(str(tmp_path / "photo.png"), cv2.cvtColor(scene.photo, cv2.COLOR_RGB2BGR))
    for label, mask in zip(scene.labels, scene.masks):
        cv2.imwrite(str(tmp_path / f"{label}.png"), mask.astype(np.uint8) * 255)
        specs.append(f"{tmp_path / label}.png:{label}")
    result = api.build(tmp_path / "photo.png", tmp_path / "shot", specs, pushes=["cup=0.5,0,0"])
    api.simulate(result.shot, SimulateSettings(seconds=1.0))
    stage = Usd.Stage.Open(str(result.shot))
    end = stage.GetEndTimeCode()
    frame = ShotRenderer(stage).frame(end)
    report = json.loads((result.folder / "report.json").read_text())
    names = [o["name"] for o in report["objects"]]
    now = world_meshes(stage, end)
    camera = _built_camera(stage, report["shot"]["fov_deg"], scene.camera.width, scene.camera.height)
    seen = visible_silhouettes([now[n].vertices for n in names], [now[n].faces for n in names], camera)
    cup, saucer = scene.labels.index("cup"), scene.labels.index("saucer")
    where = scene.masks[cup] & seen[saucer]  # the cup stood there in the photo; the saucer shows there now
    assert where.sum() > 200, f"the cup did not leave the saucer ({int(where.sum())} px of it uncovered)"
    photo = scene.photo.astype(float)
    saucer_rgb = np.median(photo[scene.masks[saucer]], axis=0)
    table_rgb = np.median(photo[~np.any(scene.masks, axis=0)], axis=0)
    nearer_saucer = lambda px: (np.linalg.norm(px - saucer_rgb, axis=1)  # noqa: E731
                                < np.linalg.norm(px - table_rgb, axis=1))
    first = ShotRenderer(stage).frame(stage.GetStartTimeCode())
    assert nearer_saucer(first[scene.masks[saucer]].astype(float)).mean() >= 0.9  # frame 0 shows the saucer as such
    share = float(nearer_saucer(frame[where].astype(float)).mean())
    print(f"saucer colour on {100 * share:.0f} % of the {int(where.sum())} px where the cup stood")
    assert share >= 0.9, f"saucer colour on {100 * share:.0f} % of the {int(where.sum())} px where the cup stood"
