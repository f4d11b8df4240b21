"""Blender Cycles as an independent reference for `lightskin bench` (issue 8). Not run in CI.

Run through scripts/blender_reference.sh, or by hand:
    lightskin bench --export-blender DIR [--default-width 320 --default-height 240 --default-stride 4 ...]
    blender -b -noaudio --factory-startup -P scripts/blender_reference.py -- DIR [SAMPLES]

It rebuilds the exported scene (DIR/scene.json, world metres, Z up) in Cycles:
  * every VAL as a one-sided-facing disc (16-gon of the VAL's area) with an Emission shader of the VAL's
    radiance L = flux / (pi area); the emitter mesh is invisible to camera rays;
  * the two virtual meshes (world-space vertices, smooth-shaded, with lightskin's vertex normals as
    custom split normals) with a Diffuse BSDF of their albedo (the export drops the glossy lobe:
    Cycles has no Phong lobe);
  * the camera with the same vertical field of view and aspect; a black world.
Light paths: camera -> virtual surface -> VAL emitter, the single bounce that the LightSkin indirect
light is (the VALs are the real scene's first bounce, the virtual surface reflects it once). Cycles
settings for that: max/diffuse bounces 1, virtual meshes invisible to diffuse/glossy rays (no
inter-reflection between virtual objects, as in LightSkin; they still cast shadows), VAL emitters
invisible to camera and shadow rays (the discs stand for a continuous surface). Unbiased settings: no
denoising (Debian's build lacks OpenImageDenoise), sample_clamp_direct = sample_clamp_indirect = 0,
blur_glossy = 0, view transform Standard, look None, exposure 0, gamma 1, OPEN_EXR float output
(linear). With an Emission strength of 1 a pixel value is radiance in the VALs' units, the same as
lightskin's output.

Then it compares the Cycles image with lightskin's exported images (raw float32 RGB, top-down rows):
lightskin.f32 (LightSkin, diffuse + occlusion), brute.f32 (brute force, no visibility), truth.f32
(Embree ground truth with disc-centre visibility) over the pixels both cover (lightskin's mask and
Cycles' alpha = 1), and writes DIR/blender_comparison.json and prints a table.
"""
import json
import math
import os
import sys

from array import array

import bpy
from mathutils import Matrix, Vector


def args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if not argv:
        raise SystemExit("usage: blender -b -noaudio --factory-startup -P blender_reference.py -- DIR [SAMPLES]")
    return argv[0], int(argv[1]) if len(argv) > 1 else 256


def clear_scene():
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj, do_unlink=True)


def emitter_object(vals, segments=16):
    positions, faces, colours = [], [], []
    for v in vals:
        centre, normal, area, radiance = Vector(v[0:3]), Vector(v[3:6]).normalized(), v[6], v[7:10]
        # radius of the disc polygon with the VAL's area: area = n/2 r^2 sin(2 pi / n)
        radius = math.sqrt(2.0 * area / (segments * math.sin(2.0 * math.pi / segments)))
        helper = Vector((1, 0, 0)) if abs(normal.x) < 0.9 else Vector((0, 1, 0))
        t = normal.cross(helper).normalized()
        b = normal.cross(t)
        base = len(positions)
        for k in range(segments):
            a = 2.0 * math.pi * k / segments
            positions.append(centre + radius * (math.cos(a) * t + math.sin(a) * b))
        faces.append(list(range(base, base + segments)))  # counter-clockwise about the normal
        colours.append(radiance)
    mesh = bpy.data.meshes.new("vals")
    mesh.from_pydata([tuple(p) for p in positions], [], faces)
    attribute = mesh.attributes.new("radiance", "FLOAT_COLOR", "FACE")
    flat = []
    for c in colours:
        flat.extend((c[0], c[1], c[2], 1.0))
    attribute.data.foreach_set("color", flat)
    obj = bpy.data.objects.new("vals", mesh)
    bpy.context.collection.objects.link(obj)
    material = bpy.data.materials.new("val_emission")
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    emission = nodes.new("ShaderNodeEmission")
    attr = nodes.new("ShaderNodeAttribute")
    attr.attribute_name = "radiance"
    emission.inputs["Strength"].default_value = 1.0
    links.new(attr.outputs["Color"], emission.inputs["Color"])
    links.new(emission.outputs["Emission"], out.inputs["Surface"])
    mesh.materials.append(material)
    # Emitters are invisible to camera and shadow rays: the VAL discs stand for a continuous real
    # surface and do not shadow one another (tilted neighbouring discs would otherwise hide ~11 % of
    # the light in this scene); diffuse rays still hit them (MIS).
    obj.visible_camera = False
    obj.visible_shadow = False
    return obj


def mesh_object(name, data):
    mesh = bpy.data.meshes.new(name)
    idx = data["indices"]
    faces = [idx[i:i + 3] for i in range(0, len(idx), 3)]
    mesh.from_pydata([tuple(p) for p in data["positions"]], [], faces)
    mesh.shade_smooth() if hasattr(mesh, "shade_smooth") else None
    for polygon in mesh.polygons:
        polygon.use_smooth = True
    mesh.use_auto_smooth = True
    mesh.normals_split_custom_set_from_vertices([tuple(n) for n in data["normals"]])
    obj = bpy.data.objects.new(name, mesh)
    # No inter-reflection between virtual surfaces (LightSkin has none); they still cast shadows
    # (shadow rays). A BSDF-sampled ray passes through them to an emitter behind: a small leak in
    # the MIS half of the estimate.
    obj.visible_diffuse = False
    obj.visible_glossy = False
    bpy.context.collection.objects.link(obj)
    material = bpy.data.materials.new(name + "_diffuse")
    material.use_nodes = True
    bsdf = material.node_tree.nodes["Principled BSDF"]
    material.node_tree.nodes.remove(bsdf)
    diffuse = material.node_tree.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (*data["albedo"], 1.0)
    diffuse.inputs["Roughness"].default_value = 0.0  # Lambert
    material.node_tree.links.new(diffuse.outputs["BSDF"], material.node_tree.nodes["Material Output"].inputs["Surface"])
    mesh.materials.append(material)
    return obj


def camera_object(scene_data):
    eye, target = Vector(scene_data["eye"]), Vector(scene_data["target"])
    f = (target - eye).normalized()
    r = f.cross(Vector((0, 0, 1))).normalized()
    u = r.cross(f)
    m = Matrix(((r.x, u.x, -f.x, eye.x), (r.y, u.y, -f.y, eye.y), (r.z, u.z, -f.z, eye.z), (0, 0, 0, 1)))
    cam = bpy.data.cameras.new("camera")
    cam.sensor_fit = "VERTICAL"
    cam.sensor_height = 24.0
    cam.lens = 12.0 / math.tan(0.5 * scene_data["fovy_radians"])
    cam.clip_start = 0.05
    obj = bpy.data.objects.new("camera", cam)
    obj.matrix_world = m
    bpy.context.collection.objects.link(obj)
    return obj


def setup_render(scene, width, height, samples, path):
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.use_denoising = False
    # One diffuse bounce: the camera ray's surface (the virtual mesh) is shaded by light sampling
    # and a BSDF ray that may hit an emitter (MIS). With max_bounces 0 Cycles drops the BSDF half
    # and the image is ~3.5 % darker here.
    scene.cycles.max_bounces = 1
    scene.cycles.diffuse_bounces = 1
    scene.cycles.glossy_bounces = 0
    scene.cycles.transmission_bounces = 0
    scene.cycles.volume_bounces = 0
    scene.cycles.transparent_max_bounces = 0
    scene.cycles.sample_clamp_direct = 0.0
    scene.cycles.sample_clamp_indirect = 0.0
    scene.cycles.blur_glossy = 0.0
    scene.cycles.caustics_reflective = True
    scene.cycles.caustics_refractive = True
    scene.cycles.pixel_filter_type = "BOX"
    scene.cycles.filter_width = 1.0
    scene.render.film_transparent = True
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    scene.render.image_settings.color_mode = "RGBA"
    scene.render.filepath = path
    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
    scene.world = world


def metrics(x, r, mask):
    """x, r: flat RGB float lists (top-down rows); mask: per pixel bool."""
    n, rel, mae, mx, sx, sr = 0, 0.0, 0.0, 0.0, 0.0, 0.0
    for p, use in enumerate(mask):
        if not use:
            continue
        for c in range(3):
            a, b = x[3 * p + c], r[3 * p + c]
            d = a - b
            rel += d * d / (b * b + 0.01)
            mae += abs(d)
            mx = max(mx, abs(d))
            sx += a
            sr += b
            n += 1
    n = max(n, 1)
    return {"relative_mse": rel / n, "mae": mae / n, "max": mx, "mean_ratio": sx / max(sr, 1e-30)}


def main():
    folder, samples = args()
    with open(os.path.join(folder, "scene.json")) as f:
        scene_data = json.load(f)
    width, height = scene_data["width"], scene_data["height"]
    clear_scene()
    emitter_object(scene_data["vals"])
    for i, m in enumerate(scene_data["meshes"]):
        mesh_object("mesh%d" % i, m)
    scene = bpy.context.scene
    scene.camera = camera_object(scene_data)
    exr = os.path.join(folder, "cycles.exr")
    setup_render(scene, width, height, samples, exr)
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(exr)
    pixels = list(image.pixels[:])  # RGBA, bottom-up rows
    cycles, alpha = [0.0] * (3 * width * height), [0.0] * (width * height)
    for y in range(height):
        src = (height - 1 - y) * width
        for x in range(width):
            q = 4 * (src + x)
            p = y * width + x
            cycles[3 * p:3 * p + 3] = pixels[q:q + 3]
            alpha[p] = pixels[q + 3]

    def load(name):
        values = array("f")
        with open(os.path.join(folder, name), "rb") as f:
            values.fromfile(f, 3 * width * height)
        return values

    ours_mask = load("mask.f32")
    mask = [ours_mask[3 * p] > 0.5 and alpha[p] > 0.999 for p in range(width * height)]
    result = {"samples": samples, "pixels": sum(mask), "vals": len(scene_data["vals"])}
    for name in ("lightskin", "brute", "truth"):
        result[name + "_vs_cycles"] = metrics(load(name + ".f32"), cycles, mask)
    with open(os.path.join(folder, "blender_comparison.json"), "w") as f:
        json.dump(result, f, indent=2)
    print("Cycles reference: %d samples, %d pixels compared, %d VALs" % (samples, result["pixels"], result["vals"]))
    print("| image | rel. MSE vs Cycles | MAE | max | mean / Cycles mean |")
    for name in ("lightskin", "brute", "truth"):
        m = result[name + "_vs_cycles"]
        print("| %s | %.3e | %.3e | %.3e | %.4f |" % (name, m["relative_mse"], m["mae"], m["max"], m["mean_ratio"]))


main()
