# Runs inside Debian's Blender (`blender -b --factory-startup --python cycles_render.py -- ARGS`):
# renders a glTF scene with Cycles set up to compute what Tessera computes, and writes one
# linear EXR per sample count with the render's wall time beside it.
#
#   ARGS: SCENE.gltf OUT_DIR WIDTH HEIGHT MAX_DEPTH THREADS ROULETTE(on|off) SPP [SPP ...]
#
# One render per count: bench_cycles.sh repeats the whole script in its rounds.
#
# Two material models, by the environment variable CYCLES_MATERIALS:
# - `diffuse` (the default): the same integral as Tessera's on a Lambertian scene: every material
#   a Lambertian of its glTF base colour plus its emission (KHR_materials_emissive_strength
#   included);
# - `gltf`: the materials as Blender's glTF importer makes them (Principled BSDF, textures
#   included), with Cycles' own defaults for glossy and transmission bounces and caustics on: the
#   scene classes whose materials are not Lambertian (each renderer is then measured against its
#   own converged render, since the two material models differ slightly).
# CYCLES_ENVIRONMENT=FILE lights the scene with a lat-long map as Tessera's `-e` does (the same
# directions: the image's left edge is Tessera's u = 0); without it the world is black.
# Tessera's max_depth d is
# Cycles' max_bounces d - 1 (Tessera counts the camera ray's hit as depth 1); a box filter one
# pixel wide (Tessera's pixel samples are uniform over the pixel); no clamping, no denoising,
# no adaptive sampling, no filmic view transform. `ROULETTE off` sets min_light_bounces to the
# bounce count, which turns Cycles' Russian roulette off (Tessera's default has none).
import json
import math
import os
import sys
import time

import bpy
import numpy

# Blender 3.4's glTF importer still uses numpy.bool, which Debian 12's numpy (1.24) no longer
# has; the alias it meant is the builtin.
if not hasattr(numpy, "bool"):
    numpy.bool = bool

args = sys.argv[sys.argv.index("--") + 1:]
scene_path, out_dir = args[0], args[1]
width, height, max_depth, threads = int(args[2]), int(args[3]), int(args[4]), int(args[5])
roulette = args[6] == "on"
spps = [int(a) for a in args[7:]]

bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=scene_path)
scene = bpy.context.scene
cams = [o for o in scene.objects if o.type == "CAMERA"]
if not cams:
    sys.exit("cycles_render: the scene has no camera (bench_cycles.sh adds Tessera's default one)")
scene.camera = cams[0]
# glTF's yfov is vertical: fit the sensor to the height, as Tessera does.
cams[0].data.sensor_fit = "VERTICAL"

materials = os.environ.get("CYCLES_MATERIALS", "diffuse")
environment = os.environ.get("CYCLES_ENVIRONMENT", "")
if materials not in ("diffuse", "gltf"):
    sys.exit("cycles_render: CYCLES_MATERIALS is diffuse or gltf")

# Diffuse materials: base colour and emission read from the importer's Principled BSDF.
for mat in (bpy.data.materials if materials == "diffuse" else []):
    if not mat.use_nodes:
        continue
    nodes = mat.node_tree.nodes
    bsdf = next((n for n in nodes if n.type == "BSDF_PRINCIPLED"), None)
    if bsdf is None:
        continue
    base = list(bsdf.inputs["Base Color"].default_value)
    emission = list(bsdf.inputs["Emission"].default_value)
    strength = bsdf.inputs["Emission Strength"].default_value if "Emission Strength" in bsdf.inputs else 1.0
    links = mat.node_tree.links
    for n in list(nodes):
        nodes.remove(n)
    out = nodes.new("ShaderNodeOutputMaterial")
    diffuse = nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = base
    diffuse.inputs["Roughness"].default_value = 0.0  # Lambert, not Oren-Nayar
    emit = nodes.new("ShaderNodeEmission")
    emit.inputs["Color"].default_value = emission
    emit.inputs["Strength"].default_value = strength
    if mat.use_backface_culling:
        # A glTF material that is not doubleSided emits from its front only, as in Tessera;
        # Cycles' emission is two-sided, so the back's is multiplied by zero.
        geometry = nodes.new("ShaderNodeNewGeometry")
        front = nodes.new("ShaderNodeMath")
        front.operation = "SUBTRACT"
        front.inputs[0].default_value = 1.0
        links.new(geometry.outputs["Backfacing"], front.inputs[1])
        scaled = nodes.new("ShaderNodeMath")
        scaled.operation = "MULTIPLY"
        scaled.inputs[1].default_value = strength
        links.new(front.outputs["Value"], scaled.inputs[0])
        links.new(scaled.outputs["Value"], emit.inputs["Strength"])
    add = nodes.new("ShaderNodeAddShader")
    links.new(diffuse.outputs["BSDF"], add.inputs[0])
    links.new(emit.outputs["Emission"], add.inputs[1])
    links.new(add.outputs["Shader"], out.inputs["Surface"])

world = bpy.data.worlds.new("world")
world.use_nodes = True
background = world.node_tree.nodes["Background"]
if environment:
    # Tessera's lat-long map (engine/scene/environment.h, glTF's +y up) seen in Blender's +z-up
    # world (the importer turns glTF's -z into +y): the two equirectangular conventions are a
    # quarter turn apart about the vertical, which turning the lookup by -90° about z undoes.
    # Checked on CesiumMilkTruck under scenes/sky.exr: mean absolute difference to Tessera's
    # image 0.046 at -90°, 0.20 to 0.87 at the other quarter turns.
    wn, wl = world.node_tree.nodes, world.node_tree.links
    tex = wn.new("ShaderNodeTexEnvironment")
    tex.image = bpy.data.images.load(environment)
    tex.interpolation = "Closest"  # Tessera's radiance is constant over a texel
    coord = wn.new("ShaderNodeTexCoord")
    mapping = wn.new("ShaderNodeMapping")
    mapping.inputs["Rotation"].default_value[2] = -math.pi / 2
    wl.new(coord.outputs["Generated"], mapping.inputs["Vector"])
    wl.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    wl.new(tex.outputs["Color"], background.inputs["Color"])
    background.inputs["Strength"].default_value = 1.0
else:
    background.inputs["Strength"].default_value = 0.0
scene.world = world

scene.render.engine = "CYCLES"
c = scene.cycles
c.device = "CPU"
c.use_adaptive_sampling = False
c.use_denoising = False
c.sample_clamp_direct = 0.0
c.sample_clamp_indirect = 0.0
c.max_bounces = max(0, max_depth - 1)
c.diffuse_bounces = max(0, max_depth - 1)
if materials == "diffuse":
    c.glossy_bounces = c.transmission_bounces = c.volume_bounces = c.transparent_max_bounces = 0
    c.caustics_reflective = c.caustics_refractive = False
else:
    c.glossy_bounces = c.transmission_bounces = max(0, max_depth - 1)
    c.caustics_reflective = c.caustics_refractive = True
c.min_light_bounces = c.max_bounces if not roulette else 0
c.pixel_filter_type = "BOX"
c.filter_width = 1.0
c.seed = 0
c.use_animated_seed = False
scene.render.threads_mode = "FIXED"
scene.render.threads = threads
scene.render.resolution_x = width
scene.render.resolution_y = height
scene.render.resolution_percentage = 100
scene.render.film_transparent = False
scene.view_settings.view_transform = "Standard"
scene.view_settings.look = "None"
scene.view_settings.exposure = 0.0
scene.view_settings.gamma = 1.0
scene.render.image_settings.file_format = "OPEN_EXR"
scene.render.image_settings.color_depth = "32"
scene.render.image_settings.exr_codec = "ZIP"
scene.render.use_persistent_data = True  # the scene is synced and its BVH built once

os.makedirs(out_dir, exist_ok=True)
# A render is timed from Blender's render_pre handler to its render_post: the sampling, not the
# image's writing that follows (a render must write its image: without write_still, Blender 3.4
# renders again with the sample count of the render before).
marks = {}
bpy.app.handlers.render_pre.append(lambda *_: marks.__setitem__("pre", time.perf_counter()))
bpy.app.handlers.render_post.append(lambda *_: marks.__setitem__("post", time.perf_counter()))
times = {}
# A first render of one sample: synchronisation and the BVH, so that the timed renders below
# measure sampling (Tessera's render_seconds likewise leaves out loading, building and writing).
c.samples = 1
scene.render.filepath = os.path.join(out_dir, "warmup.exr")
bpy.ops.render.render(write_still=True)
for spp in spps:
    c.samples = spp
    scene.render.filepath = os.path.join(out_dir, f"cycles_{spp}.exr")
    bpy.ops.render.render(write_still=True)
    times[spp] = marks["post"] - marks["pre"]
    print(f"cycles_render: {spp} spp in {times[spp]:.3f} s", flush=True)
with open(os.path.join(out_dir, "cycles_times.json"), "w") as f:
    json.dump({"version": bpy.app.version_string, "roulette": roulette, "seconds": times}, f)
