"""Deformable materials: routing to Newton's solvers, time-sampled output, steps from the materials,
and the guard that rolls a diverging frame back."""

import json
import shutil

import numpy as np
import pytest
from pxr import Usd, UsdGeom

from physomni_usd.physics.cloth import voxel_tets
from physomni_usd.physics.mpm import bind_surface, deform_surface, newton_parameters, sample_inside
from physomni_usd.physics.stability import Guard

from .conftest import cli


def _switched(tmp_path, shot, material, seconds="0.4", extra=()):
    out = tmp_path / "shot"
    shutil.copytree(shot["dir"], out)
    cli("estimate", out / "shot.usda", "--set", f"cup.material={material}", check=True)
    proc = cli("simulate", out / "shot.usda", "--seconds", seconds, "--particle-spacing", "0.06", *extra, check=True)
    report = json.loads((out / "report.json").read_text())["stages"]["simulate"]
    return out, Usd.Stage.Open(str(out / "shot.usda")), report, proc


def test_rigid_only_scene_builds_only_the_rigid_solver(shot):
    report = json.loads((shot["dir"] / "report.json").read_text())["stages"]["simulate"]
    assert report["solvers"] == ["xpbd"] and report["mpm"] is None
    assert report["cloths"] == {} and report["soft_bodies"] == {}


def test_no_mpm_kernels_compiled_for_a_rigid_scene(tmp_path, shot):
    out = tmp_path / "shot"
    shutil.copytree(shot["dir"], out)
    script = ("import sys, warp\nfrom physomni_usd.physics.simulate import simulate_shot\n"
              "from physomni_usd.settings import SimulateSettings\n"
              f"simulate_shot({str(out / 'shot.usda')!r}, SimulateSettings(seconds=0.1))\n"
              "from warp._src import context\n"
              "loaded = [m.name for m in context.user_modules.values() if m.execs]\n"
              "print('LOADED', ' '.join(loaded))\n"
              "print('IMPORTED', ' '.join(sorted(sys.modules)))\n")
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True)
    line = next(x for x in proc.stdout.splitlines() if x.startswith("LOADED"))
    assert "solvers.xpbd" in line
    assert "implicit_mpm" not in line and "style3d" not in line and "vbd" not in line
    # nor are the deformable solvers' modules imported (each defines its kernels on import), nor the
    # libraries only other solvers use
    imported = next(x for x in proc.stdout.splitlines() if x.startswith("IMPORTED")).split()[1:]
    assert "newton._src.solvers.xpbd" in imported
    unneeded = ("newton._src.solvers.implicit_mpm", "newton._src.solvers.vbd", "newton._src.solvers.style3d",
                "newton._src.solvers.featherstone", "mujoco", "mujoco_warp", "torch")
    assert not [m for m in imported if m in unneeded or m.startswith(tuple(u + "." for u in unneeded))]


@pytest.mark.slow  # sand 203 s, liquid 66 s on a loaded 2-core machine; a quicker test runs the same solver
@pytest.mark.parametrize("material", ["mpm_sand", "mpm_liquid"])
def test_flowing_materials_become_time_sampled_particles(tmp_path, shot, material):
    out, stage, report, _ = _switched(tmp_path, shot, material)
    assert report["solvers"] == ["xpbd", "implicit_mpm"] and report["objects"]["cup_0"]["solver"] == "mpm"
    points = UsdGeom.Points(stage.GetPrimAtPath("/World/Particles/cup_0"))
    attr = points.GetPointsAttr()
    assert attr.GetNumTimeSamples() == stage.GetEndTimeCode() + 1
    first, last = np.array(attr.Get(0)), np.array(attr.Get(stage.GetEndTimeCode()))
    assert len(first) == report["mpm"]["particles"] > 50 and np.isfinite(last).all()
    assert np.abs(last - first).max() > 0.02  # it flows
    assert last[:, 2].min() > -0.06  # the ground holds it
    mesh = UsdGeom.Imageable(stage.GetPrimAtPath("/World/Objects/cup_0"))
    assert mesh.ComputeVisibility(0) != "invisible" and mesh.ComputeVisibility(1) == "invisible"
    assert points.ComputeVisibility(0) == "invisible" and points.ComputeVisibility(1) != "invisible"
    assert cli("validate", out / "shot.usda").returncode == 0
    assert report["steps"]["mpm_steps"] >= 1 and "mpm_cfl" in report["steps"]["reasons"]
    if material == "mpm_sand":  # the particles are drawn, and shade the ground under them
        from physomni_usd.rendering.stage import read_camera
        from physomni_usd.rendering.video import ShotRenderer

        renderer = ShotRenderer(stage)
        end = stage.GetEndTimeCode()
        cam = read_camera(stage, Usd.TimeCode(end), renderer.width, renderer.height)
        shadow_at = lambda t: renderer._particle_shadow(cam, renderer._visible_particles(Usd.TimeCode(t)))  # noqa: E731
        assert shadow_at(end).max() > 0.05
        assert shadow_at(0).max() == 0  # frame 0: the mesh, not particles
        assert np.abs(renderer.frame(end).astype(float) - renderer.frame(0)).max() > 30


@pytest.mark.slow  # 57 s on a loaded 2-core machine; a quicker test runs the same solver
def test_elastic_object_keeps_its_textured_surface_and_deforms(tmp_path, shot):
    # a preview's MPM steps, as a user would ask for them (the default for elastic solids is 16)
    out, stage, report, _ = _switched(tmp_path, shot, "mpm_elastic", extra=("--mpm-steps", "3"))
    assert report["steps"]["mpm_steps"] == 3 and report["steps"]["reasons"]["mpm_cfl"]["given"] == 3
    assert report["substeps"] % 3 == 0
    pts = stage.GetPrimAtPath("/World/Objects/cup_0").GetAttribute("points")
    assert pts.GetNumTimeSamples() == stage.GetEndTimeCode() + 1
    a, b = np.array(pts.Get(0)), np.array(pts.Get(stage.GetEndTimeCode()))
    assert np.isfinite(b).all() and np.abs(b - a).max() > 1e-3
    assert UsdGeom.Imageable(stage.GetPrimAtPath("/World/Particles/cup_0")).ComputeVisibility(1) == "invisible"
    proc = cli("render", out / "shot.usda", "-q")
    assert proc.returncode == 0, proc.stderr


def test_soft_body_from_tetrahedra_moves_and_pushes_the_box(tmp_path, shot):
    out = tmp_path / "shot"
    shutil.copytree(shot["dir"], out)
    cli("estimate", out / "shot.usda", "--set", "cup.material=pbd_elastic", check=True)
    edits = (out / "edits.usda").read_bytes()
    cli("simulate", out / "shot.usda", "--seconds", "0.3", check=True)
    assert (out / "edits.usda").read_bytes() == edits  # simulate never writes the artist's layer
    report = json.loads((out / "report.json").read_text())["stages"]["simulate"]
    assert "cup_0" in report["soft_bodies"] and report["soft_bodies"]["cup_0"]["particles"] > 8
    stage = Usd.Stage.Open(str(out / "shot.usda"))
    pts = stage.GetPrimAtPath("/World/Objects/cup_0").GetAttribute("points")
    assert pts.GetNumTimeSamples() > 1 and np.isfinite(np.array(pts.Get(stage.GetEndTimeCode()))).all()


def test_mapping_of_paper_materials_onto_newton_parameters():
    sand = newton_parameters("mpm_sand", {"friction_angle": 30.0})
    assert sand["friction"] == pytest.approx(np.tan(np.radians(30))) and sand["yield_stress"] == 0
    liquid = newton_parameters("mpm_liquid", {"viscosity": 2.0})
    assert liquid["viscosity"] == 2.0 and liquid["friction"] == 0 and liquid["yield_stress"] == 0
    snow = newton_parameters("mpm_snow", {})
    assert snow["yield_pressure"] == pytest.approx(1e6 * 2.5e-2) and snow["hardening"] > 0
    assert newton_parameters("mpm_elastoplastic", {"yield_stress": 500.0})["yield_stress"] == 500.0
    assert newton_parameters("mpm_elastic", {})["yield_stress"] >= 1e15


def test_particles_fill_the_mesh_and_the_surface_follows_them():
    import trimesh

    box = trimesh.creation.box((0.4, 0.2, 0.2))
    pts = sample_inside(box, 0.02)
    assert 1800 < len(pts) <= 2000 and box.contains(pts).all()  # 20 × 10 × 10 cells
    bind = bind_surface(box.vertices, pts)
    moved = pts + [1.0, 2.0, 3.0]
    assert np.allclose(deform_surface(bind, moved, None), box.vertices + [1.0, 2.0, 3.0])
    rot = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])
    g = np.broadcast_to(rot, (len(pts), 3, 3))
    assert np.allclose(deform_surface(bind, pts @ rot.T, g), box.vertices @ rot.T, atol=1e-9)


def test_voxel_tetrahedra_are_positive_and_fill_the_volume():
    import trimesh

    ball = trimesh.creation.icosphere(3, 0.5)
    verts, tets = voxel_tets(ball, 0.1)
    a, b, c, d = (verts[tets[:, k]] for k in range(4))
    vol = np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a) / 6
    assert (vol > 0).all() and abs(vol.sum() - ball.volume) / ball.volume < 0.25


def test_guard_counts_work_and_flags_growth_nan_and_speed():
    g = Guard(tolerance=0.05)
    assert g.check(100.0, 1.0, True) is None
    assert g.check(104.0, 1.0, True) is None
    assert "energy" in g.check(120.0, 1.0, True)
    g.add_work(30.0)
    assert g.check(120.0, 1.0, True) is None
    assert "NaN" in g.check(float("nan"), 1.0, True)
    assert "speed" in g.check(1.0, 5e3, True)


def test_bundled_example_object_switched_to_liquid_flows(tmp_path):
    import pathlib

    example = pathlib.Path(__file__).resolve().parents[1] / "examples" / "sand"
    out = tmp_path / "sand"
    cli("build", example / "photo.png", "--mask", f"{example / 'sand.png'}:sand", "-o", out, "-q", check=True)
    cli("estimate", out / "shot.usda", "--set", "sand.material=mpm_liquid", check=True)
    cli("simulate", out / "shot.usda", "--seconds", "0.3", "--particle-spacing", "0.05", "-q", check=True)
    stage = Usd.Stage.Open(str(out / "shot.usda"))
    attr = UsdGeom.Points(stage.GetPrimAtPath("/World/Particles/sand_0")).GetPointsAttr()
    a, b = np.array(attr.Get(0)), np.array(attr.Get(stage.GetEndTimeCode()))
    assert attr.GetNumTimeSamples() == stage.GetEndTimeCode() + 1 and np.isfinite(b).all()
    assert np.abs(b - a).max() > 0.05


@pytest.mark.parametrize("option", [("--particle-spacing", "-1"), ("--mpm-steps", "0")])
def test_run_refuses_absurd_particle_settings(tmp_path, photo, option):
    proc = cli("run", photo["photo"], "-o", tmp_path / "x", "--mask", photo["cup"], *option)
    assert proc.returncode == 2 and proc.stderr.count("\n") <= 2 and not (tmp_path / "x").exists()


def test_a_run_the_guard_cannot_save_ends_in_one_line_and_keeps_the_old_simulation(tmp_path, shot):
    import subprocess
    import sys

    out = tmp_path / "shot"
    shutil.copytree(shot["dir"], out)
    before = (out / "sim.usdc").read_bytes()
    # a guard that rejects every frame: the run must give up after its roll-backs, not write anything
    code = ("import sys\nfrom physomni_usd.physics import stability\n"
            "stability.Guard.check = lambda self, energy, speed, finite: 'a test refusal'\n"
            "from physomni_usd.cli import main\nmain(sys.argv[1:], prog_name='physomni-usd')\n")
    proc = subprocess.run([sys.executable, "-c", code, "simulate", str(out / "shot.usda"), "--seconds", "0.2", "-q"],
                          capture_output=True, text=True)
    errors = [line for line in proc.stderr.splitlines() if line.startswith("error:")]
    assert proc.returncode == 1 and len(errors) == 1 and "diverged at frame 1" in errors[0], proc.stderr
    assert "Traceback" not in proc.stderr
    assert (out / "sim.usdc").read_bytes() == before


def test_shape_damping_keeps_the_rigid_motion_and_takes_the_wobble():
    """Müller's damping moves each soft body's velocities toward its rigid motion: the linear and angular
    momentum of each body stay what they were, the velocities relative to that motion shrink, and
    particles of no soft body are left alone."""
    import types

    import warp as wp

    from physomni_usd.physics.cloth import ShapeDamping

    rng = np.random.default_rng(3)
    n = 40
    x = rng.normal(size=(n, 3)).astype(np.float32)
    v = rng.normal(size=(n, 3)).astype(np.float32)
    m = rng.uniform(0.5, 2.0, n).astype(np.float32)
    ranges = {"/a": (0, 15), "/b": (15, 15)}  # particles 30.. belong to no soft body (a cloth, say)
    objects = [types.SimpleNamespace(family="soft", path=p, fixed=False) for p in ranges]
    damping = ShapeDamping.of(objects, ranges, n, "cpu")
    state = types.SimpleNamespace(particle_q=wp.array(x, dtype=wp.vec3, device="cpu"),
                                  particle_qd=wp.array(v, dtype=wp.vec3, device="cpu"))
    model = types.SimpleNamespace(particle_mass=wp.array(m, dtype=float, device="cpu"))

    def rigid_part(vel, sl):
        mm, xx, vv = m[sl, None].astype(np.float64), x[sl].astype(np.float64), vel[sl].astype(np.float64)
        c = (mm * xx).sum(0) / mm.sum()
        r = xx - c
        p = (mm * vv).sum(0)
        L = (mm * np.cross(r, vv)).sum(0)
        inertia = sum(mi * (ri @ ri * np.eye(3) - np.outer(ri, ri)) for mi, ri in zip(mm[:, 0], r))
        omega = np.linalg.solve(inertia, L)
        return p, L, vv - (p / mm.sum() + np.cross(omega, r))

    damping.apply(model, state, 0.005)  # one time constant
    after = state.particle_qd.numpy()
    for sl in (slice(0, 15), slice(15, 30)):
        p0, L0, rel0 = rigid_part(v, sl)
        p1, L1, rel1 = rigid_part(after, sl)
        np.testing.assert_allclose(p1, p0, atol=1e-4)
        np.testing.assert_allclose(L1, L0, atol=1e-4)
        np.testing.assert_allclose(rel1, rel0 * np.exp(-1.0), rtol=1e-3, atol=1e-5)
    np.testing.assert_array_equal(after[30:], v[30:])


@pytest.mark.slow  # 33 s on a loaded 2-core machine; a quicker test runs the same solver
def test_a_dropped_sponge_lands_and_lies_still(tmp_path):
    """An 8 cm sponge dropped 30 cm: undamped it bounced back 20 cm and still wobbled a second later; now
    its bottom rises at most 2 cm after it lands, and at 1 s it is still (under 1 cm/s) and whole."""
    import trimesh

    from physomni_usd.bench.scenes import BenchObject, write_bench_shot
    from physomni_usd.physics.simulate import simulate_shot
    from physomni_usd.settings import SimulateSettings
    from physomni_usd.usd import layers

    sponge = trimesh.creation.box((0.08, 0.08, 0.08))
    sponge.apply_translation((0.0, 0.0, 0.34))
    shot = write_bench_shot(tmp_path, [BenchObject("sponge", sponge, "pbd_elastic", {})])
    report = simulate_shot(shot, SimulateSettings(seconds=1.0))
    assert report["guard"]["rollbacks"] == []
    stage = layers.open_shot(shot)
    prim = stage.GetPrimAtPath("/World/Objects/sponge")
    cache = UsdGeom.XformCache()
    frames = []
    for f in range(report["frames"]):
        cache.SetTime(f)
        m = np.asarray(cache.GetLocalToWorldTransform(prim))
        p = np.asarray(UsdGeom.Mesh(prim).GetPointsAttr().Get(f), float)
        frames.append(p @ m[:3, :3] + m[3, :3])
    bottom = np.array([p[:, 2].min() for p in frames])
    landed = int(np.argmax(bottom < 0.005))
    assert landed > 0 and bottom[landed:].max() < 0.02, bottom
    end_speed = np.abs(frames[-1] - frames[-2]).max() * report["steps"]["fps"]
    assert end_speed < 0.01, end_speed
    height = frames[-1][:, 2].max() - frames[-1][:, 2].min()
    assert 0.07 < height <= 0.081, height


@pytest.mark.parametrize("closed", [True, False])
def test_a_soft_body_has_the_mesh_mass_and_surface(closed):
    """The soft body's particles, inset by their radius, touch the mesh's bounds and go no further, and its
    mass is the mesh's (density × volume), also for a mesh with a hole (then the voxels' volume)."""
    import types

    import newton
    import trimesh
    import warp as wp

    from physomni_usd.physics.cloth import add_soft_body

    mesh = trimesh.creation.box((0.08, 0.12, 0.06))
    mesh.apply_translation((0.0, 0.0, 0.03))
    if not closed:
        mesh = trimesh.Trimesh(mesh.vertices, mesh.faces[:-1], process=False)
        assert not mesh.is_volume
    obj = types.SimpleNamespace(trimesh=lambda: mesh, params={"density": 500.0}, fixed=False, path="/World/Objects/s")
    builder = newton.ModelBuilder()
    start, count, rest, dt = add_soft_body(builder, obj, wp)
    r = float(builder.particle_radius[start])
    np.testing.assert_allclose(rest.min(axis=0) - r, mesh.bounds[0], atol=1e-6)
    np.testing.assert_allclose(rest.max(axis=0) + r, mesh.bounds[1], atol=1e-6)
    mass = float(np.sum(builder.particle_mass[start:start + count]))
    assert mass == pytest.approx(500.0 * 0.08 * 0.12 * 0.06, rel=1e-4)
    assert dt > 0


@pytest.mark.slow  # 34 s on a loaded 2-core machine; a quicker test runs the same solver
def test_a_pushed_object_switched_to_a_soft_body_keeps_its_push(tmp_path):
    """``run --push`` at 0 s is the rigid body's ``physics:velocity``; an object a layer then makes a soft
    body (``estimate --set``, here on a shot with no photo) is pushed all the same: it had stood still."""
    import trimesh

    import physomni_usd
    from physomni_usd.bench.scenes import BenchObject, write_bench_shot
    from physomni_usd.physics.simulate import simulate_shot
    from physomni_usd.settings import SimulateSettings
    from physomni_usd.usd import layers

    box = trimesh.creation.box((0.08, 0.08, 0.08))
    box.apply_translation((0.0, 0.0, 0.04))
    shot = write_bench_shot(tmp_path, [BenchObject("box", box, "rigid", {"density": 500.0}, velocity=(1.0, 0.0, 0.0))])
    physomni_usd.estimate(shot, sets=["box.material=pbd_elastic"])
    simulate_shot(shot, SimulateSettings(seconds=0.3))
    stage = layers.open_shot(shot)
    points = UsdGeom.Mesh(stage.GetPrimAtPath("/World/Objects/box")).GetPointsAttr()
    moved = np.asarray(points.Get(9), float).mean(axis=0) - np.asarray(points.Get(0), float).mean(axis=0)
    assert moved[0] > 0.05, moved  # 1 m/s against friction: 9 cm; unpushed, 0.2 mm


def test_a_turned_soft_body_carries_its_surface_round_with_it():
    """A soft body turned and moved as a whole (a ball rolling) gives the surface turned and moved the
    same; before, the offsets kept their rest directions and a rolling ball's surface crumpled."""
    from scipy.spatial.transform import Rotation

    from physomni_usd.physics.cloth import soft_turn

    rng = np.random.default_rng(5)
    rest = rng.uniform(-0.03, 0.03, (60, 3))
    surface = rng.uniform(-0.035, 0.035, (40, 3))
    binding = bind_surface(surface, rest)
    turn = Rotation.from_rotvec([0.4, -1.1, 0.7]).as_matrix()
    now = rest @ turn.T + [0.2, 0.1, 0.0]
    np.testing.assert_allclose(soft_turn(rest, now)[0], turn, atol=1e-9)
    np.testing.assert_allclose(deform_surface(binding, now, soft_turn(rest, now)), surface @ turn.T + [0.2, 0.1, 0.0],
                               atol=1e-9)
    np.testing.assert_allclose(deform_surface(binding, rest, soft_turn(rest, rest)), surface, atol=1e-9)
