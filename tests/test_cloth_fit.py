"""A solid made cloth (issue 38, part 1): its density as a solid becomes the cloth's areal density by its
thickness, and a thin object welded into one sheet keeps one layer of triangles (``physics/cloth.py``:
:func:`areal_density`, :func:`manifold_sheet`; ``physics/objects.py``: :func:`authored_with`)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from pxr import Sdf, Usd

from physomni_usd.physics.cloth import areal_density, cloth_sheet, manifold_sheet, triangle_quality
from physomni_usd.physics.objects import SimObject, authored_with


def _edge_counts(tris):
    e = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    return np.unique(e, axis=0, return_counts=True)[1]


def test_a_thin_slab_welded_into_one_sheet_keeps_one_layer():
    slab = trimesh.creation.box((0.2, 0.05, 0.002))  # its two faces closer than the weld: one sheet
    sheet = cloth_sheet(slab.vertices, slab.faces)
    assert _edge_counts(sheet.triangles).max() <= 2
    area = 0.5 * np.linalg.norm(np.cross(*(sheet.particles[sheet.triangles[:, k]] - sheet.particles[sheet.triangles[:, 0]]
                                             for k in (1, 2))), axis=1).sum()
    assert abs(area - 0.2 * 0.05) < 0.15 * 0.2 * 0.05  # one layer's area, not two


def test_a_quad_in_both_triangulations_keeps_two_triangles_and_a_closed_surface_keeps_all():
    quad = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    both = np.array([[0, 1, 2], [0, 2, 3], [0, 1, 3], [1, 2, 3]])
    kept = manifold_sheet(quad, both, triangle_quality(quad, both))
    assert len(kept) == 2 and _edge_counts(kept).max() == 1 + (len(kept) == 2)  # the shared diagonal only
    ball = trimesh.creation.icosphere(2)
    tris = np.asarray(ball.faces)
    assert len(manifold_sheet(ball.vertices, tris, triangle_quality(ball.vertices, tris))) == len(tris)


def _material(tmp_path, weaker_type, stronger_type, density_in):
    """A material whose type is ``weaker_type`` in the weaker layer and ``stronger_type`` in the stronger
    one (None: not authored there), its density authored in ``density_in`` ('weak' or 'strong')."""
    weak, strong = Sdf.Layer.CreateNew(str(tmp_path / "weak.usda")), Sdf.Layer.CreateNew(str(tmp_path / "strong.usda"))
    root = Sdf.Layer.CreateNew(str(tmp_path / "root.usda"))
    root.subLayerPaths[:] = [strong.identifier, weak.identifier]
    stage = Usd.Stage.Open(root)
    for layer, kind, density in ((weak, weaker_type, density_in == "weak"), (strong, stronger_type, density_in == "strong")):
        stage.SetEditTarget(layer)
        prim = stage.OverridePrim("/M")
        if kind:
            prim.CreateAttribute("physomni:materialType", Sdf.ValueTypeNames.Token).Set(kind)
        if density:
            prim.CreateAttribute("physics:density", Sdf.ValueTypeNames.Float).Set(200.0)
    return stage, stage.GetPrimAtPath("/M")


def test_a_density_means_what_the_type_it_was_written_with_says(tmp_path):
    cases = [(("rigid", "pbd_cloth", "weak"), "rigid"),  # the estimate's rigid density, the edits' switch to cloth
             (("rigid", "pbd_cloth", "strong"), "pbd_cloth"),  # the edits set the cloth's density too
             (("pbd_cloth", None, "strong"), "pbd_cloth")]  # the edits set it over a cloth the estimate made
    for k, (args, kind) in enumerate(cases):
        (tmp_path / str(k)).mkdir()
        stage, prim = _material(tmp_path / str(k), *args)
        assert authored_with(prim, "physics:density") == kind, args


def test_a_solid_made_cloth_weighs_what_the_solid_did():
    box = trimesh.creation.box((0.1, 0.04, 0.02))
    sheet = cloth_sheet(box.vertices, box.faces)
    obj = SimObject(None, "pbd_cloth", {"density": 200.0}, False, np.asarray(box.vertices), np.asarray(box.faces),
                    np.eye(4), {"density": "rules"}, volume_density=200.0)
    tris = sheet.particles[sheet.triangles]
    area = 0.5 * np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1).sum()
    assert abs(areal_density(obj, sheet) * area - 200.0 * box.volume) < 1e-9
    obj.volume_density = None  # a cloth's own density is kg/m² as authored
    assert areal_density(obj, sheet) == 200.0


def test_a_light_cloth_is_no_stiffer_than_the_step_cap_resolves():
    """A 3 cm disc as cloth (4 mm thick, 200 kg/m³ as a solid: 0.6 g) asks, at the stiffness clamp, more substeps
    than the plan's cap and was stepped beyond the cloth rule; its springs and bending are softened alike until
    the rule asks no more than the cap. A 1 m sheet of the catalog's cloth keeps the clamp's stiffness."""
    from types import SimpleNamespace

    from physomni_usd._warp import load_newton, load_warp
    from physomni_usd.physics.cloth import CLOTH_BEND_KE, CLOTH_SPRING_KE, add_cloth
    from physomni_usd.physics.stability import MAX_SUBSTEPS, PlanInputs, plan_steps

    wp, newton = load_warp(), load_newton()
    prim = SimpleNamespace(GetAttribute=lambda name: SimpleNamespace(Get=lambda: None))

    def cloth(mesh, volume_density, fps=30.0, substeps=None):
        obj = SimpleNamespace(points=np.asarray(mesh.vertices), faces=np.asarray(mesh.faces), params={},
                              fixed=False, path="/World/Objects/c", volume_density=volume_density, prim=prim,
                              trimesh=lambda: mesh)
        builder = newton.ModelBuilder(up_axis=newton.Axis.Z)
        start, count, made = add_cloth(builder, obj, wp, fps, substeps)
        masses = np.asarray(builder.particle_mass[start:start + count])
        plan = plan_steps(PlanInputs([], fps, substeps or 8, cloth_masses=masses, fixed_substeps=bool(substeps),
                                     cloth_stiffness=max(builder.spring_stiffness)))
        bend = max(p[0] for p in builder.edge_bending_properties)
        # what report.json says of it: the stiffness simulated, and what it was softened from, if it was
        assert made.spring_n_m == pytest.approx(max(builder.spring_stiffness), rel=1e-6)
        softened.append(made.softened_from_n_m)
        if made.softened_from_n_m:  # the substeps the line says its springs needed: the rule's, unsoftened
            stiff = plan_steps(PlanInputs([], fps, 8, cloth_masses=masses, cloth_stiffness=made.softened_from_n_m))
            assert made.needs_substeps == stiff.reasons["cloth"]["substeps"] > (substeps or MAX_SUBSTEPS)
        else:
            assert made.needs_substeps is None
        return plan, max(builder.spring_stiffness), bend

    softened = []

    coin = trimesh.creation.cylinder(radius=0.015, height=0.004, sections=32)
    for fps in (30.0, 60.0):
        plan, stretch, bend = cloth(coin, 200.0, fps)
        assert stretch < CLOTH_SPRING_KE[1] and not plan.reasons["cloth"]["capped"], plan.reasons
        assert plan.reasons["cloth"]["substeps"] == MAX_SUBSTEPS
        assert bend / CLOTH_BEND_KE[1] == pytest.approx(stretch / CLOTH_SPRING_KE[1], rel=1e-6)
    sheet = trimesh.creation.box((1.0, 1.0, 0.002))
    plan, stretch, bend = cloth(sheet, None)
    assert stretch == CLOTH_SPRING_KE[1] and bend == CLOTH_BEND_KE[1] and plan.substeps < MAX_SUBSTEPS
    assert softened == [CLOTH_SPRING_KE[1], CLOTH_SPRING_KE[1], None], softened
    # the user's substeps: the springs are softened to what those resolve, not to the cap's, and the plan,
    # taking exactly them, meets the rule
    _, at_cap, _ = cloth(coin, 200.0)
    for substeps in (100, 2 * MAX_SUBSTEPS):
        plan, given, _ = cloth(coin, 200.0, 30.0, substeps)
        assert plan.substeps == substeps and plan.reasons["cloth"]["substeps"] <= substeps
        assert not plan.reasons["cloth"]["capped"], plan.reasons
        assert given == pytest.approx(min(CLOTH_SPRING_KE[1], at_cap * (substeps / MAX_SUBSTEPS) ** 2), rel=1e-4)
    # so is a cloth at the clamp under fewer substeps than it asks
    plan, given, _ = cloth(sheet, None, 30.0, 4)
    assert given < CLOTH_SPRING_KE[1] and plan.reasons["cloth"]["substeps"] == 4, plan.reasons
    assert not plan.reasons["cloth"]["capped"]
    # a plan whose given substeps fall short of the rule says so
    short = plan_steps(PlanInputs([], 30.0, 4, cloth_masses=np.array([1e-3]), cloth_stiffness=100.0,
                                  fixed_substeps=True))
    assert short.substeps == 4 and short.reasons["cloth"]["capped"], short.reasons


def test_a_softened_cloth_is_said_and_reported(tmp_path):
    """A light coin made cloth is simulated with softer springs than its material asks: ``simulate`` says so in
    one line and report.json's cloth entry gives both stiffnesses; a cloth left as asked says nothing."""
    from physomni_usd.bench.scenes import BenchObject, write_bench_shot
    from physomni_usd.physics.simulate import simulate_shot
    from physomni_usd.settings import SimulateSettings

    def run(density, substeps=None):
        coin = trimesh.creation.cylinder(radius=0.015, height=0.004, sections=32)
        coin.apply_translation((0.0, 0.0, 0.01))
        shot = write_bench_shot(tmp_path / f"{density}-{substeps}",
                                [BenchObject("coin", coin, "pbd_cloth", {"density": density})])
        said = []
        section = simulate_shot(shot, SimulateSettings(seconds=0.05, substeps=substeps), echo=said.append)
        return [line for line in said if "softened" in line], section["cloths"]["coin"]

    lines, entry = run(0.1)
    assert len(lines) == 1 and "coin" in lines[0] and "fps" in lines[0], lines
    assert entry["softened_from_n_m"] == 100.0 and 0 < entry["spring_n_m"] < 100.0, entry
    at_cap = entry["spring_n_m"]
    lines, entry = run(200.0)
    assert lines == [] and "softened_from_n_m" not in entry and entry["spring_n_m"] == 100.0, entry
    # the user's substeps: softened to what they resolve, and the line names the option that steps finer
    lines, entry = run(0.1, substeps=100)
    assert len(lines) == 1 and "--substeps 100 resolves only" in lines[0], lines
    assert entry["spring_n_m"] == pytest.approx(at_cap / 100, rel=1e-2), (at_cap, entry)  # both rounded


def test_the_cloth_rule_pairs_each_particle_with_its_own_stiffest_spring(tmp_path):
    """Two cloths and a soft body in one model: a light coin (softened below the clamp), a heavy sheet at the
    clamp and a jelly whose particles have no springs. The plan must read the coin's lightest particle with the
    coin's own (softened) springs: the sheet's 100 N/m on the coin's mass, or a soft body's particle read as
    a cloth's, would ask beyond the cap and name another particle or stiffness."""
    from physomni_usd.bench.scenes import BenchObject, write_bench_shot
    from physomni_usd.physics.cloth import CLOTH_SPRING_KE
    from physomni_usd.physics.prepare import prepare_simulation
    from physomni_usd.physics.stability import MAX_SUBSTEPS
    from physomni_usd.settings import SimulateSettings
    from physomni_usd.usd import layers

    coin = trimesh.creation.cylinder(radius=0.015, height=0.004, sections=32)
    coin.apply_translation((-0.3, 0.0, 0.01))
    sheet = trimesh.creation.box((0.3, 0.3, 0.004))
    sheet.apply_translation((0.3, 0.0, 0.01))
    jelly = trimesh.creation.box((0.01, 0.01, 0.01))
    jelly.apply_translation((0.0, 0.3, 0.005))
    shot = write_bench_shot(tmp_path / "shot", [BenchObject("coin", coin, "pbd_cloth", {"density": 0.1}),
                                                BenchObject("sheet", sheet, "pbd_cloth", {"density": 200.0}),
                                                BenchObject("jelly", jelly, "pbd_elastic", {"density": 1.0})])
    prepared = prepare_simulation(layers.open_shot(shot, mute_sim=True), SimulateSettings(seconds=0.1))
    models, cloth = prepared.models, prepared.plan.reasons["cloth"]
    masses = models.model.particle_mass.numpy()
    (c0, cn), (s0, sn), (j0, jn) = (models.ranges[f"/World/Objects/{n}"] for n in ("coin", "sheet", "jelly"))
    coin_k = models.cloth_sheets["/World/Objects/coin"].spring_n_m
    assert coin_k < CLOTH_SPRING_KE[1] == models.cloth_sheets["/World/Objects/sheet"].spring_n_m
    # the jelly's particles are the lightest of all, the coin's the lightest of the cloths
    assert masses[j0:j0 + jn].min() < masses[c0:c0 + cn].min() < masses[s0:s0 + sn].min()
    assert cloth["particle_kg"] == pytest.approx(float(masses[c0:c0 + cn][masses[c0:c0 + cn] > 0].min()), rel=1e-6)
    assert cloth["stiffness_n_m"] == pytest.approx(coin_k, rel=1e-6)
    assert cloth["substeps"] <= MAX_SUBSTEPS and not cloth["capped"], cloth


def test_a_cloth_lands_the_same_whether_its_contacts_are_reused_or_searched_every_substep(tmp_path):
    """The physics of contact reuse, not its arithmetic: a light coin cloth (1000 substeps a frame) dropped 3.2 cm
    onto a 1 cm slab, stepped by the product's guarded run with its plan's reuse and again searching every
    substep, rests at the same height and never sinks into the slab. Contacts searched only once a frame (the
    speed bound ignored) let it fall into the slab (min z 0.021 m against the top's 0.040 m, when this was written),
    so the check can fail."""
    import dataclasses

    from physomni_usd.bench.scenes import BenchObject, write_bench_shot
    from physomni_usd.physics.prepare import prepare_simulation
    from physomni_usd.physics.runner import run_guarded
    from physomni_usd.settings import SimulateSettings
    from physomni_usd.usd import layers

    slab = trimesh.creation.box((0.1, 0.1, 0.01))
    slab.apply_translation((0.0, 0.0, 0.035))
    coin = trimesh.creation.cylinder(radius=0.015, height=0.004, sections=32)
    coin.apply_translation((0.0, 0.0, 0.072))
    shot = write_bench_shot(tmp_path / "shot", [BenchObject("slab", slab, "rigid", {"density": 500.0}, fixed=True),
                                                BenchObject("coin", coin, "pbd_cloth", {"density": 0.1})])
    rests = []
    for every in (None, 1):
        prepared = prepare_simulation(layers.open_shot(shot, mute_sim=True), SimulateSettings(seconds=0.3))
        plan = prepared.plan if every is None else dataclasses.replace(prepared.plan, collide_every=every)
        if every is None:
            assert plan.collide_every > 1 and plan.particle_gap, plan.as_dict()
        run_guarded(prepared.models, plan, 0.3)
        z = prepared.models.stepper.state.particle_q.numpy()[:, 2]
        radius = float(prepared.models.model.particle_radius.numpy().max())
        assert z.min() >= 0.04 - radius, (every, float(z.min()))
        rests.append(float(z.mean()))
    assert rests[0] == pytest.approx(rests[1], abs=5e-4), rests
