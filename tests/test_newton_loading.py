"""Newton as the simulator loads it: the submodules no stage uses are left until first touched (and then
work), and what warp and Newton defined is kept out of the cycle collector's later walks, which stays on."""

import json
import subprocess
import sys

from physomni_usd._warp import NEWTON_DEFERRED

PROBE = """
import gc, json, sys
from physomni_usd._warp import NEWTON_DEFERRED, load_newton
newton = load_newton()
lazy = [n for n in NEWTON_DEFERRED if type(sys.modules.get(n)).__name__ == "_LazyModule"]
frozen, enabled = gc.get_freeze_count(), gc.isenabled()
kind = newton.sensors.__name__  # first touch: loaded now
print(json.dumps({"lazy": lazy, "frozen": frozen, "enabled": enabled, "touched": kind,
                  "still_lazy": type(sys.modules["newton.sensors"]).__name__ == "_LazyModule",
                  "model": hasattr(newton, "ModelBuilder")}))
"""


def test_newton_loads_without_its_unused_submodules_and_with_the_collector_on():
    proc = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, check=True)
    r = json.loads(proc.stdout.strip().splitlines()[-1])
    assert sorted(r["lazy"]) == sorted(NEWTON_DEFERRED)  # none imported with Newton
    assert r["touched"] == "newton.sensors" and not r["still_lazy"]  # and each one loads when used
    assert r["model"] and r["enabled"] and r["frozen"] > 10000
