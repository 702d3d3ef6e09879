"""``bench scale``'s size axis (bench/scale.py): each repeat's whole run over the first size's in the same
repeat, so the ratio pairs runs made at one round's load."""

from physomni_usd.bench.scale import _paired


def _run(wall, cpu, load):
    # two stages splitting the run's seconds, as build and render would
    return {"build": {"wall_s": wall / 4, "cpu_s": cpu / 4, "peak_mb": 1.0, "load": load},
            "render": {"wall_s": 3 * wall / 4, "cpu_s": 3 * cpu / 4, "peak_mb": 1.0, "load": load}}


def test_each_repeat_is_put_over_the_first_sizes_run_of_the_same_repeat():
    small = [_run(10, 8, 2.0), _run(40, 10, 20.0), _run(20, 9, 6.0)]
    large = [_run(30, 16, 4.0), _run(50, 15, 20.0), _run(60, 27, 8.0)]
    out = _paired(large, small)
    assert out["wall_s"] == [3.0, 1.25, 3.0]
    assert out["cpu_s"] == [2.0, 1.5, 3.0]
    assert out["load"] == [3.0, 20.0, 7.0]
    assert out["min"] == {"wall_s": 1.25, "cpu_s": 1.5}
    # the median of the pairs, not the ratio of the medians (16/9 here)
    assert out["median"] == {"wall_s": 3.0, "cpu_s": 2.0}
    assert _paired(small, small)["cpu_s"] == [1.0, 1.0, 1.0]
