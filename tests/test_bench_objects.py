"""``bench scale``'s object axis (bench/scale.py, bench_objects): simulate on more dropped boxes, each in a fresh
process, its stepping's seconds read from the shot's report, and the growth's exponent fitted over the counts."""

import math

from physomni_usd.bench.scale import bench_objects


def test_the_object_axis_times_each_count_and_fits_the_growth():
    lines = []
    out = bench_objects((2, 6), seconds=0.2, echo=lines.append)
    assert [r["objects"] for r in out["rows"]] == [2, 6]
    for r in out["rows"]:
        assert r["step_s"] > 0 and r["step_cpu_s"] > 0 and r["cpu_s"] > 0 and r["peak_mb"] > 0
    assert out["rows"][0]["ratio_to_fewest"]["step_s"] == 1.0
    # the slope through two points is the log of the stepping's ratio over the log of the boxes'
    s0, s1 = (r["step_s"] for r in out["rows"])
    assert math.isfinite(out["exponent"])
    assert abs(out["exponent"] - math.log(s1 / s0) / math.log(3.0)) < 1e-2
    # the solver's contacts counted at the guard's checks: boxes on the ground hold more as there are more boxes
    assert 0 < out["rows"][0]["contacts"] < out["rows"][1]["contacts"]
    assert math.isfinite(out["exponent_cpu_by_contacts"])
    c0, c1 = (r["step_cpu_s"] for r in out["rows"])
    assert abs(out["exponent_cpu"] - math.log(c1 / c0) / math.log(3.0)) < 1e-2
    assert any("stepping grows as boxes^" in line and "in CPU seconds" in line for line in lines)
