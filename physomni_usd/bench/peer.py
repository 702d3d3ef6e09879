"""``bench peer``: the simulator side by side with Genesis (the engine the paper ran on), in one process:
ten boxes at rest, a pile of twenty boxes colliding, and a sand column on both engines' MPM at the same
particle count. Our side is ``simulate_shot`` itself (its guarded stepping loop, as ``simulate`` runs it);
Genesis's is ``scene.step()`` at the same frame rate and substeps. Each side's build, kernel compiling
and first run are left out of the timing alike: both run the case once untimed, then the timed runs
alternate, ours then Genesis's. Needs ``genesis-world`` (the ``peer`` extra), which pins its own pillow,
so it goes in an environment of its own."""

from __future__ import annotations

import importlib.util
import math
import pathlib
import statistics
import tempfile
import time

from .limits import PEER
from .scenes import BOX, BOX_DENSITY, box, boxes_at_rest  # noqa: F401 (the cases' scenes)

#: The cases, in the order they run; ``--only`` takes these names.
CASES = ("boxes_at_rest", "box_pile", "sand_column")
#: The sand column's size (m) and material.
SAND_SIZE = (0.1, 0.1, 0.2)
SAND_MATERIAL = "mpm_sand"
#: Genesis's explicit MPM warns above a substep of this many grid cells' worth of seconds (2e-2·dx, its
#: ``suggested_dt``); its sand runs at that step, ours at the implicit solver's own MPM steps.
GENESIS_MPM_DT_PER_DX = 2e-2

INSTALL = ("genesis: not installed; nothing run (python3.11 -m venv ENV; ENV/bin/pip install torch==2.13.0 "
           "'physomni-usd[peer]'; then ENV/bin/physomni-usd bench peer)")


def genesis_available() -> bool:
    return importlib.util.find_spec("genesis") is not None


def start_genesis():
    """The ``genesis`` module, started on its CPU backend once in this process (warp started first, quietly)."""
    import genesis as gs

    from .._warp import load_warp

    load_warp()
    if not getattr(gs, "_initialized", False):
        gs.init(backend=gs.cpu, logging_level="warning")
    return gs


def box_pile(n: int = 20) -> list:
    """``n`` boxes in layers of five 0.3 m apart, each layer shifted 7 cm × 5 cm from the one below so
    that every box lands on an edge of another and the pile topples into itself."""
    layer = ((-0.22, 0.0), (0.0, 0.0), (0.22, 0.0), (-0.11, 0.22), (0.11, 0.22))
    out = []
    for i in range(n):
        k = i // len(layer)
        x, y = layer[i % len(layer)]
        out.append(box(f"box_{i}", (x + 0.07 * k, y + 0.05 * k, BOX / 2 + 0.05 + 0.3 * k)))
    return out


def sand_column() -> list:
    """One column of sand (``SAND_SIZE``, the catalogue's ``mpm_sand``) standing on the ground."""
    import trimesh

    from .scenes import BenchObject

    column = trimesh.creation.box(SAND_SIZE)
    column.apply_translation((0.0, 0.0, SAND_SIZE[2] / 2))
    return [BenchObject("sand", column, SAND_MATERIAL, {})]


class Ours:
    """A case through ``simulate_shot``; :meth:`run` returns its stepping's wall and CPU seconds (the report's
    ``seconds.step`` and ``seconds.step_cpu``: the guarded loop with its checks and recording, what
    ``simulate`` runs)."""

    def __init__(self, folder: pathlib.Path, objects: list, seconds: float):
        from .scenes import write_bench_shot

        self.shot, self.seconds = write_bench_shot(folder, objects), seconds
        self.section = None

    def run(self) -> tuple[float, float]:
        from ..physics.simulate import simulate_shot
        from ..settings import SimulateSettings

        self.section = simulate_shot(self.shot, SimulateSettings(seconds=self.seconds))
        return self.section["seconds"]["step"], self.section["seconds"]["step_cpu"]


class Genesis:
    """The same case as a Genesis scene on its CPU backend: boxes as ``gs.morphs.Box`` of the same size,
    pose and density on a plane; the sand as ``gs.morphs.Box`` of ``gs.materials.MPM.Sand`` sampled on a
    regular grid at ``spacing``. :meth:`run` steps ``frames`` frames from the start and returns the wall and
    the process's CPU seconds (all its threads) ``scene.step()`` took."""

    def __init__(self, objects: list, fps: float, substeps: int, spacing: float | None = None):
        import genesis as gs

        self.gs = gs
        self.fps, self.substeps = fps, substeps
        sim = gs.options.SimOptions(dt=1.0 / fps, substeps=substeps)
        extra = {}
        if spacing is not None:
            lo = [-0.5, -0.5, -0.05]
            hi = [0.5, 0.5, 0.6]
            extra["mpm_options"] = gs.options.MPMOptions(lower_bound=lo, upper_bound=hi, particle_size=spacing,
                                                         grid_density=1.0 / spacing)
        self.scene = gs.Scene(sim_options=sim, show_viewer=False, **extra)
        self.scene.add_entity(gs.morphs.Plane())
        self.entities = []
        for o in objects:
            lo, hi = o.mesh.bounds
            morph = gs.morphs.Box(size=tuple(map(float, hi - lo)), pos=tuple(map(float, (lo + hi) / 2)))
            if o.material == "rigid":
                material = gs.materials.Rigid(rho=float(o.params.get("density", BOX_DENSITY)))
            else:
                from ..materials.catalog import check_params

                p = check_params(o.material, o.params)
                material = gs.materials.MPM.Sand(E=float(p["youngs_modulus"]), nu=float(p["poissons_ratio"]),
                                                 rho=float(p["density"]), friction_angle=float(p["friction_angle"]),
                                                 sampler="regular")
            self.entities.append(self.scene.add_entity(morph, material=material))
        self.scene.build()

    @property
    def particles(self) -> int:
        return int(sum(getattr(e, "n_particles", 0) for e in self.entities))

    def run(self, frames: int) -> tuple[float, float]:
        self.scene.reset()
        t0, c0 = time.perf_counter(), time.process_time()
        for _ in range(frames):
            self.scene.step()
        return time.perf_counter() - t0, time.process_time() - c0

    def finite(self) -> bool:
        import numpy as np

        for e in self.entities:
            state = e.get_particles_pos() if hasattr(e, "get_particles_pos") else None
            if state is not None and not np.isfinite(np.asarray(_host(state))).all():
                return False
        return True


def _host(x):
    return x.cpu().numpy() if hasattr(x, "cpu") else x


def run_case(name: str, repeats: int = 3, seconds: float = 2.0, echo=lambda m: None) -> dict:
    """One case on both engines in this process: each run once untimed, then ``repeats`` timed runs
    alternating ours and Genesis's. Returns both sides' seconds per simulated second and the ratios."""
    start_genesis()
    objects = {"boxes_at_rest": boxes_at_rest, "box_pile": box_pile, "sand_column": sand_column}[name]()
    with tempfile.TemporaryDirectory() as tmp:
        ours = Ours(pathlib.Path(tmp), objects, seconds)
        ours.run()  # untimed: kernels compiled, the model built, the frames' graphs captured
        s = ours.section
        frames = s["frames"] - 1
        mpm = s["mpm"]
        spacing = mpm["spacing_m"] if mpm else None
        substeps = (math.ceil(1.0 / s["fps"] / (GENESIS_MPM_DT_PER_DX * spacing) - 1e-9) if mpm
                    else s["substeps"])
        gen = Genesis(objects, s["fps"], substeps, spacing)
        gen.run(frames)  # untimed: Genesis's kernels compiled on their first step
        ours_s, gen_s, ours_cpu, gen_cpu = [], [], [], []
        for _ in range(repeats):
            wall, cpu = ours.run()
            ours_s.append(wall / seconds)
            ours_cpu.append(cpu / seconds)
            wall, cpu = gen.run(frames)
            gen_s.append(wall / seconds)
            gen_cpu.append(cpu / seconds)
            echo(f"  {name}: ours {ours_s[-1]:.4f}, Genesis {gen_s[-1]:.4f} s per simulated second "
                 f"(CPU: ours {ours_cpu[-1]:.4f}, Genesis {gen_cpu[-1]:.4f})")
    ratios = sorted(g / o for g, o in zip(gen_s, ours_s) if o > 0)
    cpu_ratios = sorted(g / o for g, o in zip(gen_cpu, ours_cpu) if o > 0)
    return {"case": name, "objects": len(objects), "fps": s["fps"], "frames": frames,
            "ours": {"substeps": s["substeps"], "mpm_steps": s["steps"].get("mpm_steps") if mpm else None,
                     "particles": mpm["particles"] if mpm else None, "spacing_m": spacing,
                     "captured_frames": s["captured_step"]["frames_replayed"],
                     "seconds_per_sim_second": ours_s, "cpu_seconds_per_sim_second": ours_cpu},
            "genesis": {"substeps": gen.substeps, "particles": gen.particles if mpm else None,
                        "finite": gen.finite(), "seconds_per_sim_second": gen_s, "cpu_seconds_per_sim_second": gen_cpu},
            "ratio": _spread(ratios), "cpu_ratio": _spread(cpu_ratios)}


def _spread(ratios: list) -> dict | None:
    return {"min": min(ratios), "median": statistics.median(ratios), "max": max(ratios)} if ratios else None


def bench_peer(only=(), repeats: int = 3, seconds: float = 2.0, echo=print) -> dict:
    """Run the cases (``only``: a subset of :data:`CASES`) and print one line each; returns the numbers,
    or ``{"genesis": None}`` having run nothing where Genesis is not installed."""
    PEER.check(repeats=repeats, seconds=seconds)  # before any work, as the command refuses them

    import os

    from .physics import machine

    if not genesis_available():
        echo(INSTALL)
        return {"genesis": None}
    gs = start_genesis()
    load = os.getloadavg()
    echo(f"machine: {machine()}; load average {', '.join(f'{x:.2f}' for x in load)}; Genesis {gs.__version__} "
         "(CPU backend)")
    echo(f"timed: {seconds:g} simulated seconds a run; ours = simulate_shot's stepping (the guarded loop with "
         "its checks and recording), Genesis = scene.step() at the same fps and substeps; both sides' build, "
         f"compiling and first run untimed; {repeats} runs each, alternating")
    rows = []
    for name in only or CASES:
        r = run_case(name, repeats, seconds, echo)
        rows.append(r)
        echo(case_line(r))
    return {"genesis": gs.__version__, "load_average": load, "simulated_seconds": seconds, "repeats": repeats,
            "cases": rows}


def case_line(r: dict) -> str:
    o, g, q = r["ours"], r["genesis"], r["ratio"]
    what = (f"{r['objects']} rigid, {o['substeps']} substeps a frame both" if o["particles"] is None else
            f"{o['particles']} particles ours, {g['particles']} Genesis; MPM steps a frame {o['mpm_steps']} ours, "
            f"{g['substeps']} Genesis (its explicit MPM's suggested step, 2e-2·dx)")
    ratio = (f"Genesis/ours min {q['min']:.2f}, median {q['median']:.2f}, max {q['max']:.2f}" if q else "no ratio")
    c = r.get("cpu_ratio")
    if c:  # what a loaded machine does not skew: wall seconds favour the engine running more threads
        ratio += f"; in CPU seconds min {c['min']:.2f}, median {c['median']:.2f}, max {c['max']:.2f}"
    finite = "" if g["finite"] else "; Genesis's particles not finite"
    return (f"{r['case']} ({what}; {r['fps']:g} fps): ours {statistics.median(o['seconds_per_sim_second']):.4f}, "
            f"Genesis {statistics.median(g['seconds_per_sim_second']):.4f} s per simulated second; {ratio}"
            f" (> 1: ours faster){finite}")

