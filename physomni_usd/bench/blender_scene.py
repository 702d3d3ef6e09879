"""Render one generated scene with Blender's Cycles on the CPU: run by the Python that has ``bpy``, not imported.

``python blender_scene.py SCENE.json`` reads the scene that ``bench/general_render.py`` describes (triangle meshes in
world coordinates, metres, Z up; their procedural materials; the camera in OpenCV axes; the lights) and
writes two PNGs: the photo (path tracing, denoised) and the object-id image (each object's own flat
emission, one sample per pixel, no filter, no colour transform), from which the visible masks are read.
It prints one ``RESULT {...}`` line with the seconds each render took.

Blender's Python module pins numpy<2, so it lives in an environment of its own; this file imports nothing
of the project and nothing beyond the standard library and ``bpy``.
"""

import json
import math
import sys
import time

import bpy
from mathutils import Matrix

#: The object-id image stores object k (1-based) as red = k * ID_STEP / 255 (0 is what no object covers).
ID_STEP = 4


def _node(tree, kind, **inputs):
    n = tree.nodes.new(kind)
    for key, value in inputs.items():
        n.inputs[key].default_value = value
    return n


def _rgba(c):
    return (float(c[0]), float(c[1]), float(c[2]), 1.0)


def _mix(tree, fac, a, b):
    """A colour mix node between a and b (sockets or colours) by fac (a socket)."""
    m = tree.nodes.new("ShaderNodeMix")
    m.data_type = "RGBA"
    tree.links.new(fac, m.inputs[0])
    for sock, value in ((m.inputs[6], a), (m.inputs[7], b)):
        if isinstance(value, (list, tuple)):
            sock.default_value = _rgba(value)
        else:
            tree.links.new(value, sock)
    return m.outputs[2]


def _material(name, spec):
    """A Principled BSDF whose colour, roughness and bump come from Blender's procedural textures in the
    object's own coordinates (metres: the meshes are authored in world coordinates), by ``spec["kind"]``."""
    mat = bpy.data.materials.new(name)
    tree = mat.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    bsdf = _node(tree, "ShaderNodeBsdfPrincipled", Roughness=float(spec.get("roughness", 0.5)),
                 Metallic=float(spec.get("metallic", 0.0)))
    tree.links.new(bsdf.outputs[0], out.inputs["Surface"])
    coord = tree.nodes.new("ShaderNodeTexCoord").outputs["Object"]
    colours = spec.get("colours") or [[0.5, 0.5, 0.5]]
    a, b = colours[0], colours[1] if len(colours) > 1 else [c * 0.8 for c in colours[0]]
    s = float(spec.get("scale", 10.0))
    kind = spec.get("kind", "plain")
    height = None
    if kind == "wood":  # growth rings: bands distorted by noise, along the board's grain
        wave = _node(tree, "ShaderNodeTexWave", Scale=s, Distortion=float(spec.get("distortion", 6.0)),
                     Detail=4.0)
        wave.wave_type = "RINGS" if spec.get("rings") else "BANDS"
        tree.links.new(coord, wave.inputs["Vector"])
        grain = _node(tree, "ShaderNodeTexNoise", Scale=s * 12.0, Detail=6.0)
        tree.links.new(coord, grain.inputs["Vector"])
        colour = _mix(tree, wave.outputs["Fac"], a, b)
        colour = _mix(tree, grain.outputs["Fac"], colour, [c * 0.8 for c in a])
        height = wave.outputs["Fac"]
    elif kind == "cloth":  # a weave: warp and weft bands, a coarse check of two colours, fuzz
        warp = _node(tree, "ShaderNodeTexWave", Scale=s * 40.0, Distortion=0.5)
        warp.bands_direction = "X"
        weft = _node(tree, "ShaderNodeTexWave", Scale=s * 40.0, Distortion=0.5)
        weft.bands_direction = "Y"
        check = _node(tree, "ShaderNodeTexChecker", Scale=s)
        check.inputs["Color1"].default_value = _rgba(a)
        check.inputs["Color2"].default_value = _rgba(b)
        for n in (warp, weft, check):
            tree.links.new(coord, n.inputs["Vector"])
        weave = tree.nodes.new("ShaderNodeMath")
        weave.operation = "MULTIPLY"
        tree.links.new(warp.outputs["Fac"], weave.inputs[0])
        tree.links.new(weft.outputs["Fac"], weave.inputs[1])
        colour = _mix(tree, weave.outputs[0], check.outputs["Color"], [c * 0.7 for c in a])
        height = weave.outputs[0]
        bsdf.inputs["Sheen Weight"].default_value = 0.6
    elif kind == "paper":  # near-white, faint fibres, ruled lines
        fibre = _node(tree, "ShaderNodeTexNoise", Scale=s * 30.0, Detail=8.0)
        tree.links.new(coord, fibre.inputs["Vector"])
        lines = _node(tree, "ShaderNodeTexWave", Scale=s, Distortion=0.0)
        lines.bands_direction = "Y"
        lines.wave_profile = "SAW"
        tree.links.new(coord, lines.inputs["Vector"])
        ramp = tree.nodes.new("ShaderNodeValToRGB")
        ramp.color_ramp.elements[0].position = 0.93
        ramp.color_ramp.elements[0].color = _rgba(a)
        ramp.color_ramp.elements[1].position = 0.96
        ramp.color_ramp.elements[1].color = _rgba(b)
        tree.links.new(lines.outputs["Fac"], ramp.inputs[0])
        colour = _mix(tree, fibre.outputs["Fac"], ramp.outputs[0], [c * 0.92 for c in a])
        height = fibre.outputs["Fac"]
    elif kind == "board":  # a printed board: a check of two colours with dark printed lines over it
        check = _node(tree, "ShaderNodeTexChecker", Scale=s)
        check.inputs["Color1"].default_value = _rgba(a)
        check.inputs["Color2"].default_value = _rgba(b)
        tree.links.new(coord, check.inputs["Vector"])
        grid = _node(tree, "ShaderNodeTexBrick", Scale=s * 0.5, **{"Mortar Size": 0.01})
        grid.offset = 0.0
        grid.inputs["Mortar"].default_value = (0.05, 0.05, 0.05, 1.0)
        tree.links.new(check.outputs["Color"], grid.inputs["Color1"])
        tree.links.new(check.outputs["Color"], grid.inputs["Color2"])
        tree.links.new(coord, grid.inputs["Vector"])
        colour = grid.outputs["Color"]
    elif kind == "tiles":  # tiles in mortar, each a little different
        brick = _node(tree, "ShaderNodeTexBrick", Scale=s, **{"Mortar Size": 0.015, "Bias": 0.0})
        brick.offset = float(spec.get("offset", 0.0))
        brick.inputs["Color1"].default_value = _rgba(a)
        brick.inputs["Color2"].default_value = _rgba([c * 0.85 for c in a])
        brick.inputs["Mortar"].default_value = _rgba(b)
        tree.links.new(coord, brick.inputs["Vector"])
        colour = brick.outputs["Color"]
        height = brick.outputs["Fac"]
    elif kind == "print":  # a printed object (a box's artwork, a book's cover): bricks of two colours, stripes
        brick = _node(tree, "ShaderNodeTexBrick", Scale=s, **{"Mortar Size": 0.03})
        brick.inputs["Color1"].default_value = _rgba(a)
        brick.inputs["Color2"].default_value = _rgba(b)
        brick.inputs["Mortar"].default_value = _rgba([1 - c for c in a])
        tree.links.new(coord, brick.inputs["Vector"])
        colour = brick.outputs["Color"]
    elif kind == "mottled":  # fruit, leaves, cardboard: two colours blended by low-frequency noise, with pores
        blotch = _node(tree, "ShaderNodeTexNoise", Scale=s, Detail=3.0)
        pores = _node(tree, "ShaderNodeTexVoronoi", Scale=s * 25.0)
        for n in (blotch, pores):
            tree.links.new(coord, n.inputs["Vector"])
        colour = _mix(tree, blotch.outputs["Fac"], a, b)
        height = pores.outputs["Distance"]
    else:  # plain plastic, ceramic or metal, with a faint blotch so that it is not a flat colour
        blotch = _node(tree, "ShaderNodeTexNoise", Scale=s, Detail=2.0)
        tree.links.new(coord, blotch.inputs["Vector"])
        colour = _mix(tree, blotch.outputs["Fac"], a, [c * 0.9 for c in a])
    tree.links.new(colour, bsdf.inputs["Base Color"])
    if height is not None and spec.get("bump", 0.0) > 0:
        bump = _node(tree, "ShaderNodeBump", Strength=float(spec["bump"]), Distance=0.002)
        tree.links.new(height, bump.inputs["Height"])
        tree.links.new(bump.outputs["Normal"], bsdf.inputs["Normal"])
    return mat


def _emission(name, rgb):
    mat = bpy.data.materials.new(name)
    tree = mat.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    em = _node(tree, "ShaderNodeEmission", Color=_rgba(rgb), Strength=1.0)
    tree.links.new(em.outputs[0], out.inputs["Surface"])
    return mat


def _mesh(name, item, collection):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(v) for v in item["vertices"]], [], [tuple(f) for f in item["faces"]])
    mesh.update()
    if item.get("smooth"):
        mesh.shade_smooth()
    obj = bpy.data.objects.new(name, mesh)
    collection.objects.link(obj)
    obj.data.materials.append(_material(name + "_mat", item["material"]))
    return obj


def _camera(scene, cam):
    r = cam["world_from_camera"]  # rows of a 3x3: columns are OpenCV x right, y down, z forward
    cols = [[r[i][j] for i in range(3)] for j in range(3)]
    x, y, z = cols[0], [-c for c in cols[1]], [-c for c in cols[2]]  # Blender's camera: x right, y up, looks -z
    data = bpy.data.cameras.new("camera")
    data.sensor_fit = "VERTICAL"
    data.sensor_height = 24.0
    data.lens = 12.0 / math.tan(math.radians(cam["fov_deg"]) / 2)
    data.clip_start = 0.005
    data.clip_end = 100.0
    obj = bpy.data.objects.new("camera", data)
    obj.matrix_world = Matrix([[x[0], y[0], z[0], cam["position"][0]], [x[1], y[1], z[1], cam["position"][1]],
                        [x[2], y[2], z[2], cam["position"][2]], [0, 0, 0, 1]])
    scene.collection.objects.link(obj)
    scene.camera = obj


def _lights(scene, light):
    world = bpy.data.worlds.new("world")
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = _rgba(light["sky"])
    bg.inputs["Strength"].default_value = float(light["sky_strength"])
    scene.world = world
    lamps = []
    sun = bpy.data.lights.new("sun", "SUN")
    sun.energy = float(light["sun_strength"])
    sun.color = light["sun_colour"]
    sun.angle = math.radians(light["sun_angle_deg"])  # the sun's disc: how soft the shadows are
    obj = bpy.data.objects.new("sun", sun)
    az, el = math.radians(light["sun_azimuth_deg"]), math.radians(light["sun_elevation_deg"])
    obj.rotation_euler = (math.pi / 2 - el, 0.0, az + math.pi / 2)
    scene.collection.objects.link(obj)
    lamps.append(obj)
    if light.get("area_power"):
        area = bpy.data.lights.new("area", "AREA")
        area.energy = float(light["area_power"])
        area.size = float(light["area_size_m"])
        area.color = light["area_colour"]
        obj = bpy.data.objects.new("area", area)
        obj.location = light["area_position"]
        d = [light["area_target"][i] - light["area_position"][i] for i in range(3)]
        obj.rotation_euler = (math.atan2(math.hypot(d[0], d[1]), -d[2]), 0.0, math.atan2(d[1], d[0]) + math.pi / 2)
        scene.collection.objects.link(obj)
        lamps.append(obj)
    return world, lamps


def main(path):
    spec = json.loads(open(path).read())
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    r = scene.render
    r.engine = "CYCLES"
    r.resolution_x, r.resolution_y, r.resolution_percentage = spec["width"], spec["height"], 100
    r.threads_mode = "FIXED"
    r.threads = int(spec.get("threads", 2))
    r.image_settings.file_format = "PNG"
    r.image_settings.color_mode = "RGB"
    c = scene.cycles
    c.device = "CPU"
    c.samples = int(spec["samples"])
    c.use_adaptive_sampling = True
    c.max_bounces = 4
    c.caustics_reflective = c.caustics_refractive = False
    c.sample_clamp_indirect = 5.0
    try:
        c.use_denoising = True
        c.denoiser = "OPENIMAGEDENOISE"
    except (AttributeError, TypeError):  # a build without the denoiser renders the noisy image
        c.use_denoising = False
    _camera(scene, spec["camera"])
    world, lamps = _lights(scene, spec["light"])
    surfaces = [_mesh(s["name"], s, scene.collection) for s in spec["surfaces"]]
    objects = [_mesh(o["name"], o, scene.collection) for o in spec["objects"]]
    seconds = {}
    t0 = time.perf_counter()
    r.filepath = spec["photo"]
    bpy.ops.render.render(write_still=True)
    seconds["photo"] = time.perf_counter() - t0

    # the object ids: flat emission, no light, one unfiltered sample per pixel, written as the numbers are
    t0 = time.perf_counter()
    for lamp in lamps:
        lamp.hide_render = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    for s in surfaces:
        s.data.materials[0] = _emission(s.name + "_id", (0.0, 0.0, 0.0))
    for k, o in enumerate(objects, start=1):
        o.data.materials[0] = _emission(o.name + "_id", (k * ID_STEP / 255.0, 0.0, 0.0))
    c.samples = 1
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.max_bounces = 0
    c.filter_width = 0.01
    scene.view_settings.view_transform = "Raw"
    scene.view_settings.look = "None"
    r.dither_intensity = 0.0
    r.filepath = spec["ids"]
    bpy.ops.render.render(write_still=True)
    seconds["ids"] = time.perf_counter() - t0
    print("RESULT " + json.dumps({"seconds": seconds, "blender": bpy.app.version_string}))


if __name__ == "__main__":
    main(sys.argv[1])
