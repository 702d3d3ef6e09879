"""One place that imports warp and Newton: warp quietly, with the device picked the same way for every
stage; Newton without the parts no stage uses and with its narrow phase's kernels made once per process,
and both without Python's cycle collector walking, again and again, the objects their kernels are defined
as."""

from __future__ import annotations

import gc
import importlib.abc
import importlib.machinery
import importlib.util
import os
import sys
import tempfile
from contextlib import contextmanager
from functools import lru_cache, wraps

#: What warp's native library prints on every start of a machine without a GPU; not news to a CPU user.
_NO_DRIVER = "Could not find or load the NVIDIA CUDA driver"


@contextmanager
def _kernels_defined():
    """Python's cycle collector paused while modules define warp's built-ins and kernels, and what they made
    moved out of its reach afterwards. Each kernel's definition parses its function's source into many
    small objects that live as long as the process; the collector otherwise walks them all on every pass
    during the import, the run and the interpreter's exit (seconds of CPU for Newton's kernels). Garbage
    left before (a long process's earlier shots) is collected first, so that it is not frozen with them."""
    enabled = gc.isenabled()
    gc.collect()
    gc.disable()
    try:
        yield
    finally:
        gc.freeze()
        if enabled:
            gc.enable()


@lru_cache(maxsize=1)
def load_warp():
    """The initialised ``warp`` module, printing errors only.

    warp's banner and its native "no CUDA driver" notice would interleave with
    our progress output, so initialisation runs with the process's stdout and
    stderr captured; anything else it prints is passed on to stderr.
    """
    with _kernels_defined():
        import warp as wp

    wp.config.log_level = getattr(wp, "LOG_ERROR", wp.config.log_level)
    wp.config.quiet = True
    with tempfile.TemporaryFile(mode="w+b") as sink:
        sys.stdout.flush()
        sys.stderr.flush()
        saved = os.dup(1), os.dup(2)
        try:
            os.dup2(sink.fileno(), 1)
            os.dup2(sink.fileno(), 2)
            wp.init()
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
        sink.seek(0)
        text = sink.read().decode(errors="replace")
    rest = [ln for ln in text.splitlines() if ln.strip() and _NO_DRIVER not in ln]
    if rest:
        print("\n".join(rest), file=sys.stderr)
    _time_compiles()
    return wp


#: Wall seconds this process has spent in warp building kernel modules (codegen and the C++ or CUDA
#: compiler), and how many it built; a module found in the kernel cache adds nothing. None: this warp has
#: no ``Module._compile`` to time.
COMPILED: dict = {"seconds": None, "modules": 0}


def _time_compiles() -> None:
    """Time warp's own build of each kernel module, so that a first run can say what the compile cost
    rather than what the whole command did around it. warp compiles lazily, at a module's first launch,
    anywhere inside a model's construction or its first steps; only its ``Module._compile`` knows when."""
    import time

    try:
        from warp._src.context import Module
    except ImportError:
        return
    compile_ = getattr(Module, "_compile", None)
    if compile_ is None or getattr(compile_, "_physomni_timed", False):
        return
    COMPILED["seconds"] = 0.0

    @wraps(compile_)
    def timed(self, *args, **kwargs):
        start = time.perf_counter()
        built = compile_(self, *args, **kwargs)
        if built:  # False: found in the cache
            COMPILED["seconds"] += time.perf_counter() - start
            COMPILED["modules"] += 1
        return built

    timed._physomni_timed = True
    Module._compile = timed


def compiled_seconds() -> float | None:
    """Seconds spent compiling kernels so far in this process (None where it cannot be timed)."""
    return COMPILED["seconds"]


def pick_device(requested: str | None = None) -> str:
    """``requested`` if given, else ``cuda:0`` when a GPU is usable, else ``cpu``."""
    wp = load_warp()
    if requested:
        return requested
    return "cuda:0" if wp.is_cuda_available() else "cpu"


#: Newton's public submodules that no stage uses (actuators, controllers, inverse kinematics, selection,
#: sensors, its USD helpers and utilities, its viewer). ``import newton`` imports them all, defining a few
#: hundred warp kernels; they are imported on first use instead, as Newton already does for its solvers.
NEWTON_DEFERRED = ("newton.actuators", "newton.controllers", "newton.ik", "newton.selection", "newton.sensors",
                   "newton.usd", "newton.utils", "newton.viewer")


class _Deferred(importlib.abc.MetaPathFinder):
    """Finds the modules ``names`` as the path finder does, but loads each on its first attribute access
    (:class:`importlib.util.LazyLoader`)."""

    def __init__(self, names):
        self.names = frozenset(names)

    def find_spec(self, name, path, target=None):
        if name not in self.names:
            return None
        spec = importlib.machinery.PathFinder.find_spec(name, path)
        if spec is not None and spec.loader is not None:
            spec.loader = importlib.util.LazyLoader(spec.loader)
        return spec


@lru_cache(maxsize=1)
def load_newton():
    """The ``newton`` module, imported after warp (see :func:`load_warp`), its
    :data:`NEWTON_DEFERRED` submodules loaded on first use and its narrow phase's kernels kept between
    models (:func:`_keep_narrow_phase_kernels`)."""
    load_warp()
    finder = _Deferred(NEWTON_DEFERRED)
    sys.meta_path.insert(0, finder)
    try:
        with _kernels_defined():
            import newton
    finally:
        sys.meta_path.remove(finder)
    _keep_narrow_phase_kernels()
    return newton


#: Where Newton's collision pipeline makes the kernels of its narrow phase (``NarrowPhase.__init__``).
NARROW_PHASE = "newton._src.geometry.narrow_phase"


def _keep_narrow_phase_kernels() -> None:
    """Make each narrow-phase kernel once per process, not once per model.

    Newton's ``NarrowPhase`` builds its kernels anew for every model, from factories (``create_...``) closing
    over its contact writer and support functions and a few flags. warp then parses and hashes each new
    kernel's source before finding it in its cache: 0.3–0.5 s of every new shot's model on ten boxes, where
    the rest of the model takes 0.05 s. The same functions and flags make the same kernels, so each
    factory's result is kept by its arguments (those that cannot be a key are passed through). Where a
    Newton release has moved the module, nothing is kept and nothing else changes."""
    try:
        module = importlib.import_module(NARROW_PHASE)
    except ImportError:
        return
    for name in dir(module):
        factory = getattr(module, name)
        if name.startswith("create_") and callable(factory) and not hasattr(factory, "_physomni_kept"):
            setattr(module, name, _kept(factory))


def _kept(factory):
    made = {}

    @wraps(factory)
    def kept(*args, **kwargs):
        key = (args, tuple(sorted(kwargs.items())))
        try:
            hash(key)
        except TypeError:
            return factory(*args, **kwargs)
        if key not in made:
            made[key] = factory(*args, **kwargs)
        return made[key]

    kept._physomni_kept = True
    return kept


@lru_cache(maxsize=None)
def newton_solver(name: str):
    """Newton's solver class ``name`` (``"SolverXPBD"``, ``"SolverImplicitMPM"``): Newton imports each
    solver's module, and so defines its kernels, on first use; here under the same pause of the collector."""
    newton = load_newton()
    with _kernels_defined():
        return getattr(newton.solvers, name)
