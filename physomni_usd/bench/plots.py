"""Error against run time, one plot per case (matplotlib, the ``bench`` extra)."""

from __future__ import annotations

import math


def check_plots_possible() -> None:
    """Refuse (:class:`~physomni_usd.errors.InputError`) ``--plots`` where matplotlib is missing, before the
    bench runs."""
    import importlib.util

    from ..errors import InputError

    if importlib.util.find_spec("matplotlib") is None:
        raise InputError("--plots needs matplotlib, which is not installed: pip install 'physomni-usd[bench]'")
    try:
        import matplotlib  # noqa: F401 - found is not enough: it must import
    except ImportError as exc:
        raise InputError(f"--plots needs matplotlib, which does not import ({exc}): "
                         "pip install 'physomni-usd[bench]'") from None


def write_plots(numbers: dict, folder) -> list:
    """Error against seconds per simulated second, one PNG per case (matplotlib: see
    :func:`check_plots_possible`)."""
    import pathlib

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

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
