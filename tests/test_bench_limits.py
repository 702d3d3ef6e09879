"""The numbers outside the settings models (the benches', the batch's, the re-render's) are checked by the
functions that take them, and the commands read their defaults and ranges from the same tables: the
Python call and the command refuse the same values with the same line, before any work."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from physomni_usd.batch.runner import LIMITS as BATCH, check_batch, run_batch
from physomni_usd.bench import limits
from physomni_usd.bench.batch import bench_batch
from physomni_usd.bench.general import bench_general
from physomni_usd.bench.look import bench_look
from physomni_usd.bench.peer import bench_peer
from physomni_usd.bench.pipeline import bench_pipeline
from physomni_usd.bench.real_photos import bench_both_halves
from physomni_usd.bench.render import bench_render
from physomni_usd.bench.scale import bench_scale, bench_whole_box
from physomni_usd.cli import main
from physomni_usd.errors import InputError
from physomni_usd.preview import limits as pages
from physomni_usd.preview.app import Options, Preview
from physomni_usd.rerender import LIMITS as RERENDER, rerender_shot

# (command, bench function called with the one bad value, the CLI's arguments); every call is refused
# before it reads the example, starts Ray or Blender, or renders anything
CASES = [
    ("pipeline", lambda: bench_pipeline("examples/motorcycle", size=10), ["--size", "10"]),
    ("pipeline", lambda: bench_pipeline("examples/motorcycle", repeats=51), ["--repeats", "51"]),
    ("render", lambda: bench_render("examples/motorcycle", size=5000), ["--size", "5000"]),
    ("render", lambda: bench_render("examples/motorcycle", seconds=0.05), ["--seconds", "0.05"]),
    ("batch", lambda: bench_batch("examples/motorcycle", size=32), ["--size", "32"]),
    ("batch", lambda: bench_batch("examples/motorcycle", fps=500.0), ["--fps", "500"]),
    ("scale", lambda: bench_scale("examples/motorcycle", repeats=0), ["--repeats", "0"]),
    ("scale", lambda: bench_whole_box("examples/motorcycle", (40, 9000)), ["--whole-box", "40x9000"]),
    ("look", lambda: bench_look([], "out/never", seconds=31.0), ["--seconds", "31"]),
    ("photos", lambda: bench_both_halves(pitches=(30.0, 90.0)), ["--pitch", "30", "--pitch", "90"]),
    ("general", lambda: bench_general(0), ["--n", "0"]),
    ("general", lambda: bench_general(3, seed=-1), ["--n", "3", "--seed", "-1"]),
    ("general", lambda: bench_general(3, materials=101), ["--n", "3", "--materials", "101"]),
    ("peer", lambda: bench_peer(repeats=21), ["--repeats", "21"]),
    ("peer", lambda: bench_peer(seconds=0.0), ["--seconds", "0"]),
]
# the same for commands outside ``bench``: (argv before the options, the call, the options)
OTHERS = [
    (["batch", "shots.txt"], lambda: run_batch([], retries=21, call=None), ["--retries", "21"]),
    (["batch", "shots.txt"], lambda: check_batch(None, workers=0), ["--workers", "0"]),
    (["batch", "shots.txt"], lambda: run_batch([], cpus_per_shot=0.0, call=None), ["--cpus-per-shot", "0"]),
    (["rerender", "shot.usda"], lambda: rerender_shot("shot.usda", None, strength=0.0), ["--strength", "0"]),
    (["rerender", "shot.usda"], lambda: rerender_shot("shot.usda", None, steps=1001), ["--steps", "1001"]),
    (["rerender", "shot.usda"], lambda: rerender_shot("shot.usda", None, max_size=8), ["--max-size", "8"]),
    (["preview", "shot.usda"], lambda: Preview("shot.usda", Options(port=0)), ["--port", "0"]),
    (["preview", "shot.usda"], lambda: Preview("shot.usda", Options(duration=0.0)), ["--duration", "0"]),
    (["studio", "photo.png", "-o", "out"], lambda: _studio(port=65535), ["--port", "65535"]),
    (["estimate", "shot.usda"], lambda: _vlm(timeout_s=0.5), ["--vlm-timeout", "0.5"]),
    (["render", "shot.usda"], lambda: _render(camera_amount=4.5), ["--camera", "orbit-left", "--camera-amount", "4.5"]),
]


def _vlm(**kw):
    from physomni_usd.materials.vlm import VLMSettings

    return VLMSettings.resolve("http://localhost:1/v1", "model", **kw)


def _render(**kw):
    from physomni_usd.rendering.video import render_shot

    return render_shot("shot.usda", "video.mp4", camera="orbit-left", **kw)


def _studio(**options):
    from physomni_usd.studio import Options as StudioOptions, Studio

    return Studio("photo.png", "out", StudioOptions(**options))


@pytest.mark.parametrize("command,call,args", CASES + OTHERS,
                         ids=[f"{' '.join(c[0]) if isinstance(c[0], list) else c[0]} {' '.join(c[2])}"
                              for c in CASES + OTHERS])
def test_the_bench_function_refuses_what_the_command_refuses_with_the_same_line(command, call, args):
    with pytest.raises(InputError) as refused:
        call()
    assert str(refused.value).startswith(f"{args[-2]} {args[-1]}: must be "), str(refused.value)
    result = CliRunner().invoke(main, (command if isinstance(command, list) else ["bench", command]) + args)
    assert result.exit_code == 2, result.output
    assert result.output.strip().splitlines()[-1] == f"error: {refused.value}"


def test_each_option_takes_its_default_and_range_from_the_table():
    bench = main.commands["bench"]
    for group, command, table in ((bench, "pipeline", limits.PIPELINE), (bench, "render", limits.RENDER),
                                  (bench, "batch", limits.BATCH), (bench, "scale", limits.SCALE),
                                  (bench, "look", limits.LOOK), (bench, "photos", limits.PHOTOS),
                                  (bench, "general", limits.GENERAL), (bench, "peer", limits.PEER),
                                  (main, "batch", BATCH), (main, "rerender", RERENDER),
                                  (main, "preview", pages.PREVIEW), (main, "studio", pages.STUDIO)):
        params = {p.name: p for p in group.commands[command].params}
        for name, limit in table.items():
            option = params[name]
            assert option.opts[0] == limit.flag, (command, name)
            assert option.default == limit.default, (command, name)
            assert f"Range: {limit.span()}." in option.help or not limit.span(), (command, name)


def test_a_value_at_the_edge_of_a_range_passes_and_a_fraction_does_not_pass_for_a_count():
    limits.PIPELINE.check(size=64, repeats=50)
    limits.PHOTOS.check(pitches=(0.0, 89.5), seconds=0.0)
    with pytest.raises(InputError, match=r"^--repeats 2.5: must be a whole number, 1 ≤ value ≤ 50$"):
        limits.PIPELINE.check(repeats=2.5)
    with pytest.raises(InputError, match=r"^--seconds nan: must be 0.1 ≤ value ≤ 20$"):
        limits.PEER.check(seconds=float("nan"))
    BATCH.check(cpus_per_shot=0.01, gpus_per_shot=0.0)
    with pytest.raises(InputError, match=r"^--seed 1.5: must be a whole number$"):
        RERENDER.check(seed=1.5)


def test_the_object_axis_refuses_a_count_out_of_range_before_any_run():
    from physomni_usd.bench.scale import bench_objects

    with pytest.raises(InputError, match=r"^--objects 0: must be"):
        bench_objects((0, 3))
    result = CliRunner().invoke(main, ["bench", "scale", "--sizes", "", "--objects", "0,3"])
    assert result.exit_code == 2 and "--objects 0: must be" in result.output
