"""``bench preview`` reports Genesis through ``bench peer``'s own ten-boxes case (one code path, the same
figures), and its simulate rows give each figure over the stepping of its own run."""

from physomni_usd.bench import peer, preview, scenes, ten_objects


def _peer_case():
    return {"case": "boxes_at_rest", "objects": 10, "fps": 30.0, "frames": 60,
            "ours": {"substeps": 8, "mpm_steps": None, "particles": None, "spacing_m": None, "captured_frames": 54,
                     "seconds_per_sim_second": [0.05, 0.04, 0.06]},
            "genesis": {"substeps": 8, "particles": None, "finite": True, "seconds_per_sim_second": [0.2, 0.2, 0.3]},
            "ratio": {"min": 3.33, "median": 4.0, "max": 6.0}}


def test_the_genesis_row_is_bench_peers_ten_boxes_case(monkeypatch):
    calls = []

    def fresh(module, function, **kwargs):
        calls.append((module, function, kwargs))
        return _peer_case() if function == "run_case" else {"error": "not run here"}

    monkeypatch.setattr(scenes, "in_fresh_interpreter", fresh)
    monkeypatch.setattr(ten_objects, "ten_objects", lambda echo, case: {"case": case})
    monkeypatch.setattr(peer, "genesis_available", lambda: True)
    monkeypatch.setattr(preview, "browser_available", lambda: False)
    said = []
    out = preview.bench_preview(quick=True, echo=said.append)
    assert ("physomni_usd.bench.peer", "run_case", {"name": "boxes_at_rest"}) in calls
    assert out["genesis"] == _peer_case()
    row = [s for s in said if "Genesis" in s and "ours" in s]
    assert row == [f"bench peer's {peer.case_line(_peer_case())}; meets the target of ≥ 1.5× Genesis"]


def test_each_simulate_figure_is_over_its_own_runs_stepping():
    t = {"case": "at_rest", "simulated_seconds": 2.0, "solver": "xpbd", "substeps": 8, "iterations": 2,
         "load_average": {"start": 1.0, "end": 2.0}, "step_seconds": 0.1, "times_real_time": 20.0,
         "importing_the_simulator_seconds": 1.5, "call_target": 3.0,
         "first_call": {"seconds": 4.0, "step_seconds": 0.5, "times_its_stepping": 8.0,
                        "parts": {"read": 2.0, "build_model": 1.4, "step": 0.5, "write": 0.1}},
         "repeated_calls": {"seconds": [0.3, 0.25, 0.2], "step_seconds": [0.1, 0.1, 0.1],
                            "times_its_stepping": [3.0, 2.5, 2.0]},
         "new_shots": {"seconds": [0.5, 0.4, 0.6], "step_seconds": [0.1, 0.1, 0.1],
                       "times_its_stepping": [5.0, 4.0, 6.0]},
         "command": {"wall_seconds": [8.0, 9.0, 10.0], "cpu_seconds": [5.0, 5.0, 6.0], "step_seconds": [0.2, 0.3, 0.4],
                     "times_its_stepping": [40.0, 30.0, 25.0], "cpu_times_its_stepping": [25.0, 16.7, 15.0]}}
    first, repeated, new, command = ten_objects.lines(t)[2:]
    assert "8.0×" in first and "not within 3×" in first
    assert "2.5× its stepping (within 3×" in repeated
    assert "5.0× its stepping (not within 3×; runs 5.0×, 4.0×, 6.0×)" in new
    assert "30× in wall time, 17× in CPU (not within 3×)" in command
