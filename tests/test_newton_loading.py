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


KEPT = """
import json
import numpy as np
from physomni_usd._warp import load_newton, load_warp
from physomni_usd.physics.stepping import contact_pipeline
wp, newton = load_warp(), load_newton()
found = []
for size in (0.1, 0.2):  # two different scenes, one after the other in one process
    builder = newton.ModelBuilder()
    builder.add_ground_plane()
    body = builder.add_body(xform=wp.transform((0.0, 0.0, size / 2), wp.quat_identity()))
    builder.add_shape_box(body, hx=size / 2, hy=size / 2, hz=size / 2)
    model = builder.finalize(device="cpu")
    pipeline, contacts = contact_pipeline(model)
    state = model.state()
    pipeline.collide(state, contacts)
    found.append({"kernel": id(pipeline.narrow_phase.primitive_kernel),
                  "contacts": int(contacts.rigid_contact_count.numpy()[0])})
print(json.dumps(found))
"""


def test_a_second_model_in_a_process_reuses_the_narrow_phase_kernels_and_finds_its_contacts():
    proc = subprocess.run([sys.executable, "-c", KEPT], capture_output=True, text=True, check=True)
    first, second = json.loads(proc.stdout.strip().splitlines()[-1])
    assert first["kernel"] == second["kernel"]  # made once, not once per model
    assert first["contacts"] >= 4 and second["contacts"] >= 4  # a box standing on the ground
