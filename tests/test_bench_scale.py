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


def test_the_whole_box_case_is_one_box_over_the_frame_with_clicks_on_and_off_the_masks(tmp_path):
    import cv2
    import numpy as np

    from physomni_usd.bench.limits import EXAMPLE, WHOLE_BOX
    from physomni_usd.bench.scale import whole_box_example
    from physomni_usd.perceive.masks import box_clicks, parse_box

    args = whole_box_example(EXAMPLE, (400, 345), tmp_path)
    assert args[1] == "--box" and len(args) == 3  # the masks are not given: the box is all build gets
    assert cv2.imread(args[0]).shape == (345, 400, 3)
    (box, label) = parse_box(args[2])
    assert box == (0, 0, 400, 345) and label == "motorcycle"
    clicks = box_clicks(args[2])
    assert sum(on for *_, on in clicks) == WHOLE_BOX["on"] and sum(not on for *_, on in clicks) == WHOLE_BOX["off"]
    masks = [cv2.resize(cv2.imread(str(EXAMPLE / f"{n}.png"), cv2.IMREAD_GRAYSCALE), (400, 345)) >= 128
             for n in ("motorcycle", "bench", "bin")]
    anywhere = np.any(masks, axis=0)
    for i, (x, y, on) in enumerate(clicks):
        if on:  # the objects in turn, each click on its own
            assert masks[i % 3][y, x], (x, y)
        else:
            assert not anywhere[max(0, y - 20):y + 21, max(0, x - 20):x + 21].any(), (x, y)
    assert whole_box_example(EXAMPLE, (400, 345), tmp_path / "again")[2] == args[2]  # one seed, one case


def test_bench_scale_whole_box_reports_the_build_and_its_stages(tmp_path):
    """A small frame keeps it quick; the 1.4 MP case is the same command with the default size."""
    import json

    from .conftest import cli

    out = tmp_path / "box.json"
    proc = cli("bench", "scale", "--whole-box", "240x207", "--json", out, check=True)
    numbers = json.loads(out.read_text())
    assert (numbers["width"], numbers["height"], numbers["repeats"]) == (240, 207, 1)
    assert numbers["median"]["cpu_s"] > 0 and numbers["median"]["peak_mb"] > 0
    stages = numbers["stages"]
    assert {"read", "texture.plate", "texture.outpaint", "check"} <= set(stages)
    assert all(v["wall_s"] >= 0 and v["cpu_s"] >= 0 for v in stages.values())
    # the process's CPU holds its stages' and the imports before them
    assert sum(v["cpu_s"] for v in stages.values()) <= numbers["median"]["cpu_s"] + 0.5
    assert "texture.plate" in proc.stdout
    bad = cli("bench", "scale", "--whole-box", "240")
    assert bad.returncode != 0 and "--whole-box" in bad.stderr.strip().splitlines()[-2]


def test_the_whole_box_case_refuses_a_mask_too_small_to_click_inside_or_too_large_to_click_off(tmp_path):
    import json

    import cv2
    import numpy as np
    import pytest

    from physomni_usd.bench.scale import whole_box_example
    from physomni_usd.errors import InputError

    cv2.imwrite(str(tmp_path / "photo.png"), np.full((200, 300, 3), 120, np.uint8))
    (tmp_path / "example.json").write_text(json.dumps({"photo": "photo.png", "masks": ["thing.png:thing"]}))
    thin = np.zeros((200, 300), np.uint8)
    thin[90:110, 140:146] = 255  # 6 px wide: no pixel of it 6 px inside
    everywhere = np.full((200, 300), 255, np.uint8)  # nothing 30 px off it
    for mask, why in ((thin, "no pixel 6 px inside"), (everywhere, "fewer than the 8 clicks")):
        cv2.imwrite(str(tmp_path / "thing.png"), mask)
        with pytest.raises(InputError, match=rf"^--whole-box 300x200: .*{why}"):
            whole_box_example(tmp_path, (300, 200), tmp_path / "out")


def test_whole_box_takes_the_sign_the_help_prints_and_refuses_the_options_it_does_not_use():
    from click.testing import CliRunner

    from physomni_usd.cli import main

    typed = CliRunner().invoke(main, ["bench", "scale", "--whole-box", "100×9000"])
    assert typed.exit_code == 2
    assert typed.output.strip().splitlines()[-1].startswith("error: --whole-box 100x9000: must be")
    for extra in (["--sizes", "1"], ["--stages", "build"], ["--objects", "3"], ["--seconds", "2"],
                  ["--max-size", "640"]):
        both = CliRunner().invoke(main, ["bench", "scale", "--whole-box", "300x200", *extra])
        assert both.exit_code == 2 and f"{extra[0]} cannot go with it" in both.output, both.output
