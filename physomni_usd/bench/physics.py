"""``bench physics``: error against run time on cases with exact or measured answers, the stiff and
extreme matrix, and what the simulator's defaults cost.

Each case runs a tiny Newton scene for a few simulated seconds and compares it
with its reference; the sweep varies the solver and the substeps per frame
(30 frames per second, so dt = 1 / (30·substeps)) and, for MPM, the particle
spacing. For every (case, solver) the cheapest setting that meets the case's
target is marked ``recommended``. The deformable cases (cloth sag, elastic
bar, dam break, granular column) and their references are in
:mod:`physomni_usd.bench.deformable`; the matrix in :mod:`physomni_usd.bench.stability`.

Cases and their references:

- free fall: z(t) = z₀ − ½·g·t² (Galileo; any mechanics text);
- linear drag projectile: x(t) = x₀ + v₀ₓ(1 − e^{−kt})/k, z(t) = z₀ + (v₀z + g/k)(1 − e^{−kt})/k − g·t/k
  (Taylor, *Classical Mechanics*, 2005, §2.2–2.4);
- quadratic drag fall: z(t) = z₀ − ln(cosh(t·√(g·c)))/c (Taylor 2005, §2.4);
- friction on an incline: a block on a plane tilted by θ slides with a = g(sin θ − μ cos θ) when
  tan θ > μ and sticks otherwise (Coulomb; the plane is tilted by tilting gravity);
- restitution: a sphere dropped from h rises to e²·h after its first bounce;
- resting stack: five boxes stacked must not drift; error = largest drift / box size;
- free rotation: a free box spinning about a non-principal axis keeps its angular momentum
  (Euler's equations); error = |ΔL| / |L₀|.

Rigid solvers compared: XPBD, MuJoCo (its own CPU engine, where ``mujoco`` and ``mujoco-warp`` are
installed: the ``bench`` extra), Featherstone and semi-implicit (penalty contacts, ke = 1e6, kd = 1e4).
"""

from __future__ import annotations

import math
import platform
import statistics
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .._warp import load_warp
from ..physics.stability import CLOTH_FACTOR, DEFAULT_ITERATIONS, MPM_STEPS, RIGID_SUBSTEPS

G = 9.81
FPS = 30
SOLVERS = ("xpbd", "mujoco", "featherstone", "semi_implicit")
TARGET = 0.01


@dataclass
class Case:
    name: str
    run: Callable  # (solver, substeps) -> error
    seconds: float  # simulated
    target: float = TARGET
    contact: bool = False


def _solver(name, model):
    import newton

    if name == "xpbd":
        return newton.solvers.SolverXPBD(model, iterations=DEFAULT_ITERATIONS, enable_restitution=True)  # the simulator's
    if name == "mujoco":  # MuJoCo's own CPU engine and contacts, through Newton
        return newton.solvers.SolverMuJoCo(model, use_mujoco_cpu=True)
    if name == "featherstone":
        return newton.solvers.SolverFeatherstone(model)
    if name == "semi_implicit":
        return newton.solvers.SolverSemiImplicit(model)
    raise ValueError(name)


def _builder(gravity=(0.0, 0.0, -G), penalty=False):
    import newton

    b = newton.ModelBuilder(up_axis=newton.Axis.Z, gravity=tuple(gravity))
    if penalty:  # penalty solvers need stiff contacts (Newton's defaults let boxes sink)
        b.default_shape_cfg.ke, b.default_shape_cfg.kd = 1e6, 1e4
    return b


def _simulate(model, solver_name, substeps, seconds, contacts=False, forces=None, record=None):
    import newton

    solver = _solver(solver_name, model)
    a, b = model.state(), model.state()
    if solver_name in ("featherstone", "mujoco") and a.joint_qd is not None and model.body_count:
        # these integrate joint coordinates: every body here hangs on a free joint whose
        # velocity coordinates are the body's (linear, angular) velocity
        a.joint_qd.assign(a.body_qd.numpy().ravel())
    control = model.control()
    # MuJoCo finds its own contacts
    pipe = newton.CollisionPipeline(model, contact_matching="sticky") if contacts and solver_name != "mujoco" else None
    found = pipe.contacts() if pipe else None
    dt = 1.0 / (FPS * substeps)
    steps = int(round(seconds * FPS * substeps))
    t0 = time.perf_counter()
    for i in range(steps):
        a.clear_forces()
        if forces is not None:
            forces.apply(model, a, i * dt, i)
        if pipe:
            pipe.collide(a, found)
        solver.step(a, b, control, found, dt)
        a, b = b, a
        if record is not None and (i + 1) % substeps == 0:
            record.append(a.body_q.numpy().copy())
    return a, time.perf_counter() - t0


def _body(b, pos, kind="sphere", size=0.1, mass_density=1000.0, velocity=None, spin=None):
    import warp as wp

    body = b.add_body(xform=wp.transform(tuple(pos), wp.quat_identity()))
    cfg = b.default_shape_cfg.copy()
    cfg.density = mass_density
    if kind == "sphere":
        b.add_shape_sphere(body, radius=size, cfg=cfg)
    else:
        hx, hy, hz = size if isinstance(size, tuple) else (size, size, size)
        b.add_shape_box(body, hx=hx, hy=hy, hz=hz, cfg=cfg)
    if velocity is not None or spin is not None:
        v = velocity or (0.0, 0.0, 0.0)
        w = spin or (0.0, 0.0, 0.0)
        b.body_qd[body] = wp.spatial_vector(*v, *w)
    return body


def free_fall(solver, substeps):
    b = _builder(penalty=solver != "xpbd")
    _body(b, (0, 0, 2.0))
    state, sec = _simulate(b.finalize(device="cpu"), solver, substeps, 0.5)
    exact = 0.5 * G * 0.5 ** 2
    return abs((2.0 - state.body_q.numpy()[0, 2]) - exact) / exact, sec


def linear_drag(solver, substeps):
    from ..physics.forces import FieldSet, ForceField

    k, v0, t = 1.5, np.array([3.0, 0.0, 4.0]), 1.0
    b = _builder(penalty=solver != "xpbd")
    _body(b, (0, 0, 0), velocity=tuple(v0))
    model = b.finalize(device="cpu")
    fields = FieldSet([ForceField("drag", linear_drag=k)])
    fields.set_body_samples(np.zeros((1, 1, 3)))
    state, sec = _simulate(model, solver, substeps, t, forces=fields)
    e = 1 - math.exp(-k * t)
    exact = np.array([v0[0] * e / k, 0.0, (v0[2] + G / k) * e / k - G * t / k])
    return float(np.linalg.norm(state.body_q.numpy()[0, :3] - exact) / np.linalg.norm(exact)), sec


def quadratic_drag(solver, substeps):
    from ..physics.forces import FieldSet, ForceField

    c, t = 0.2, 1.5
    b = _builder(penalty=solver != "xpbd")
    _body(b, (0, 0, 0))
    model = b.finalize(device="cpu")
    fields = FieldSet([ForceField("drag", quadratic_drag=c)])
    fields.set_body_samples(np.zeros((1, 1, 3)))
    state, sec = _simulate(model, solver, substeps, t, forces=fields)
    exact = math.log(math.cosh(t * math.sqrt(G * c))) / c
    return abs(-state.body_q.numpy()[0, 2] - exact) / exact, sec


def incline(solver, substeps, theta_deg=30.0, mu=0.3):
    """Slide down a 30° incline with μ = 0.3 (gravity tilted instead of the plane)."""
    th = math.radians(theta_deg)
    b = _builder(gravity=(G * math.sin(th), 0.0, -G * math.cos(th)), penalty=solver != "xpbd")
    b.default_shape_cfg.mu = mu
    b.add_ground_plane(cfg=b.default_shape_cfg.copy())
    _body(b, (0, 0, 0.1), kind="box", size=0.1)
    t = 1.0
    state, sec = _simulate(b.finalize(device="cpu"), solver, substeps, t, contacts=True)
    exact = 0.5 * G * (math.sin(th) - mu * math.cos(th)) * t * t
    return abs(state.body_q.numpy()[0, 0] - exact) / exact, sec


def restitution(solver, substeps, e=0.6, h=1.0):
    b = _builder(penalty=solver != "xpbd")
    b.default_shape_cfg.restitution = e
    b.add_ground_plane(cfg=b.default_shape_cfg.copy())
    _body(b, (0, 0, h + 0.1))
    record = []
    state, sec = _simulate(b.finalize(device="cpu"), solver, substeps, 1.4, contacts=True, record=record)
    z = np.array([q[0, 2] for q in record]) - 0.1
    after = z[int(math.sqrt(2 * h / G) * FPS) + 2:]
    apex = float(after.max()) if len(after) else 0.0
    return abs(apex - e * e * h) / (e * e * h), sec


def resting_stack(solver, substeps, seconds=3.0):
    b = _builder(penalty=solver != "xpbd")
    b.add_ground_plane()
    size = 0.1
    for i in range(5):
        _body(b, (0, 0, size + 2 * size * i + 1e-4), kind="box", size=size)
    model = b.finalize(device="cpu")
    start = model.state().body_q.numpy()[:, :3].copy()
    state, sec = _simulate(model, solver, substeps, seconds, contacts=True)
    drift = np.linalg.norm(state.body_q.numpy()[:, :3] - start, axis=1).max()
    return float(drift / (2 * size)), sec


def free_rotation(solver, substeps):
    from scipy.spatial.transform import Rotation

    b = _builder(gravity=(0, 0, 0), penalty=solver != "xpbd")
    _body(b, (0, 0, 0), kind="box", size=(0.3, 0.2, 0.1), spin=(0.1, 5.0, 0.1))
    model = b.finalize(device="cpu")
    inertia = model.body_inertia.numpy()[0]
    s0 = model.state()
    w0 = s0.body_qd.numpy()[0, 3:]
    l0 = inertia @ w0  # identity orientation: body and world frames agree
    state, sec = _simulate(model, solver, substeps, 2.0)
    q = state.body_q.numpy()[0, 3:]
    r = Rotation.from_quat(q).as_matrix()
    w = state.body_qd.numpy()[0, 3:]
    l1 = r @ inertia @ r.T @ w
    return float(np.linalg.norm(l1 - l0) / np.linalg.norm(l0)), sec


CASES = [Case("free_fall", free_fall, 0.5), Case("linear_drag", linear_drag, 1.0),
         Case("quadratic_drag", quadratic_drag, 1.5), Case("incline_friction", incline, 1.0, contact=True),
         Case("restitution", restitution, 1.4, contact=True), Case("resting_stack", resting_stack, 3.0, contact=True),
         Case("free_rotation", free_rotation, 2.0)]


#: Deformable cases (bench.deformable): name → (function, solver, target, quick settings, full settings);
#: a setting is (steps per frame, particle spacing or None).
DEFORMABLE = {
    "cloth_sag": ("cloth_sag", "xpbd", TARGET, [(16, None), (32, None)],
                  [(8, None), (16, None), (24, None), (32, None), (48, None), (64, None), (128, None)]),
    "elastic_bar": ("elastic_bar", "implicit_mpm", TARGET, [(16, 0.025)],
                    [(8, 0.025), (16, 0.025), (32, 0.025), (8, 0.0167), (16, 0.0167), (32, 0.0167),
                     (16, 0.0125)]),
    "dam_break": ("dam_break", "implicit_mpm", 0.10, [(2, 0.01)], [(1, 0.01), (2, 0.01), (4, 0.01), (2, 0.0067)]),
    "granular_column": ("granular_column", "implicit_mpm", 0.15, [(4, 0.01)],
                        [(2, 0.01), (4, 0.01), (8, 0.01), (16, 0.01), (4, 0.0067)]),
}


def rigid_solvers() -> tuple[str, ...]:
    """The rigid solvers this machine can run: MuJoCo only where its Python packages are installed."""
    import importlib.util

    have_mujoco = all(importlib.util.find_spec(m) for m in ("mujoco", "mujoco_warp"))
    return tuple(s for s in SOLVERS if s != "mujoco" or have_mujoco)


def bench_physics(quick: bool = False, repeats: int = 3, echo=print, matrix: bool = True) -> dict:
    load_warp()
    substeps_list = (1, 4, 16) if quick else (1, 2, 4, 8, 16, 32)
    solvers = rigid_solvers()
    rows = []
    for case in CASES:
        for solver in solvers:
            for n in substeps_list:
                errors, costs = [], []
                for _ in range(1 if quick else repeats):
                    try:
                        err, sec = case.run(solver, n)
                    except Exception as exc:  # noqa: BLE001 - a solver that cannot run this case says so
                        errors, costs = [float("nan")], [float("nan")]
                        echo(f"{case.name} {solver}: {type(exc).__name__}: {exc}")
                        break
                    errors.append(err if math.isfinite(err) else float("inf"))
                    costs.append(sec / case.seconds)
                rows.append({"case": case.name, "solver": solver, "dt": 1.0 / (FPS * n), "substeps": n,
                             "error": float(statistics.median(errors)), "target": case.target,
                             "seconds_per_sim_second": float(statistics.median(costs)), "recommended": False})
    rows += _deformable_rows(quick, echo)
    for case, solver in dict.fromkeys((r["case"], r["solver"]) for r in rows):
        ok = [r for r in rows if r["case"] == case and r["solver"] == solver and r["error"] <= r["target"]]
        if ok:
            min(ok, key=lambda r: r["seconds_per_sim_second"])["recommended"] = True
    default = choose_default([r for r in rows if r["case"] in {c.name for c in CASES}], substeps_list)
    _print(rows, default, echo)
    deformables = deformable_defaults(rows)
    echo(f"deformable defaults (bench vs simulator): {deformables}")
    out = {"machine": machine(), "date": time.strftime("%Y-%m-%d"), "fps": FPS, "rows": rows, "default": default,
           "scene_defaults": scene_defaults(rows), "deformable_defaults": deformables, "ten_objects": ten_objects(echo)}
    if matrix:
        from .stability import memory_probe, run_matrix

        echo("stiff and extreme matrix:")
        out["matrix"] = run_matrix(quick=quick, echo=echo)
        out["memory"] = memory_probe()
        echo(f"memory: {out['memory']}")
    return out


def machine() -> str:
    import os

    cpu = platform.processor() or platform.machine()
    return f"{cpu}, {os.cpu_count()} cores, {platform.system()}, Python {platform.python_version()}"


def _deformable_rows(quick: bool, echo) -> list[dict]:
    from . import deformable

    rows = []
    for case, (fn, solver, target, quick_settings, full_settings) in DEFORMABLE.items():
        for n, spacing in quick_settings if quick else full_settings:
            kwargs = {} if spacing is None else {"spacing": spacing}
            try:
                err, cost = getattr(deformable, fn)(n, **kwargs)
            except Exception as exc:  # noqa: BLE001 - reported, the sweep goes on
                echo(f"{case} {solver}: {type(exc).__name__}: {exc}")
                err, cost = float("nan"), float("nan")
            rows.append({"case": case, "solver": solver, "dt": 1.0 / (FPS * n), "substeps": n, "spacing": spacing,
                         "error": float(err) if math.isfinite(err) else float("inf"), "target": target,
                         "seconds_per_sim_second": cost, "recommended": False})
    return rows


def scene_defaults(rows) -> dict:
    """The XPBD substeps the bench recommends for each kind of rigid scene, beside what the simulator
    uses (``physics.stability.RIGID_SUBSTEPS``)."""
    kinds = {"free": ("free_fall", "incline_friction", "free_rotation"), "drag": ("linear_drag", "quadratic_drag"),
             "bouncy": ("restitution",), "stacked": ("resting_stack",)}
    out = {}
    for kind, cases in kinds.items():
        need = []
        for case in cases:
            ok = [r["substeps"] for r in rows if r["case"] == case and r["solver"] == "xpbd" and r["error"] <= r["target"]]
            need.append(min(ok) if ok else None)
        measured = None if None in need else max(need)
        out[kind] = {"bench": measured, "simulator": RIGID_SUBSTEPS[kind]}
    return out


def deformable_defaults(rows) -> dict:
    """What the deformable cases recommend beside what the simulator uses: the factor c of the cloth
    rule dt ≤ c·√(m/k) (``physics.stability.CLOTH_FACTOR``) and MPM steps per frame for each kind of
    material (``physics.stability.MPM_STEPS``); None where no setting met the case's target."""
    from .deformable import cloth_time_scale

    def recommended(case):
        return next((r for r in rows if r["case"] == case and r["recommended"]), None)

    cloth = recommended("cloth_sag")
    out = {"cloth_factor": {"bench": round(cloth["dt"] / cloth_time_scale(), 3) if cloth else None,
                            "simulator": CLOTH_FACTOR}, "mpm_steps": {}}
    for kind, case in (("elastic", "elastic_bar"), ("granular", "granular_column"), ("liquid", "dam_break")):
        r = recommended(case)
        out["mpm_steps"][kind] = {"case": case, "bench": r["substeps"] if r else None, "simulator": MPM_STEPS[kind]}
    return out


def ten_objects(echo=print, seconds: float = 2.0) -> dict:
    """Ten boxes dropped on the ground, through ``simulate`` at its own step choice, in a fresh interpreter
    as a user's ``physomni-usd simulate`` would run: its cost, the median of three runs."""
    from .scenes import in_fresh_interpreter

    r = in_fresh_interpreter(__name__, "_ten_objects_run", seconds=seconds)
    if "error" in r:
        echo(f"ten objects: {r}")
        return r
    cost = statistics.median(r["costs"])
    out = {"objects": 10, "solver": r["solver"], "substeps": r["substeps"], "iterations": r["iterations"],
           "collide_at_most_every": r["collide_every"], "seconds_per_sim_second": cost,
           "runs_seconds_per_sim_second": r["costs"], "times_real_time": round(1.0 / cost, 2) if cost > 0 else None}
    echo(f"ten objects: {out}")
    return out


def _ten_objects_run(seconds: float) -> dict:
    import pathlib
    import tempfile

    import trimesh

    from ..physics.simulate import simulate_shot
    from ..settings import SimulateSettings
    from .scenes import BenchObject, write_bench_shot

    objects = []
    for i in range(10):
        box = trimesh.creation.box((0.2, 0.2, 0.2))
        box.apply_translation(((i % 5) * 0.4 - 0.8, (i // 5) * 0.4, 0.3 + 0.05 * i))
        objects.append(BenchObject(f"box_{i}", box, "rigid", {"density": 500.0}))
    with tempfile.TemporaryDirectory() as tmp:
        shot = write_bench_shot(pathlib.Path(tmp), objects)
        simulate_shot(shot, SimulateSettings(seconds=0.2))  # warm the kernel cache
        runs = [simulate_shot(shot, SimulateSettings(seconds=seconds)) for _ in range(3)]
    r = runs[0]
    return {"solver": r["solver"], "substeps": r["substeps"], "iterations": r["iterations"],
            "collide_every": r["steps"]["collide_every"], "costs": [x["seconds_per_simulated_second"] for x in runs]}


def choose_default(rows, substeps_list) -> dict:
    """The cheapest (solver, substeps) meeting every case's target; None where none does."""
    best = None
    for solver in dict.fromkeys(r["solver"] for r in rows):
        for n in substeps_list:
            mine = [r for r in rows if r["solver"] == solver and r["substeps"] == n]
            if mine and all(r["error"] <= r["target"] for r in mine):
                cost = sum(r["seconds_per_sim_second"] for r in mine)
                if best is None or cost < best["cost"]:
                    best = {"solver": solver, "substeps": n, "cost": cost}
    if best is None:
        return {"solver": None, "substeps": None, "reason": "no setting met every target"}
    return {**best, "reason": f"cheapest setting meeting every case's {TARGET:.0%} target "
                              f"(sum of seconds per simulated second over the cases: {best['cost']:.3f})"}


def _print(rows, default, echo):
    for line in table(rows):
        echo(line)
    echo(f"default: {default}")


def table(rows) -> list[str]:
    """The rows as a Markdown table (``*`` marks the recommended setting of each case and solver)."""
    out = ["| case | solver | steps/frame | dt ms | spacing mm | error | target | s per sim s | rec |",
           "|---|---|---:|---:|---:|---:|---:|---:|:-:|"]
    for r in rows:
        spacing = f"{r['spacing'] * 1000:.1f}" if r.get("spacing") else ""
        out.append(f"| {r['case']} | {r['solver']} | {r['substeps']} | {r['dt'] * 1000:.2f} | {spacing} | "
                   f"{r['error']:.4f} | {r['target']:.2f} | {r['seconds_per_sim_second']:.4f} | "
                   f"{'*' if r['recommended'] else ''} |")
    return out


def write_plots(numbers: dict, folder) -> list:
    """Error against seconds per simulated second, one PNG per case (matplotlib)."""
    import pathlib

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return []
    folder = pathlib.Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for case in dict.fromkeys(r["case"] for r in numbers["rows"]):
        fig, ax = plt.subplots(figsize=(5, 3.5))
        for solver, spacing in dict.fromkeys((r["solver"], r.get("spacing")) for r in numbers["rows"]
                                             if r["case"] == case):
            rs = [r for r in numbers["rows"] if r["case"] == case and r["solver"] == solver
                  and r.get("spacing") == spacing and math.isfinite(r["error"])]
            if rs:
                label = solver if spacing is None else f"{solver}, {spacing * 1000:.1f} mm"
                ax.loglog([r["seconds_per_sim_second"] for r in rs], [max(r["error"], 1e-8) for r in rs], "o-",
                          label=label)
        target = next(r["target"] for r in numbers["rows"] if r["case"] == case)
        ax.axhline(target, color="grey", ls="--", lw=1)
        ax.set_xlabel("wall seconds per simulated second")
        ax.set_ylabel("relative error")
        ax.set_title(case)
        ax.legend(fontsize=7)
        fig.tight_layout()
        path = folder / f"{case}.png"
        fig.savefig(path, dpi=100)
        plt.close(fig)
        out.append(str(path))
    return out


def markdown(numbers: dict) -> str:
    """The whole run as Markdown: date, machine, the error table, the matrix, memory, ten objects."""
    lines = [f"Generated by `physomni-usd bench physics` on {numbers['date']} ({numbers['machine']}), "
             f"{numbers['fps']} frames per second.", ""]
    lines += table(numbers["rows"]) + [""]
    d = numbers["default"]
    lines.append(f"Cheapest rigid setting meeting every closed form at once: {d.get('solver')} × "
                 f"{d.get('substeps')} substeps — {d.get('reason')}.")
    lines.append("")
    lines.append("| rigid scene kind | bench recommends (XPBD substeps) | simulator uses |")
    lines.append("|---|---:|---:|")
    for kind, v in numbers.get("scene_defaults", {}).items():
        lines.append(f"| {kind} | {v['bench']} | {v['simulator']} |")
    d = numbers.get("deformable_defaults")
    if d:
        c = d["cloth_factor"]
        lines += ["", f"Cloth step rule dt ≤ c·√(m/k): the cheapest cloth-sag setting meeting its target gives "
                      f"c = {c['bench']}; the simulator uses c = {c['simulator']}.", "",
                  "| MPM material | reference case | bench recommends (steps per frame) | simulator uses |",
                  "|---|---|---:|---:|"]
        for kind, v in d["mpm_steps"].items():
            bench = v["bench"] if v["bench"] is not None else "none met the target"
            lines.append(f"| {kind} | {v['case']} | {bench} | {v['simulator']} |")
    t = numbers.get("ten_objects")
    if t and "seconds_per_sim_second" in t:
        lines += ["", f"Ten boxes in a fresh `simulate` at its defaults ({t['solver']}, {t['substeps']} substeps, "
                      f"{t['iterations']} iterations, contacts searched as often as the speeds need, at most every "
                      f"{t['collide_at_most_every']} substeps): "
                      f"{t['seconds_per_sim_second']:.3f} s per simulated second (median of three), "
                      f"{t['times_real_time']}× real time."]
    if numbers.get("matrix"):
        lines += ["", "| matrix case | result | substeps | MPM steps | roll-backs | energy J (start → end, work) | detail |",
                  "|---|---|---:|---:|---:|---|---|"]
        for r in numbers["matrix"]:
            energy = (f"{r['energy_initial_j']:.4g} → {r['energy_final_j']:.4g}, {r['work_j']:.3g}"
                      if "energy_initial_j" in r else "")
            lines.append(f"| {r['case']} | {'pass' if r['passed'] else 'FAIL'} | {r.get('substeps', '')} | "
                         f"{r.get('mpm_steps', '')} | {r.get('rollbacks', '')} | {energy} | {r['detail']} |")
    m = numbers.get("memory")
    if m and "peak_rss_gib" in m:
        lines += ["", f"Memory: {m['particles']:,} MPM particles (sand, spacing {m['spacing_m'] * 1000:.1f} mm) "
                      f"simulated {m['simulated_seconds']} s with a peak of {m['peak_rss_gib']:.2f} GiB resident."]
    return "\n".join(lines) + "\n"


MARK_BEGIN = "<!-- bench physics:"
MARK_END = "<!-- /bench physics -->"


def splice_markdown(document: str, generated: str) -> str:
    """``document`` with the text between its bench-physics markers replaced by ``generated``; a document
    without the markers is replaced whole (it is the bench's own file)."""
    start = document.find(MARK_BEGIN)
    end = document.find(MARK_END)
    if start < 0 or end < start:
        return generated
    head_end = document.index("\n", start) + 1
    return document[:head_end] + "\n" + generated + "\n" + document[end:]
