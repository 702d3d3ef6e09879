"""The stiff and extreme matrix: shots that break naive simulators, run through ``simulate`` with its
step choice and guard in charge. Each case passes when the run ends with finite values, nothing has
tunnelled (through the ground or a wall), and the guard held the energy to the initial energy plus
the work done, within 5 %."""

from __future__ import annotations

import pathlib
import tempfile
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .scenes import BenchObject, write_bench_shot


@dataclass
class MatrixCase:
    name: str
    objects: Callable[[], list]  # → [BenchObject]
    seconds: float
    check: Callable  # (stage, report) → (passed, detail)
    forces: Callable = tuple  # → force fields
    spacing: float | None = None
    substeps: int | None = None  # as a user would force them, overriding the planner


def _box(size, centre):
    import trimesh

    m = trimesh.creation.box(size if isinstance(size, tuple) else (size, size, size))
    m.apply_translation(centre)
    return m


def _final(stage):
    from pxr import Usd, UsdGeom

    from ..metrics.geometry import world_meshes

    end = stage.GetEndTimeCode()
    meshes = world_meshes(stage, end)
    particles = {}
    root = stage.GetPrimAtPath("/World/Particles")
    for prim in Usd.PrimRange(root) if root else []:
        if prim.IsA(UsdGeom.Points):
            pts = UsdGeom.Points(prim).GetPointsAttr().Get(end)
            particles[prim.GetName()] = np.asarray(pts, float) if pts else np.zeros((0, 3))
    return meshes, particles


def _above_ground(tolerance):
    def check(stage, report):
        meshes, particles = _final(stage)
        lows = [float(m.vertices[:, 2].min()) for m in meshes.values()]
        lows += [float(p[:, 2].min()) for p in particles.values() if len(p)]
        finite = all(np.isfinite(m.vertices).all() for m in meshes.values()) and \
            all(np.isfinite(p).all() for p in particles.values())
        low = min(lows)
        return finite and low > -tolerance, f"lowest point {low * 1000:.2f} mm"
    return check


def _elastic(e):
    return lambda: [BenchObject("cube", _box(0.2, (0, 0, 0.15)), "mpm_elastic", {"youngs_modulus": e})]


def _densities(rho):
    return lambda: [BenchObject("box", _box(0.2, (-0.3, 0, 0.4)), "rigid", {"density": rho}),
                    BenchObject("cube", _box(0.2, (0.3, 0, 0.15)), "mpm_elastic", {"density": rho})]


def _stack():
    return [BenchObject("light", _box(0.2, (0, 0, 0.1)), "rigid", {"density": 10.0}),
            BenchObject("heavy", _box(0.2, (0, 0, 0.3005)), "rigid", {"density": 10000.0})]


def _stack_check(stage, report):
    meshes, _ = _final(stage)
    light, heavy = meshes["light"], meshes["heavy"]
    gap = float(heavy.vertices[:, 2].min() - light.vertices[:, 2].max())
    ok = gap > -0.005 and light.vertices[:, 2].min() > -0.005 and np.isfinite(heavy.vertices).all()
    return ok, f"heavy sits {gap * 1000:+.2f} mm on the light box"


def _wall():
    return [BenchObject("wall", _box((0.005, 1.0, 1.0), (1.0, 0, 0.5)), "rigid", {"density": 1000.0}, fixed=True),
            BenchObject("bullet", _box(0.1, (0.0, 0, 0.0505)), "rigid", {"density": 1000.0}, velocity=(50.0, 0, 0))]


def _wall_check(stage, report):
    meshes, _ = _final(stage)
    front = float(meshes["bullet"].vertices[:, 0].max())
    ok = front < 1.0 + 0.0025 and np.isfinite(meshes["bullet"].vertices).all()
    return ok, f"bullet's front at x = {front:.4f} m (wall face 0.9975 m)"


def _tiny():
    return [BenchObject("grain", _box(0.001, (0, 0, 0.003)), "rigid", {"density": 2500.0})]


def _pressed():
    # a 2 cm cube of 1250 kg/m³ weighs 10 g; the field's 1e6 m/s² on it is 1e4 N, pressing it down
    return [BenchObject("chip", _box(0.02, (0, 0, 0.0101)), "rigid", {"density": 1250.0})]


def _pressed_forces():
    from ..fields import ForceField

    return (ForceField("constant", strength=1e6, direction=(0.0, 0.0, -1.0), end_time=0.2),)


def cases(quick: bool) -> list[MatrixCase]:
    youngs = (1e3, 1e9) if quick else (1e3, 1e5, 1e7, 1e9)
    out = [MatrixCase(f"elastic_E_{e:.0e}", _elastic(e), 0.3, _above_ground(0.03), spacing=0.025) for e in youngs]
    out += [MatrixCase(f"density_{rho:g}", _densities(rho), 0.4, _above_ground(0.03), spacing=0.025)
            for rho in (10.0, 20000.0)]
    out += [MatrixCase("mass_ratio_1000_stack", _stack, 1.0, _stack_check),
            MatrixCase("50_m_s_at_5_mm_wall", _wall, 0.1, _wall_check),
            MatrixCase("1_mm_cube", _tiny, 0.3, _above_ground(0.0005)),
            MatrixCase("1e4_N_on_10_g", _pressed, 0.3, _above_ground(0.002), forces=_pressed_forces),
            # the same with the planner overruled: only the guard's roll-backs can save it
            MatrixCase("1e4_N_on_10_g_at_20_substeps", _pressed, 0.3, _above_ground(0.002), forces=_pressed_forces,
                       substeps=20)]
    return out


def run_matrix(quick: bool = False, echo=print, only: list[str] | None = None) -> list[dict]:
    """Run every case; one row each: case, passed, detail, the steps the planner and guard chose."""
    from ..errors import PhysOmniError
    from ..physics.simulate import simulate_shot
    from ..settings import SimulateSettings
    from ..usd import layers

    rows = []
    for case in cases(quick):
        if only and case.name not in only:
            continue
        with tempfile.TemporaryDirectory() as tmp:
            shot = write_bench_shot(pathlib.Path(tmp), case.objects(), forces=case.forces())
            t0 = time.perf_counter()
            row = {"case": case.name}
            try:
                rep = simulate_shot(shot, SimulateSettings(seconds=case.seconds, particle_spacing=case.spacing,
                                                                substeps=case.substeps))
                passed, detail = case.check(layers.open_shot(shot), rep)
                guard = rep["guard"]
                row |= {"passed": bool(passed), "detail": detail, "substeps": rep["substeps"],
                        "dt": rep["dt"], "mpm_steps": rep["steps"].get("mpm_steps", 0),
                        "rollbacks": len(guard["rollbacks"]), "energy_initial_j": guard["energy_initial_j"],
                        "energy_final_j": guard["energy_final_j"], "work_j": guard["work_j"]}
            except PhysOmniError as exc:
                row |= {"passed": False, "detail": str(exc)}
            row["seconds"] = round(time.perf_counter() - t0, 2)
        rows.append(row)
        echo(f"{row['case']:<30}{'pass' if row['passed'] else 'FAIL':<6}substeps {row.get('substeps', '-')!s:<5}"
             f"mpm {row.get('mpm_steps', '-')!s:<3}rollbacks {row.get('rollbacks', '-')!s:<3}{row['detail']}")
    return rows


def memory_probe(particles: int = 100_000, seconds: float = 0.1) -> dict:
    """Peak resident memory of a sand block of about ``particles`` MPM particles simulated for ``seconds``,
    measured in a fresh interpreter so that nothing else counts."""
    from .scenes import in_fresh_interpreter

    return in_fresh_interpreter(__name__, "_memory_run", particles=particles, seconds=seconds)


def _memory_run(particles: int, seconds: float) -> dict:
    import resource

    import trimesh

    from ..physics.simulate import simulate_shot
    from ..settings import SimulateSettings

    box = trimesh.creation.box((1.0, 1.0, 0.4))
    box.apply_translation((0, 0, 0.2))
    spacing = (0.4 / particles) ** (1 / 3)
    with tempfile.TemporaryDirectory() as tmp:
        shot = write_bench_shot(pathlib.Path(tmp), [BenchObject("sand", box, "mpm_sand")])
        t0 = time.perf_counter()
        rep = simulate_shot(shot, SimulateSettings(seconds=seconds, particle_spacing=spacing))
        return {"particles": rep["mpm"]["particles"], "spacing_m": spacing,
                "peak_rss_gib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2 ** 20,
                "seconds": time.perf_counter() - t0, "simulated_seconds": seconds,
                "step_seconds": rep["seconds"]["step"]}
