"""Issue 38, part 1 (nothing unpushed moves): the build's settle (``physics.settle``) simulates the written
shot with nothing pushed, keeps a small settling whose outline still matches the photo's, and names a fall."""

from __future__ import annotations

import pathlib

import numpy as np
import pytest

from physomni_usd.align.compare import silhouette
from physomni_usd.bench.scenes import BOX, BenchObject, box, write_bench_shot
from physomni_usd.geometry.camera import PinholeCamera
from physomni_usd.physics.settle import KEEP_M, Motion, Settled, judge, settle_shot
from physomni_usd.usd import layers

from .conftest import rendered_blocks

#: a camera nearer than write_bench_shot's (4 m back), so that the boxes' masks are 30 pixels wide, not 15
CAMERA = PinholeCamera(320, 240, 50.0, 10.0, (0.0, -1.6, 0.5))


def _scene(tmp_path):
    standing = box("standing", (-0.6, 0.0, BOX / 2))
    above = box("above", (0.0, 0.0, BOX / 2 + 0.01))  # placed 1 cm above the ground it stands on
    high = box("high", (0.6, 0.0, BOX / 2 + 0.3))  # 30 cm up with nothing under it: a fall
    pushed = BenchObject("pushed", box("pushed", (-0.6, 0.6, BOX / 2)).mesh, "rigid", {"density": 500.0},
                         velocity=(2.0, 0.0, 0.0))
    objects = [standing, above, high, pushed]
    return write_bench_shot(tmp_path, objects), objects


def test_the_settle_moves_what_gravity_moves_and_nothing_pushes(tmp_path):
    shot, objects = _scene(tmp_path)
    settled = settle_shot(layers.open_shot(shot, mute_sim=True), 1.0)
    assert settled.skipped is None
    m = settled.motions
    assert set(m) == {"standing", "above", "high", "pushed"}
    assert m["standing"].still and m["pushed"].still  # the shot's push is not the settle's
    assert 0.006 < m["above"].moved_m < 0.014 and m["above"].turned_deg < 2.0
    assert m["high"].moved_m > 0.25
    # the motion takes the placed points to where the body came to rest: on the ground
    dropped = m["above"].apply(objects[1].mesh.vertices)
    assert abs(dropped[:, 2].min()) < 0.004


def test_a_slow_tip_is_settled_to_its_end(tmp_path):
    """A tall box on one edge with its centre of mass 0.15° past it tips slowly at first (its top moves about
    a millimetre in 0.2 s): the settle runs on until it has fallen, not until a first still-looking moment."""
    import trimesh

    w, h = 0.05, 0.3
    mesh = trimesh.creation.box((w, w, h))
    mesh.apply_transform(trimesh.transformations.rotation_matrix(np.arctan2(w, h) + np.radians(0.15), (1, 0, 0)))
    mesh.apply_translation((0.0, 0.0, -mesh.bounds[0, 2]))
    shot = write_bench_shot(tmp_path, [BenchObject("tipping", mesh, "rigid", {"density": 500.0})])
    settled = settle_shot(layers.open_shot(shot, mute_sim=True), 2.0)
    assert settled.motions["tipping"].turned_deg > 45.0, settled.motions["tipping"]


def test_a_small_settling_that_keeps_the_outline_is_kept_and_a_fall_is_named(tmp_path):
    shot, objects = _scene(tmp_path)
    settled = settle_shot(layers.open_shot(shot, mute_sim=True), 2.0)
    names = [o.name for o in objects]
    verts, faces = [o.mesh.vertices for o in objects], [o.mesh.faces for o in objects]
    masks = [silhouette(v, f, CAMERA) for v, f in zip(verts, faces)]
    keep, far = judge(settled, names, verts, faces, CAMERA, masks)
    assert set(keep) == {"above"}
    assert set(far) == {"high"} and "nothing pushing it" in far["high"]


def test_what_is_still_moving_at_the_end_is_not_kept(tmp_path):
    """A pose the settle reached while the object still rolled is no rest pose: kept, the shot would start
    mid-roll."""
    shot, objects = _scene(tmp_path)
    names = [o.name for o in objects]
    verts, faces = [o.mesh.vertices for o in objects], [o.mesh.faces for o in objects]
    masks = [silhouette(v, f, CAMERA) for v, f in zip(verts, faces)]
    rolling = Motion("above", np.eye(3), np.array([0.0, 0.0, -0.01]), 0.01, 0.0, resting=False)
    keep, far = judge(Settled(motions={"above": rolling}, simulated_s=2.0), names, verts, faces, CAMERA, masks)
    assert not keep and "still moving" in far["above"]
    rolling.resting = True
    keep, far = judge(Settled(motions={"above": rolling}, simulated_s=2.0), names, verts, faces, CAMERA, masks)
    assert set(keep) == {"above"} and not far


def test_a_settling_that_leaves_the_outline_is_not_kept(tmp_path):
    shot, objects = _scene(tmp_path)
    names = [o.name for o in objects]
    verts, faces = [o.mesh.vertices for o in objects], [o.mesh.faces for o in objects]
    masks = [silhouette(v, f, CAMERA) for v, f in zip(verts, faces)]
    # 2.5 cm sideways is within what may be kept, but the box's outline moves off its mask at this distance
    # only when the mask is small: a mask from a camera close in (the shot's own sees 4 m away)
    near = PinholeCamera(320, 240, 50.0, 10.0, (0.0, -0.9, 0.3))
    masks = [silhouette(v, f, near) for v, f in zip(verts, faces)]
    slid = Motion("standing", np.eye(3), np.array([0.0, 0.0, 0.0]), 0.0, 0.0)
    sideways = Motion("above", np.eye(3), np.array([0.025, 0.0, -0.01]), 0.027, 0.0)
    settled = Settled(motions={"standing": slid, "above": sideways})
    assert sideways.moved_m < KEEP_M
    keep, far = judge(settled, names, verts, faces, near, masks)
    assert not keep and "no longer matches" in far["above"]


def test_build_settles_unless_told_not_to(tmp_path):
    """The build settles the written shot by default and says what each round found in ``report.json``
    (``shot.alignment.settle``); ``--settle 0`` writes it as placed."""
    import json

    from physomni_usd.building import build_shot
    from physomni_usd.settings import BuildSettings

    specs = _rendered_pair(tmp_path)
    build_shot(tmp_path / "photo.png", tmp_path / "plain", masks=specs, settings=BuildSettings(settle_s=0.0))
    plain = json.loads((tmp_path / "plain" / "report.json").read_text())
    assert "settle" not in plain["shot"]["alignment"]
    build_shot(tmp_path / "photo.png", tmp_path / "settled", masks=specs)
    settled = json.loads((tmp_path / "settled" / "report.json").read_text())["shot"]["alignment"]["settle"]
    assert settled["rounds"] and settled["rounds"][0]["simulated_s"] > 0.0, settled
    assert "skipped" not in settled, settled
    # two boxes standing on the ground: still, so the settle ends once they have been still a while
    assert settled["rounds"][0]["at_rest"] and settled["rounds"][0]["simulated_s"] < 2.0, settled
    assert len(settled["rounds"]) == 1, settled


def _fake_scene(objects):
    from types import SimpleNamespace

    from physomni_usd.settings import BuildSettings

    return SimpleNamespace(objects=[SimpleNamespace(name=o.name, vertices=np.asarray(o.mesh.vertices, float).copy(),
                                                    faces=np.asarray(o.mesh.faces)) for o in objects],
                           settings=BuildSettings(), camera=None, masks=None, align_info={})


def test_a_kept_pose_that_starts_inside_one_not_kept_is_dropped(tmp_path):
    """A settles into where B was; B slid and was not kept, so it is written back where the photo shows it:
    kept, A would start inside B and simulate would refuse the shot."""
    from physomni_usd.building import _settled_overlaps

    a, b = box("a", (0.0, 0.0, BOX / 2)), box("b", (BOX, 0.0, BOX / 2))
    shot = write_bench_shot(tmp_path, [a, b])
    scene = _fake_scene([a, b])
    placed = [o.vertices.copy() for o in scene.objects]
    # a corner of A 6 cm deep in B (the check measures vertices inside: sliding face to face has none)
    step = np.array([0.6, 0.3, -0.3]) * BOX
    into_b = Motion("a", np.eye(3), step, float(np.linalg.norm(step)), 0.0)
    assert _settled_overlaps(scene, {"a": into_b}, placed, shot.parent) == ["a"]
    # B moved on by as much: no overlap, A's pose stands
    away = Motion("b", np.eye(3), step, float(np.linalg.norm(step)), 0.0)
    assert _settled_overlaps(scene, {"a": into_b, "b": away}, placed, shot.parent) == []


def _settle_with(monkeypatch, tmp_path, objects, rounds, motions, supports=None, overlaps=()):
    """``building._settle`` on a stand-in scene of ``objects`` whose settle gives ``motions`` every round,
    judged as ``rounds`` (keep, gone) say, with ``overlaps`` the poses each round's overlap check drops:
    returns (the kept names of each write, ``alignment.settle``)."""
    from physomni_usd import building
    from physomni_usd.physics import prepare, settle

    scene = _fake_scene(objects)
    scene.align_info["supports"] = {n: {"on": on, "seen": "foot"} for n, on in (supports or {}).items()}
    judged, dropped = iter(rounds), iter(overlaps)
    monkeypatch.setattr(settle, "settle_shot", lambda *_: Settled(motions=dict(motions), simulated_s=2.0))
    monkeypatch.setattr(settle, "judge", lambda *_: next(judged))
    monkeypatch.setattr(building.layers, "open_shot", lambda *a, **k: None)
    monkeypatch.setattr(building, "_settled_overlaps", lambda *_: next(dropped, []))
    monkeypatch.setattr(prepare, "refuse_unsimulatable", lambda *a, **k: None)
    writes = []
    monkeypatch.setattr(building, "_rewrite_settled", lambda s, keep, *_: writes.append(sorted(keep)))
    building._settle(scene, tmp_path, None, {}, None, set(), lambda m: None)
    return writes, scene.align_info["settle"]


def test_a_pose_kept_then_judged_too_far_goes_back_to_the_photos(tmp_path, monkeypatch):
    """Round 1 keeps A's settled pose; round 2 finds it went on too far: the shot is written with A where
    the photo shows it, and the report says it is not kept — report and shot agree."""
    a = box("a", (0.0, 0.0, BOX / 2))
    small = Motion("a", np.eye(3), np.array([0.0, 0.0, -0.005]), 0.005, 0.0)
    writes, info = _settle_with(monkeypatch, tmp_path, [a], [({"a": small}, {}), ({}, {"a": "moved 5.0 cm"})],
                                {"a": small})
    assert writes == [["a"], []], writes
    assert info["kept"] == [] and "a" in info["not_kept"], info



def test_what_rests_on_another_and_what_holds_it_are_kept_together_or_not_at_all(tmp_path, monkeypatch):
    """Round 1 keeps a pot's and its plant's settled poses; round 2 finds the plant gone too far and the pot
    settled a little more. The plant goes back where the photo shows it, so the pot must too: kept alone, it
    would stand moved under a plant placed on where its rim was. A box beside them, kept, stays kept."""
    pot, plant, side = box("pot", (0.0, 0.0, BOX / 2)), box("plant", (0.0, 0.0, 1.5 * BOX)), box("side", (1, 0, 0.1))
    small = Motion("x", np.eye(3), np.array([0.0, 0.0, -0.005]), 0.005, 0.0)
    both = {"pot": small, "plant": small, "side": small}
    writes, info = _settle_with(monkeypatch, tmp_path, [pot, plant, side],
                                [(dict(both), {}), ({"pot": small}, {"plant": "moved 5.0 cm"})], both,
                                supports={"plant": "pot"})
    assert writes == [["plant", "pot", "side"], ["side"]], writes
    assert info["kept"] == ["side"] and {"pot", "plant"} <= set(info["not_kept"]), info


def test_the_tie_runs_only_through_what_goes_back(tmp_path, monkeypatch):
    """Two fruits in a bowl that stays where the photo shows it: one rolls away, the other settles a little and
    is kept (the bowl, not moving, ties nothing). And a kept pot dropped for starting inside another object takes
    its kept plant back with it, as a pot gone too far does."""
    from physomni_usd import building

    bowl, a, b = box("bowl", (0.0, 0.0, BOX / 2)), box("a", (0.0, 0.0, 1.5 * BOX)), box("b", (0.2, 0.0, 1.5 * BOX))
    small = Motion("x", np.eye(3), np.array([0.0, 0.0, -0.005]), 0.005, 0.0)
    three = {n: small for n in ("bowl", "a", "b")}
    writes, info = _settle_with(monkeypatch, tmp_path, [bowl, a, b], [({"b": small}, {"a": "moved 5.0 cm"})] * 2,
                                three, supports={"a": "bowl", "b": "bowl"})
    assert writes == [["b"]] and info["kept"] == ["b"], (writes, info)
    assert info["not_kept"] == {"a": "moved 5.0 cm"}, info

    pot, plant = box("pot", (0.0, 0.0, BOX / 2)), box("plant", (0.0, 0.0, 1.5 * BOX))
    both = {"pot": small, "plant": small}
    _, info = _settle_with(monkeypatch, tmp_path, [pot, plant], [(dict(both), {}), ({}, {})], both,
                           supports={"plant": "pot"}, overlaps=[["pot"]])
    assert info["kept"] == [] and info["not_kept"]["plant"] == building.TIED, info
    assert info["rounds"][0]["overlapping"] == ["pot", "plant"], info


def test_a_settled_write_the_simulator_refuses_goes_back_with_a_warning(tmp_path, monkeypatch):
    from physomni_usd import building
    from physomni_usd.errors import PhysOmniError
    from physomni_usd.physics import settle

    a = box("a", (0.0, 0.0, BOX / 2))
    scene = _fake_scene([a])
    small = Motion("a", np.eye(3), np.array([0.0, 0.0, -0.005]), 0.005, 0.0)
    calls = []

    def settle_once(*_):
        calls.append(1)
        if len(calls) > 1:
            raise PhysOmniError("a starts 2 cm inside b")
        return Settled(motions={"a": small}, simulated_s=2.0)

    monkeypatch.setattr(settle, "settle_shot", settle_once)
    monkeypatch.setattr(settle, "judge", lambda *_: ({"a": small}, {}))
    monkeypatch.setattr(building.layers, "open_shot", lambda *a, **k: None)
    monkeypatch.setattr(building, "_settled_overlaps", lambda *_: [])
    writes, said = [], []
    monkeypatch.setattr(building, "_rewrite_settled", lambda s, keep, *_: writes.append(sorted(keep)))
    building._settle(scene, tmp_path, None, {}, None, set(), said.append)
    info = scene.align_info["settle"]
    assert writes == [["a"], []], writes
    assert "skipped" not in info and "inside b" in info["refused"] and info["kept"] == [], info
    assert any(m.startswith("warning:") and "photo's poses" in m for m in said), said


def test_the_settle_skips_a_shot_with_force_fields_before_building_a_model(tmp_path, monkeypatch):
    from physomni_usd import building
    from physomni_usd.physics import settle

    scene = _fake_scene([box("a", (0.0, 0.0, BOX / 2))])
    monkeypatch.setattr(settle, "settle_shot", lambda *_: (_ for _ in ()).throw(AssertionError("built a model")))
    building._settle(scene, tmp_path, None, {}, [object()], set(), lambda m: None)
    assert scene.align_info["settle"]["skipped"] == "force fields act on the shot"


def test_the_settle_reads_the_builds_own_layers_not_the_artists_edits(tmp_path):
    """An artist's transform override in edits.usda is not what the settle measures (its motion is applied to
    the build's vertices)."""
    from pxr import Sdf, UsdGeom

    from physomni_usd.usd.author import OBJECTS

    shot = write_bench_shot(tmp_path, [box("a", (0.0, 0.0, BOX / 2))])
    edits = Sdf.Layer.FindOrOpen(str(shot.parent / layers.EDITS))
    stage = layers.open_shot(shot, mute_sim=True)
    stage.SetEditTarget(edits)
    xf = UsdGeom.Xformable(stage.GetPrimAtPath(f"{OBJECTS}/a"))
    xf.ClearXformOpOrder()
    xf.AddTranslateOp().Set((0.0, 0.0, 1.0))
    edits.Save()
    z = lambda s: UsdGeom.Xformable(s.GetPrimAtPath(f"{OBJECTS}/a")).ComputeLocalToWorldTransform(0)[3][2]
    assert z(layers.open_shot(shot, mute_sim=True)) > 0.5  # the edit composes in the shot
    assert z(layers.open_shot(shot, mute_sim=True, mute_edits=True)) < 0.5
    assert "xformOp:translate" in (shot.parent / layers.EDITS).read_text()  # muted, not changed



def test_a_settle_goes_on_while_what_moves_could_still_be_kept_and_no_longer(tmp_path, monkeypatch):
    """A settle not at rest after its seconds runs on while something still moving has gone no farther than a
    kept pose may (a fruit finding the bottom of a hollow comes to rest after the settle's seconds), and ends
    once what still moves has gone farther (a fall): it does not wait for that to come to rest. Here the
    settle's seconds end while the box 1 cm up is still dropping (no rest pose yet) and the one 30 cm up falls
    on after the first has come to rest."""
    from physomni_usd.physics import settle

    monkeypatch.setattr(settle, "SETTLE_LONGER", 10.0)  # the mechanism, not the build's bound, on a short settle
    shot, objects = _scene(tmp_path)
    seconds = 0.1
    settled = settle_shot(layers.open_shot(shot, mute_sim=True), seconds)
    m = settled.motions
    fall_s = np.sqrt(2 * 0.3 / 9.81)  # when the high box reaches the ground
    assert seconds < settled.simulated_s < fall_s and not settled.at_rest, settled
    assert m["above"].resting and 0.006 < m["above"].moved_m < 0.014, m["above"]
    assert m["high"].moved_m > KEEP_M and not m["high"].resting, m["high"]


def _rendered_pair(tmp_path):
    """A book-sized block and a small one beside it on the ground, rendered into ``tmp_path``: their masks."""
    import trimesh

    camera = PinholeCamera(240, 180, 50.0, 30.0, (0.0, -0.55, 0.35))
    truth = []
    for size, at in (((0.30, 0.20, 0.10), (0, 0, 0)), ((0.07, 0.07, 0.07), (0.25, -0.05, 0.0))):
        b = trimesh.creation.box(size)
        b.apply_translation([at[0], at[1], at[2] + size[2] / 2])
        truth.append(b)
    return rendered_blocks(tmp_path, camera, truth)


def _two_blocks(tmp_path, monkeypatch, diverges=lambda run: True):
    """A book-sized block and a small one beside it, rendered, and a guard whose energy reads 1 kJ above its
    budget at every check past frame 2 of a run where ``diverges(run)``: no step passes."""
    from physomni_usd.physics import runner

    specs = _rendered_pair(tmp_path)
    check = runner.GuardedRun._check
    runs = []

    def growing(self):
        runs.append(self.frame)
        if self.frame <= 2 or not diverges(self):
            return check(self)
        self.guard.initial -= 1000.0
        try:
            return check(self)
        finally:
            self.guard.initial += 1000.0

    monkeypatch.setattr(runner.GuardedRun, "_check", growing)
    out = tmp_path / "out"
    out.mkdir()
    return specs, out, runs


def test_a_build_whose_settle_diverges_as_placed_is_refused_naming_what_diverged(tmp_path, monkeypatch):
    """Where the settle of the shot as placed diverges (every check of the guard fails past the first frames,
    so that it gives up at its finest step), the build ends with one line naming what diverged and puts the
    output folder back as it was; it used to record the divergence as a skipped settle and write a shot that
    ``simulate`` diverges on."""
    from physomni_usd.building import build_shot
    from physomni_usd.errors import PhysOmniError

    specs, out, runs = _two_blocks(tmp_path, monkeypatch)
    (out / "notes.txt").write_text("mine")
    with pytest.raises(PhysOmniError) as caught:
        build_shot(tmp_path / "photo.png", out, masks=specs)
    line = str(caught.value)
    assert runs and "\n" not in line, line
    assert "the shot as placed diverges with nothing pushed" in line and "fastest: block" in line, line
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt"] and (out / "notes.txt").read_text() == "mine"


def test_a_settle_given_up_on_a_slow_frame_is_no_divergence_and_the_build_goes_on(tmp_path, monkeypatch):
    """A run that gives up because a frame took longer than its wall-clock budget (load, a first kernel
    compile) has not shown the shot diverges: the build is written, its settle recorded as skipped."""
    from physomni_usd.building import build_shot
    from physomni_usd.physics import runner
    from physomni_usd.report import read_report

    specs, out, runs = _two_blocks(tmp_path, monkeypatch)
    monkeypatch.setattr(runner, "FRAME_WALL_BUDGET_S", -1.0)  # every frame over budget: gives up at once
    build_shot(tmp_path / "photo.png", out, masks=specs)
    settle = read_report(out)["shot"]["alignment"]["settle"]
    assert runs and "simulation stuck at frame" in settle["skipped"], settle
    assert (out / layers.SHOT).exists()


def test_a_settle_that_diverges_only_without_the_artists_edits_does_not_refuse_the_build(tmp_path, monkeypatch):
    """The settle steps the build's own layers; ``simulate`` composes ``edits.usda`` too. Where the artist's
    layer holds every object fixed and the shot diverges only with an object free, the build is written (with
    a warning) and not refused for what ``simulate`` would not do."""
    from pxr import Sdf

    from physomni_usd.building import build_shot

    def free(run):
        return any(not p.GetAttribute("physomni:fixed").Get()
                   for p in run.stage.GetPrimAtPath("/World/Objects").GetChildren())

    specs, out, runs = _two_blocks(tmp_path, monkeypatch, diverges=free)
    edits = Sdf.Layer.CreateNew(str(out / layers.EDITS))
    for n in ("block_0", "block_1"):
        spec = Sdf.CreatePrimInLayer(edits, f"/World/Objects/{n}")
        spec.specifier = Sdf.SpecifierOver
        Sdf.AttributeSpec(spec, "physomni:fixed", Sdf.ValueTypeNames.Bool).default = True
    edits.Save()
    said = []
    build_shot(tmp_path / "photo.png", out, masks=specs, echo=said.append)
    assert runs and (out / layers.SHOT).exists()
    assert any(m.startswith("warning: the shot as placed diverges without edits.usda") for m in said), said


def test_a_refusal_names_each_pair_once():
    """Two diverging objects, one on the other: the pair is named once, with what each rests on."""
    from physomni_usd.building import _refuse_placed
    from physomni_usd.errors import PhysOmniError
    from physomni_usd.physics.runner import Diverged

    exc = Diverged("simulation diverged at frame 3", ["cup_1", "book_0"])
    with pytest.raises(PhysOmniError) as caught:
        _refuse_placed(exc, {"cup_1": "book_0", "book_0": "table_2"}, pathlib.Path("nowhere"), 1.0, print)
    assert "(cup_1 on book_0; book_0 on table_2): simulation diverged at frame 3" in str(caught.value)


def test_the_fastest_is_told_by_its_spin_too_and_particles_by_theirs():
    """The object named where a run diverges is the one whose points move fastest: a small block spinning at
    20 rad/s (its points at 1.5 m/s) before one sliding at 1 m/s; particles faster still are named as such."""
    from types import SimpleNamespace

    from physomni_usd.physics.runner import _fastest

    class Array:
        def __init__(self, a):
            self.a = np.asarray(a, dtype=np.float32)

        def numpy(self):
            return self.a

    inertia = 1.0 * 2 * 0.1 ** 2 / 12 * np.eye(3)  # a 1 kg, 10 cm cube: radius of gyration 5 cm
    model = SimpleNamespace(body_count=2, body_mass=Array([1.0, 1.0]), body_inertia=Array([inertia, inertia]),
                            particle_count=0)
    state = SimpleNamespace(body_qd=Array([[1.0, 0, 0, 0, 0, 0], [0.5, 0, 0, 0, 0, 20.0]]))
    stepper = SimpleNamespace(model=model, state=state, mpm=None)
    bodies = {0: "sliding", 1: "spinning"}
    assert _fastest(stepper, bodies)[0] == ["spinning"]
    model.particle_count = 2
    model.particle_mass, state.particle_qd = Array([1.0, 1.0]), Array([[0, 0, 0], [0, 3.0, 0]])
    assert _fastest(stepper, bodies) == (["particles"], "; fastest: particles (3 m/s)")
    state.particle_qd = Array([[0, 0, 0], [0, np.nan, 0]])
    assert _fastest(stepper, bodies)[0] == ["particles"]
