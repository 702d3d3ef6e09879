"""``bench``: one command per benchmark of :mod:`physomni_usd.bench`; each prints a table and can write the same
numbers as JSON (:func:`write_numbers`)."""

from __future__ import annotations

import pathlib
import sys

import click

from ..bench import limits
from .options import limit_option
from .shell import errors


def json_option(what: str):
    """``--json PATH``: also write the bench's ``what`` (numbers, rows) to that file."""
    return click.option("--json", "json_path", type=click.Path(dir_okay=False, path_type=pathlib.Path),
                        default=None, help=f"Also write the {what} to this JSON file.")


def write_numbers(numbers, *paths) -> None:
    """Write a bench's numbers as indented JSON to each of ``paths`` that is given (None: not asked for),
    atomically; numpy numbers as floats."""
    import json

    from .._files import write_bytes

    text = (json.dumps(numbers, indent=2, default=float) + "\n").encode()
    for path in paths:
        if path is not None:
            write_bytes(path, text)


@click.group()
def bench():
    """Benchmarks: each prints a table and can write the same numbers as JSON."""


def example_option(help_text: str):
    """--example: the bundled example folder a bench runs (the library's default, ``bench.limits.EXAMPLE``)."""
    return click.option("--example", type=click.Path(file_okay=False, path_type=pathlib.Path),
                        default=limits.EXAMPLE, show_default=True, help=help_text)


@bench.command("pipeline")
@example_option("Example folder with example.json, a photo and its masks.")
@limit_option(limits.PIPELINE, "size")
@limit_option(limits.PIPELINE, "repeats")
@limit_option(limits.PIPELINE, "seconds")
@json_option("numbers")
def bench_pipeline_command(example, size, repeats, seconds, json_path):
    """Wall time of build and of a whole run on a bundled example (run twice for warm kernel caches)."""
    with errors():
        from ..bench.pipeline import bench_pipeline

        numbers = bench_pipeline(example, size=size, repeats=repeats, seconds=seconds, echo=click.echo)
        write_numbers(numbers, json_path)


@bench.command("render")
@example_option("Example folder with example.json, a photo and its masks.")
@limit_option(limits.RENDER, "size")
@limit_option(limits.RENDER, "seconds")
@click.option("--quick", is_flag=True, help="Render 0.3 s (10 frames) instead of --seconds.")
@json_option("numbers")
def bench_render_command(example, size, seconds, quick, json_path):
    """Frames per second of render on a bundled example: plain, and with every control pass (EXR + previews).

    \b
    Static camera (the photo's), the example's push simulated first. Example:
      physomni-usd bench render --quick --json out/render.json
    """
    with errors():
        from ..bench.render import bench_render

        numbers = bench_render(example, size=size, seconds=0.3 if quick else seconds, echo=click.echo)
        write_numbers(numbers, json_path)


@bench.command("batch")
@example_option("Example folder with example.json, a photo and its masks; every shot is this one.")
@click.option("--counts", default=",".join(map(str, limits.BATCH_COUNTS)), show_default=True, metavar="N,N,...",
              help="Numbers of shots to time.")
@limit_option(limits.BATCH, "size")
@limit_option(limits.BATCH, "seconds")
@limit_option(limits.BATCH, "fps")
@json_option("numbers")
def bench_batch_command(example, counts, size, seconds, fps, json_path):
    """Wall time and shots per hour of `batch` (local Ray) against `run` one after another.

    \b
    Needs the [batch] extra. N shots take about N small runs twice over, plus
    Ray's start-up once per N (minutes on a 2-core CPU).
    Example:
      physomni-usd bench batch --counts 1,2 --json out/batch.json
    """
    with errors():
        from ..errors import InputError

        try:
            numbers = [int(c) for c in counts.split(",")]
        except ValueError:
            raise InputError(f"--counts {counts!r}: expected whole numbers separated by commas") from None
        from ..bench.batch import bench_batch

        result = bench_batch(example, numbers, size=size, seconds=seconds, fps=fps, echo=click.echo)
        write_numbers(result, json_path)


@bench.command("plate")
@click.option("--quick", is_flag=True, help="Two hole shapes per surface instead of five.")
@json_option("rows")
def bench_plate_command(quick, json_path):
    """The background plate's fill on real photos of empty surfaces with object-shaped holes.

    \b
    Surfaces from scikit-image's bundled photos (brick, grass, gravel, a wooden table, a garage floor;
    needs the test extra: pip install 'physomni-usd[test]'); holes shaped like a cup, a saucer, a pencil,
    a bottle and a chair. For the exemplar (shift-map) fill that build uses and for OpenCV Telea: gradient
    ratio inside/around the hole (1 keeps the grain, a smear is far below 1), local colour difference
    (levels), SSIM inside the hole and seconds.

    \b
    Example:
      physomni-usd bench plate --quick --json out/plate.json
    """
    with errors():
        from ..bench.plate import bench_plate

        numbers = bench_plate(quick=quick, echo=click.echo)
        write_numbers(numbers, json_path)


_WHOLE_BOX_EXAMPLE = "x".join(map(str, limits.WHOLE_BOX["size"]))


@bench.command("scale")
@example_option("Example folder (with example.json) to scale.")
@click.option("--sizes", default=",".join(f"{x:g}" for x in limits.SCALE_SIZES_MP), show_default=True, metavar="MP,MP,...",
              help="Megapixels of the photos; 0 is the example as it is.")
@limit_option(limits.SCALE, "repeats")
@click.option("--stages", default=",".join(limits.SCALE_STAGES), show_default=True, help="Which stages to run.")
@limit_option(limits.SCALE, "seconds")
@limit_option(limits.SCALE, "max_size")
@click.option("--objects", default=None, metavar="N,N,...",
              help="Also simulate this many boxes dropped on the ground, each count a fresh process (e.g. "
                   "3,10,30,100): simulate's stepping seconds against the number of objects, and the exponent "
                   "of that growth. With --sizes '' only this axis runs. Range: "
                   f"{limits.SCALE['objects'].span()}.")
@click.option("--whole-box", default=None, metavar="WxH",
              help="Instead of the sizes: build alone, --repeats fresh processes, on the example stretched to W×H "
                   f"(e.g. {_WHOLE_BOX_EXAMPLE}) with ONE box over the whole frame and "
                   f"{limits.WHOLE_BOX['on']} clicks on its masks, {limits.WHOLE_BOX['off']} off them (seed "
                   f"{limits.WHOLE_BOX['seed']}); wall, CPU, peak memory and build's per-stage seconds. Each side is "
                   f"a whole number of pixels. Range: {limits.SCALE['whole_box'].span()}.")
@json_option("numbers")
def bench_scale_command(example, sizes, repeats, stages, seconds, max_size, objects, whole_box, json_path):
    """Each stage's wall time, CPU time and peak memory on one example scaled to each photo size, as ratios to
    the smallest; each stage a fresh process, the sizes alternating so that they share the load.

    \b
    Examples:
      physomni-usd bench scale --sizes 0,12 --repeats 3 --json out/scale.json
      physomni-usd bench scale --whole-box 1282x1105 --repeats 3
    """
    with errors():
        from ..bench.scale import bench_scale
        from ..errors import InputError

        if whole_box is not None:
            from click.core import ParameterSource

            from ..bench.scale import bench_whole_box

            given = [f"--{n.replace('_', '-')}" for n in ("sizes", "stages", "objects", "seconds", "max_size")
                     if click.get_current_context().get_parameter_source(n) is not ParameterSource.DEFAULT]
            if given:
                raise InputError(f"--whole-box: {', '.join(given)} cannot go with it (it builds only, at its size)")
            try:
                w, h = (int(x) for x in whole_box.lower().replace("×", "x").split("x"))
            except ValueError:
                raise InputError(f"--whole-box {whole_box!r}: expected WIDTHxHEIGHT in pixels, e.g. "
                                 f"{_WHOLE_BOX_EXAMPLE}") from None
            write_numbers(bench_whole_box(example, (w, h), repeats, echo=click.echo), json_path)
            return

        try:
            mps = tuple(float(x) for x in sizes.split(",") if x.strip())
        except ValueError:
            raise InputError(f"--sizes {sizes!r}: expected megapixels separated by commas") from None
        try:
            counts = tuple(int(x) for x in objects.split(",")) if objects else ()
        except ValueError:
            raise InputError(f"--objects {objects!r}: expected whole numbers separated by commas") from None
        numbers = {}
        if mps:
            numbers = bench_scale(example, mps, repeats, seconds, tuple(s.strip() for s in stages.split(",")),
                                  max_size, echo=click.echo)
        if counts:
            from ..bench.scale import bench_objects

            numbers["objects"] = bench_objects(counts, seconds, echo=click.echo)
        write_numbers(numbers, json_path)


@bench.command("look")
@click.option("--example", "examples", type=click.Path(file_okay=False, path_type=pathlib.Path), multiple=True,
              help="Example folder with example.json (repeatable) [default: every folder of examples/].")
@click.option("-o", "--output", "out_dir", type=click.Path(file_okay=False, path_type=pathlib.Path),
              default=pathlib.Path("out/look"), show_default=True, help="Folder for the sheets and look.json.")
@limit_option(limits.LOOK, "size")
@limit_option(limits.LOOK, "seconds")
@click.option("--no-browser", is_flag=True, help="Leave out the preview's opening view (no Chromium needed).")
@click.option("--truth-scenes", type=click.IntRange(0, 100), default=0, show_default=True,
              help="Also hold the fill against the truth on this many generated scenes (needs Blender's Python); "
                   "with no --example, only these.")
@click.option("--truth-seed", type=int, default=1, show_default=True, help="Seed of the generated scenes.")
def bench_look_command(examples, out_dir, size, seconds, no_browser, truth_scenes, truth_seed):
    """A contact sheet per bundled example and the figures of what is left where objects stood.

    \b
    Sheet: the photo, frames 0, middle and last, the last frame under --camera orbit-left, and the
    preview's opening view in headless Chromium. Figures, on the last frame without the moved objects'
    new contact shadows, for each revealed area against a ring around it: gradient ratio (target
    0.6-1.6), border gradient ratio (<= 1.3), colour difference against the ring's colour near each
    pixel of the area (<= 8 levels); in brackets, the frame as shown (gradient, border, and colour
    against the ring's plain mean); frame 0's PSNR against the photo; the opening view's SSIM. With
    --truth-scenes, each fill's error against the true background (generated scenes rendered without
    their objects) in the revealed area, and whether the default fill errs at most as much as Telea's and
    the blend's with no revealed colour farther than 60 levels from its surroundings'.

    \b
    Example:
      physomni-usd bench look --example examples/desk -o out/look
    """
    with errors():
        from ..bench.look import bench_look

        bench_look(list(examples), out_dir, size=size, seconds=seconds, browser=not no_browser, echo=click.echo,
                   truth_scenes=truth_scenes, truth_seed=truth_seed)


@bench.command("alignment")
@click.option("--quick", is_flag=True, help="Smaller images and fewer scenes (a few minutes on a CPU).")
@click.option("--only", type=click.Choice(["all", "ablation", "stacks"]), default="all", show_default=True,
              help="The paper's ablation tables, the stacked scenes, or both.")
@click.option("--stack", "stacks", multiple=True, metavar="NAME",
              help="Run only this stacked scene (cup_saucer_spoon, three_boxes, bowl_of_spheres, tray_of_parts); "
                   "repeatable [default: all four].")
@json_option("rows")
def bench_alignment_command(quick, only, stacks, json_path):
    """The paper's alignment ablations on synthetic scenes with known truth (scene and camera tables), and
    stacked scenes with truth (a cup on its saucer with a spoon, three boxes stacked, a bowl of balls, a
    tray of identical parts from straight above) built as a user's photo would be and simulated 2 s with
    nothing pushed: per object, mask IoU from the photo's view and orbited ±45°, position error over the
    camera distance, size error and rest drift, each against the holistic targets (STACK_LIMITS in
    physomni_usd/bench/alignment.py).

    \b
    Example:
      physomni-usd bench alignment --only stacks --stack cup_saucer_spoon --json out/stacks.json
    """
    with errors():
        from ..bench.alignment import bench_alignment, write_json

        numbers = bench_alignment(quick=quick, echo=click.echo, only=only, stacks=stacks or None)
        if json_path:
            write_json(numbers, json_path)


@bench.command("photos")
@limit_option(limits.PHOTOS, "pitches", multiple=True)
@limit_option(limits.PHOTOS, "seconds")
@click.option("--real", "real", multiple=True, metavar="NAME",
              help="Run only this real photo (desk, smarties, coffee, motorcycle, football, rubberwhale, fruits, "
                   "heap, parts); repeatable [default: all nine].")
@click.option("--only", type=click.Choice(["all", "synthetic", "real"]), default="all", show_default=True,
              help="Which half of the bench to run.")
@json_option("rows")
def bench_photos_command(pitches, seconds, real, only, json_path):
    """Photos with known truth through the built-in path: camera, scale, lifting, frame 0 and a short run.

    \b
    Synthetic scenes (a box, a can, a plate and a bottle of typical sizes on a checkered floor) under a
    known camera at each pitch; prints pitch error, field-of-view error, position and height errors after
    the scale, size error, the scale's source, frame-0 SSIM, seconds and whether the run finished.
    Acceptance: pitch within 5°, field of view within 10 %, positions within 5 % of the camera distance,
    heights within 15 %.

    \b
    Real photos that packages ship (OpenCV's samples, scikit-image's data): a desk from above, sweets from
    steeply above, an espresso cup on its saucer, a motorcycle in a garage, a football on grass and a
    rubber whale on a cloth, a close-up pile of fruit, boxes and a bag heaped on a chair, and six identical
    parts on a lightbox from above, with a pitch and sizes measured by hand (physomni_usd/bench/real/photos.json
    says how). Prints the pitch error, each object's longest dimension over its real one, the scale's source,
    frame-0 SSIM, seconds, whether a --seconds run finished (nothing pushed) and how far its rigid objects
    moved. Acceptance: every object within a factor 1.5 of its real size.

    \b
    Example:
      physomni-usd bench photos --pitch 30 --pitch 85 --json out/photos.json
      physomni-usd bench photos --only real --real desk --seconds 2
    """
    with errors():
        from ..bench.real_photos import bench_both_halves

        numbers = bench_both_halves(pitches, seconds, real, only, echo=click.echo)
        write_numbers(numbers, json_path)


@bench.command("general")
@limit_option(limits.GENERAL, "n")
@limit_option(limits.GENERAL, "seed")
@click.option("-o", "--out", "out_dir", type=click.Path(file_okay=False, path_type=pathlib.Path), default=None,
              help="Keep every scene (photo, masks, truth.json), its two shots, general.json and general.md here "
                   "[default: a temporary folder, removed at the end].")
@limit_option(limits.GENERAL, "seconds")
@click.option("--only", type=click.Choice(["both", "masks", "boxes"]), default="both", show_default=True,
              help="Build each scene from its visible masks, from their bounding boxes, or both.")
@limit_option(limits.GENERAL, "materials")
@click.option("--camera-given", is_flag=True,
              help="Tell each build the true pitch and field of view (--pitch, --fov): what is left wrong is the "
                   "lift's and the placement's, not the camera's.")
@click.option("--fov-given", is_flag=True,
              help="Tell each build the true field of view alone (--fov), the pitch still read from the photo: "
                   "what the view the photo did not show costs, apart from the pitch.")
@json_option("numbers")
def bench_general_command(n, seed, out_dir, seconds, only, materials, camera_given, fov_given, json_path):
    """Scenes generated fresh, rendered with Blender's Cycles, each built as a user's photo would be.

    \b
    Every run draws new scenes (without --seed a new seed is drawn and printed): objects of many kinds
    (boxes, books, cups, bowls, bottles, fruit, coins and cards, toys, a plant in its pot) alone, stacked,
    piled, in a bowl, on a shelf or hung on a wall, on wood, cloth, paper, a printed board or tiles, under a
    camera at a pitch of 0-90° and a field of view of 25-80°, 320x240 px, 24 samples (5-30 s a render on
    2 cores). The truth: each object's visible mask (an object-id render) and whole outline, the camera,
    every mesh. Each scene is built with labels from its visible masks and from their bounding boxes.

    \b
    Invariants, per scene: build exits 0, simulate does not refuse, no start overlap over 2 mm, and with
    nothing pushed nothing moves over 1 cm or turns over 5° in --seconds. Truth, per object: IoU of the
    built mesh against the visible mask and the whole outline from the photo's view (>= 0.85) and against
    the truth from the camera orbited ±45° (>= 0.7), position error (after the one scale a photo cannot
    show) over the camera distance (<= 5 %), longest dimension within 1.5x; per scene pitch within 10°.
    With --materials K, K objects of each scene also simulate 1 s as each of mpm_elastic, mpm_sand and
    pbd_cloth without a stop or a non-finite value. Prints a row per scene and build, then the pass rates
    (Markdown).

    \b
    Needs Blender's Python module (bpy==5.0.1 pins numpy<2): install it in an environment of its own and
    set PHYSOMNI_BLENDER_PYTHON to that environment's python.

    \b
    Example:
      physomni-usd bench general --n 10 -o out/general
      physomni-usd bench general --n 3 --seed 4242 --only masks
    """
    with errors():
        from ..bench.general import MODES, bench_general, markdown

        numbers = bench_general(n, seed, out_dir, MODES if only == "both" else (only,), seconds,
                                echo=click.echo, materials=materials,
                                camera_given=True if camera_given else ("fov" if fov_given else False))
        write_numbers(numbers, json_path, out_dir / "general.json" if out_dir else None)
        if out_dir:
            from .._files import write_bytes

            write_bytes(out_dir / "general.md", markdown(numbers).encode())


@bench.command("physics")
@click.option("--quick", is_flag=True, help="Fewer settings, one repeat, a smaller matrix (a few minutes).")
@json_option("rows")
@click.option("--plots", "plots_dir", type=click.Path(file_okay=False, path_type=pathlib.Path), default=None,
              help="Write error-against-time plots (PNG, needs matplotlib) to this folder.")
@click.option("--markdown", "md_path", type=click.Path(dir_okay=False, path_type=pathlib.Path), default=None,
              help="Write the tables as Markdown, dated and with the machine, to this file: a new file, or "
                   "one whose '<!-- bench physics: ... -->' and '<!-- /bench physics -->' lines mark the part "
                   "to replace (any other file is refused).")
def bench_physics_command(quick, json_path, plots_dir, md_path):
    """Error against run time of Newton's solvers, and the stiff and extreme matrix.

    \b
    Rigid cases (free fall, drag, incline, restitution, stack, rotation) on XPBD, MuJoCo (if
    installed), Featherstone and semi-implicit; cloth sag, an elastic bar, a dam break and a granular
    column on cloth and MPM; then the matrix (E from 1e3 to 1e9 Pa, densities, a 1:1000 stack,
    50 m/s at a 5 mm wall, a 1 mm cube, 1e4 N on 10 g) through `simulate` and its guard, a
    100,000-particle memory probe and the cost of ten objects at the simulator's defaults.

    \b
    Example:
      physomni-usd bench physics --quick --plots out/plots --json out/physics.json
    """
    with errors():
        from ..bench.markdown import check_markdown_target
        from ..bench.physics import bench_physics, write_plots
        from ..bench.plots import check_plots_possible

        if md_path:
            check_markdown_target(md_path)
        if plots_dir:
            check_plots_possible()
        numbers = bench_physics(quick=quick, echo=click.echo)
        if plots_dir:
            written = write_plots(numbers, plots_dir)
            click.echo(f"plots: {len(written)} written to {plots_dir}", err=True)
        write_numbers(numbers, json_path)
        if md_path:
            from .._files import write_bytes

            from ..bench.physics import markdown, splice_markdown

            text = markdown(numbers)
            if md_path.is_file():
                text = splice_markdown(md_path.read_text(), text)
            write_bytes(md_path, text.encode())


@bench.command("preview")
@click.option("--quick", is_flag=True, help="1 and 20 objects only, shorter runs (about two minutes).")
@json_option("numbers")
def bench_preview_command(quick, json_path):
    """Frames per second of the live preview, and the step against Genesis.

    \b
    Prints, in one run: the preview loop's rate (step, read back, publish; unpaced) for 1, 5, 10 and
    20 rigid boxes with a headless chromium attached where one is installed (/usr/bin/chromium and
    playwright), the same for 20 boxes without the graph capture; for ten boxes dropped and ten at rest,
    simulate's stepping, the whole simulate call (the first in a process, repeated ones, and a new shot
    in the same process, as each shot of a batch after its first) and the `physomni-usd simulate`
    command, each as a multiple of its stepping (target: the call within 3×), with the load average;
    and `bench peer`'s ten boxes at rest against Genesis when genesis-world is installed (pip install
    'physomni-usd[peer]'; target: ours ≥ 1.5× Genesis). Each measurement runs in a fresh interpreter.

    \b
    Example:
      physomni-usd bench preview --json out/preview.json
    """
    with errors():
        from ..bench.preview import bench_preview

        numbers = bench_preview(quick=quick, echo=click.echo)
        write_numbers(numbers, json_path)


@bench.command("peer")
@click.option("--only", "only", multiple=True, type=click.Choice(["boxes_at_rest", "box_pile", "sand_column"]),
              help="Run only this case (repeatable).")
@limit_option(limits.PEER, "repeats")
@limit_option(limits.PEER, "seconds")
@json_option("numbers")
def bench_peer_command(only, repeats, seconds, json_path):
    """The simulator against Genesis 1.4.5, in one process, case by case.

    \b
    Cases: ten boxes at rest on the ground; twenty boxes dropped in shifted layers so that they
    collide and topple; a 0.1 × 0.1 × 0.2 m sand column on both engines' MPM at the same particle
    spacing. Timed: ours is simulate_shot's stepping (the guarded loop with its checks and recording,
    what `simulate` runs, reported as seconds.step); Genesis's is scene.step() over the same frames at
    the same fps and substeps (for the sand: ours at its implicit MPM's steps a frame, Genesis's explicit
    MPM at the substep it suggests, 0.02 s per metre of particle spacing).
    Each engine's model build, kernel compiling and first run are left out alike. Prints, per case,
    Genesis's time over ours, min / median / max over the runs (> 1: ours is faster), in wall seconds
    and in the process's CPU seconds (which a loaded machine does not inflate).

    \b
    Genesis pins its own pillow: install it in an environment of its own (pip install torch==2.13.0
    'physomni-usd[peer]'). Without it the command says so and exits 0 having run nothing. The first
    run compiles Genesis's kernels (minutes).

    \b
    Example:
      physomni-usd bench peer --only boxes_at_rest --json out/peer.json
    """
    with errors():
        from ..bench.peer import bench_peer

        numbers = bench_peer(only=only, repeats=repeats, seconds=seconds, echo=click.echo)
        if numbers.get("genesis"):
            write_numbers(numbers, json_path)


@bench.command("faults")
@click.option("--only", "only", multiple=True, metavar="CASE",
              help="Run only this case (repeatable); the cases are the rows the command prints.")
@json_option("matrix")
def bench_faults_command(only, json_path):
    """The reliability matrix: signals, kills, a photo bomb, two writers, NaNs, another origin, secrets, a
    full disk, each against a tiny shot through the CLI; one row per case with trials tried and clean.

    \b
    Example:
      physomni-usd bench faults --only "photo bomb"
    """
    with errors():
        from ..bench.faults import bench_faults

        rows = bench_faults(only=only, echo=click.echo)
        write_numbers(rows, json_path)
        if any(r["clean"] < r["tried"] for r in rows.values()):
            sys.exit(1)
