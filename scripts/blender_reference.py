"""Blender Cycles as an independent reference for `lightskin bench`. Not run in CI.

Run through scripts/blender_reference.sh, or by hand:
    lightskin bench --export-blender DIR [--default-width 320 --default-height 240 --default-stride 4 ...]
    blender -b -noaudio --factory-startup -P scripts/blender_reference.py -- DIR [SAMPLES per seed]

It rebuilds the exported scene (DIR/scene.json, world metres, Z up) in Cycles:
  * every VAL as a disc (16-gon) with an Emission shader of the VAL's radiance L = flux / (pi area),
    shrunk to 1/4 of its radius at 16 L (same flux; see EMITTER_SHRINK for why and what it changes);
    the emitter mesh is invisible to camera and shadow rays;
  * the two virtual meshes (world-space vertices, smooth-shaded, with lightskin's vertex normals as
    custom split normals) with a Lambert Diffuse BSDF of their albedo plus, where f_s > 0, the core's
    glossy term (eq. 5) built from Toon Glossy closures (see below);
  * the camera with the same vertical field of view and aspect; a black world.

The glossy term. Eq. 5 reflects L_o = f_s c (k + 1) cos^k(gamma) L_i per unit solid angle, with no
cos(theta_i) factor (gamma: mirror direction to view, light below the horizon adds nothing). This
Blender has no OSL (build_options.cycles_osl = False), so no custom or `phong` closure; its Glossy
BSDFs are microfacet lobes, and phong_ramp (OSL only) would carry cos(theta_i) anyway. Cycles' Toon
Glossy closure with smooth = 0 is exact for a different shape: its eval is (kernel/closure/
bsdf_toon.h, Cycles 3.4) weight / (2 pi (1 - cos a)) for gamma < a (a = size pi/2), 0 beyond, with no
cos(theta_i) factor either, and it samples that cone uniformly (eval / pdf = 1, so both MIS
strategies are exact; with smooth > 0 its sampler evaluates the ramp at the wrong angle, so smooth
stays 0). A sum of nested cones a_1 < ... < a_n is a staircase in gamma: the script takes n = 62
annuli uniform in gamma on [0, g_max] (cos^(k+1)(g_max) = 1e-6: the lobe energy dropped beyond is
1e-6) and sets each step to eq. 5's mean over its annulus (solid-angle weighted, closed form), so the
staircase reflects exactly eq. 5's energy from every annulus. The shader picks one closure (the
diffuse or one cone) per shading point at random and divides by its probability (see mesh_object:
Toon Glossy reports its pdf outside its cone, which biases several closures at once). What differs
from eq. 5: within an annulus the lobe is flat, not cos^k. Bounds, both printed and written to the
JSON: (a) the worst case over all incident radiance <= L_max, the L1 distance of the two lobes
relative to eq. 5's integral (k = 20: 2.3 %); (b) this scene's actual effect, eq. 5 against the
staircase summed over all VALs (disc centre, no visibility) at the glossy mesh's vertices that face
the camera (needs python3-numpy).

Light paths: camera -> virtual surface -> VAL emitter, the single bounce that the LightSkin indirect
light is (the VALs are the real scene's first bounce, the virtual surface reflects it once). Cycles
settings for that: max/diffuse/glossy bounces 1, virtual meshes invisible to diffuse/glossy rays (no
inter-reflection between virtual objects, as in LightSkin; they still cast shadows), VAL emitters
invisible to camera and shadow rays (the discs stand for a continuous surface). Unbiased settings: no
denoising (Debian's build lacks OpenImageDenoise), sample_clamp_direct = sample_clamp_indirect = 0,
blur_glossy = 0, reflective caustics on, view transform Standard, exposure 0, gamma 1, 32-bit
OPEN_EXR (linear) through the compositor with the Combined, DiffDir/DiffCol and GlossDir/GlossCol
passes. With an Emission strength of 1 a pixel value is radiance in the VALs' units, the same as
lightskin's output. Cycles renders twice with seeds 0 and 1 (SAMPLES each): the reference is their
mean, and seed 0 against seed 1 states Cycles' own noise.

Then it compares Cycles with lightskin's exported images (raw float32 RGB, top-down rows):
lightskin.f32 (LightSkin, diffuse + glossy + occlusion), brute.f32 (brute force, diffuse + glossy, no
visibility), truth.f32 (Embree ground truth, diffuse + glossy, disc-centre visibility) over the pixels
both cover (lightskin's mask and Cycles' alpha = 1), and the truth's diffuse and glossy terms
(truth_diffuse.f32) against Cycles' DiffDir * DiffCol and GlossDir * GlossCol; writes
DIR/blender_comparison.json and prints a table.
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


# Each VAL's polygon has EMITTER_SHRINK times its radius and 1 / EMITTER_SHRINK^2 its radiance (same
# flux). At full size, tilted neighbouring discs hide one another from BSDF-sampled rays (emitters
# are invisible to shadow rays only, so light sampling counts them all): measured on the sphere,
# Cycles 10.8 % (diffuse) and 15 % (glossy, mostly BSDF-sampled) darker than the truth, 17 % with
# BSDF sampling alone; at 1/4 the radius 1.2 % and -1.2 %. The overlap scales with the area (1/16).
# What this changes against a disc of full size: the disc form factor pi r^2 cos / (r^2 + d^2)
# becomes pi r^2 cos / (r^2 / 16 + d^2); the script computes that effect on this scene (unoccluded,
# disc centres, at the camera-facing vertices) and writes it to the JSON.
EMITTER_SHRINK = 0.25


def emitter_object(vals, segments=16):
    positions, faces, colours = [], [], []
    for v in vals:
        centre, normal, area, radiance = Vector(v[0:3]), Vector(v[3:6]).normalized(), v[6], v[7:10]
        # radius of the disc polygon with the VAL's area: area = n/2 r^2 sin(2 pi / n)
        radius = math.sqrt(2.0 * area / (segments * math.sin(2.0 * math.pi / segments)))
        radius *= EMITTER_SHRINK
        helper = Vector((1, 0, 0)) if abs(normal.x) < 0.9 else Vector((0, 1, 0))
        t = normal.cross(helper).normalized()
        b = normal.cross(t)
        base = len(positions)
        for k in range(segments):
            a = 2.0 * math.pi * k / segments
            positions.append(centre + radius * (math.cos(a) * t + math.sin(a) * b))
        faces.append(list(range(base, base + segments)))  # counter-clockwise about the normal
        colours.append([x / EMITTER_SHRINK ** 2 for x in radiance])  # same flux
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


GLOSSY_STEPS = 62
GLOSSY_TAIL = 1e-6  # lobe energy beyond the last cone (cos^(k+1) of its angle)


def glossy_staircase(k, c):
    """Eq. 5's lobe c (k + 1) cos^k(gamma) as nested uniform cones: returns (knots, steps, weights),
    knots gamma_0 = 0 < ... < gamma_n, steps[i] the lobe's solid-angle mean over [gamma_i,
    gamma_i+1] (closed form: c (cos^(k+1) g_i - cos^(k+1) g_i+1) / (cos g_i - cos g_i+1)), and
    weights[i] the Toon Glossy weight (per unit f_s) of the cone of angle gamma_i+1, whose eval is
    weight / (2 pi (1 - cos gamma_i+1)) inside: the cones' sum is the staircase."""
    gmax = math.acos(GLOSSY_TAIL ** (1.0 / (k + 1.0)))
    knots = [gmax * i / GLOSSY_STEPS for i in range(GLOSSY_STEPS + 1)]
    cs = [math.cos(g) for g in knots]
    steps = [c * (cs[i] ** (k + 1) - cs[i + 1] ** (k + 1)) / (cs[i] - cs[i + 1]) for i in range(GLOSSY_STEPS)]
    weights = []
    for i in range(GLOSSY_STEPS):
        below = steps[i + 1] if i + 1 < GLOSSY_STEPS else 0.0
        weights.append((steps[i] - below) * 2.0 * math.pi * (1.0 - cs[i + 1]))
    return knots, steps, weights


def check_staircase(k, c, knots, steps, weights):
    """The Toon cones must add up to the staircase (evals as in bsdf_toon.h with smooth = 0), and the
    staircase must carry eq. 5's energy c (k + 1) 2 pi / (k + 1) = 2 pi c up to the dropped tail."""
    for i in range(len(steps)):
        gamma = 0.5 * (knots[i] + knots[i + 1])
        cones = sum(w / (2.0 * math.pi * (1.0 - math.cos(knots[j + 1])))
                    for j, w in enumerate(weights) if gamma < knots[j + 1])
        if abs(cones - steps[i]) > 1e-9 * steps[0]:
            raise SystemExit("glossy staircase: cones give %g at gamma %g, step %g" % (cones, gamma, steps[i]))
    if abs(sum(weights) - 2.0 * math.pi * c * (1.0 - GLOSSY_TAIL)) > 1e-9:
        raise SystemExit("glossy staircase: energy %g, eq. 5 has %g" % (sum(weights), 2.0 * math.pi * c))


def staircase_l1(k, c, knots, steps, m=100000):
    """Worst-case bound (a): integral of |staircase - eq. 5| over the hemisphere around the mirror
    direction, divided by eq. 5's integral (midpoint rule in gamma, m cells)."""
    total = error = 0.0
    j = 0
    for i in range(m):
        g = (i + 0.5) / m * 0.5 * math.pi
        while j < len(steps) and g >= knots[j + 1]:
            j += 1
        p = steps[j] if j < len(steps) else 0.0
        f = c * (k + 1) * math.cos(g) ** k
        dw = 2.0 * math.pi * math.sin(g) * 0.5 * math.pi / m
        total += f * dw
        error += abs(p - f) * dw
    return error / total


def glossy_scene_effect(scene_data, mesh, eye, knots, steps, k, c):
    """Bound (b): eq. 5 against the staircase, summed over every VAL (disc-centre form factor as in
    the truth, no visibility), at the mesh's vertices facing the camera; returns the relative
    difference of the summed glossy radiance and the largest per-vertex relative difference (over
    vertices carrying >= 1 % of the mean glossy radiance), or None without numpy."""
    try:
        import numpy as np
    except ImportError:
        return None
    vals = np.array(scene_data["vals"], dtype=np.float64)
    centre, nl, area, radiance = vals[:, 0:3], vals[:, 3:6], vals[:, 6], vals[:, 7:10].mean(axis=1)
    nl /= np.linalg.norm(nl, axis=1)[:, None]
    pos = np.array(mesh["positions"], dtype=np.float64)
    nor = np.array(mesh["normals"], dtype=np.float64)
    nor /= np.linalg.norm(nor, axis=1)[:, None]
    view = np.array(eye)[None, :] - pos
    view /= np.linalg.norm(view, axis=1)[:, None]
    facing = np.einsum("ij,ij->i", view, nor) > 0.05
    pos, nor, view = pos[facing], nor[facing], view[facing]
    knots_np, steps_np = np.array(knots), np.array(steps)
    exact, stair = np.zeros(len(pos)), np.zeros(len(pos))
    for start in range(0, len(pos), 64):
        x, n, v = pos[start:start + 64, None, :], nor[start:start + 64, None, :], view[start:start + 64, None, :]
        d = centre[None, :, :] - x
        d2 = np.einsum("ijk,ijk->ij", d, d)
        w = d / np.sqrt(d2)[:, :, None]
        cos_i = np.einsum("ijk,ijk->ij", w, n)
        cos_j = -np.einsum("ijk,jk->ij", w, nl)
        ok = (cos_i > 0) & (cos_j > 0)
        r2 = area / math.pi
        incident = np.where(ok, radiance[None, :] * math.pi * r2[None, :] * cos_j / (r2[None, :] + d2), 0.0)
        mirror = 2.0 * cos_i[:, :, None] * n - w
        cos_g = np.clip(np.einsum("ijk,ijk->ij", mirror, v), 0.0, 1.0)
        exact[start:start + 64] = (incident * c * (k + 1) * cos_g ** k).sum(axis=1)
        idx = np.searchsorted(knots_np, np.arccos(cos_g), side="right") - 1
        inside = idx < len(steps_np)
        stair[start:start + 64] = (incident * np.where(inside, steps_np[np.minimum(idx, len(steps_np) - 1)], 0.0)).sum(axis=1)
    keep = exact > 0.01 * exact.mean()
    return {"vertices": int(len(pos)), "relative_sum": float((stair.sum() - exact.sum()) / exact.sum()),
            "max_relative_vertex": float(np.max(np.abs(stair[keep] - exact[keep]) / exact[keep]))}


def shrink_effect(scene_data, mesh, eye):
    """Relative change of the unoccluded disc-centre irradiance, summed over the mesh's camera-facing
    vertices, when every VAL disc has EMITTER_SHRINK times its radius at the same flux; and the
    largest per-vertex change. None without numpy."""
    try:
        import numpy as np
    except ImportError:
        return None
    vals = np.array(scene_data["vals"], dtype=np.float64)
    centre, nl, area, radiance = vals[:, 0:3], vals[:, 3:6], vals[:, 6], vals[:, 7:10].mean(axis=1)
    nl /= np.linalg.norm(nl, axis=1)[:, None]
    pos = np.array(mesh["positions"], dtype=np.float64)
    nor = np.array(mesh["normals"], dtype=np.float64)
    nor /= np.linalg.norm(nor, axis=1)[:, None]
    view = np.array(eye)[None, :] - pos
    facing = np.einsum("ij,ij->i", view, nor) > 0.0
    pos, nor = pos[facing], nor[facing]
    r2 = area / math.pi
    full, small = np.zeros(len(pos)), np.zeros(len(pos))
    for start in range(0, len(pos), 64):
        x, n = pos[start:start + 64, None, :], nor[start:start + 64, None, :]
        d = centre[None, :, :] - x
        d2 = np.einsum("ijk,ijk->ij", d, d)
        w = d / np.sqrt(d2)[:, :, None]
        cos_i = np.einsum("ijk,ijk->ij", w, n)
        cos_j = -np.einsum("ijk,jk->ij", w, nl)
        g = np.where((cos_i > 0) & (cos_j > 0), radiance[None, :] * math.pi * r2[None, :] * cos_i * cos_j, 0.0)
        full[start:start + 64] = (g / (r2[None, :] + d2)).sum(axis=1)
        small[start:start + 64] = (g / (EMITTER_SHRINK ** 2 * r2[None, :] + d2)).sum(axis=1)
    keep = full > 0.01 * full.mean()
    return {"vertices": int(len(pos)), "relative_sum": float((small.sum() - full.sum()) / full.sum()),
            "max_relative_vertex": float(np.max(np.abs(small[keep] - full[keep]) / full[keep]))}


def mesh_object(name, data, glossy_c):
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
    material = bpy.data.materials.new(name + "_material")
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.remove(nodes["Principled BSDF"])
    diffuse = nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (*data["albedo"], 1.0)
    diffuse.inputs["Roughness"].default_value = 0.0  # Lambert
    shader = diffuse.outputs["BSDF"]
    fs = data.get("specular_albedo", [0.0, 0.0, 0.0])
    if max(fs) > 0.0:
        # One closure per shading point, picked at random with probability q_i proportional to its
        # mean weight and weighted 1 / q_i: the expectation is the sum of all the closures. Several
        # closures at once would be biased: Toon Glossy's eval returns its cone's pdf also outside
        # the cone (where its eval is 0), and Cycles sums every closure's pdf for MIS and for the
        # BSDF-sampled weight (measured: the sphere 3-7x too dark with 8-62 cones and the diffuse
        # closure together). The random number is White Noise of the hit position: it hashes the
        # float bits, and the position jitters inside the pixel with every sample.
        k = float(data["specular_exponent"])
        knots, steps, weights = glossy_staircase(k, glossy_c)
        check_staircase(k, glossy_c, knots, steps, weights)
        rho, spec = sum(data["albedo"]) / 3.0, sum(fs) / 3.0
        closures = [(diffuse, rho, data["albedo"])]
        for i, w in enumerate(weights):
            toon = nodes.new("ShaderNodeBsdfToon")
            toon.component = "GLOSSY"
            toon.inputs["Size"].default_value = knots[i + 1] / (0.5 * math.pi)
            toon.inputs["Smooth"].default_value = 0.0  # see the header: the sampler is exact only at 0
            closures.append((toon, spec * w, [f * w for f in fs]))
        total = sum(m for _, m, _ in closures)
        geometry = nodes.new("ShaderNodeNewGeometry")
        noise = nodes.new("ShaderNodeTexWhiteNoise")
        noise.noise_dimensions = "3D"
        links.new(geometry.outputs["Position"], noise.inputs["Vector"])
        u = noise.outputs["Value"]
        cumulative = 0.0
        shader = None
        selectors = []
        for node, mean_weight, colour in closures:
            q = mean_weight / total
            node.inputs["Color"].default_value = (*[c / q for c in colour], 1.0)
            cumulative += q
            selectors.append((node.outputs["BSDF"], cumulative))
        # Nested Mix Shaders from the last closure outwards: closure i if u < Q_i (and not before).
        shader = selectors[-1][0]
        for output, bound in reversed(selectors[:-1]):
            less = nodes.new("ShaderNodeMath")
            less.operation = "LESS_THAN"
            links.new(u, less.inputs[0])
            less.inputs[1].default_value = bound
            mix = nodes.new("ShaderNodeMixShader")
            links.new(less.outputs["Value"], mix.inputs["Fac"])
            links.new(shader, mix.inputs[1])
            links.new(output, mix.inputs[2])
            shader = mix.outputs["Shader"]
    links.new(shader, nodes["Material Output"].inputs["Surface"])
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


PASSES = ("Image", "DiffDir", "DiffCol", "GlossDir", "GlossCol")


def setup_render(scene, width, height, samples, path):
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.use_denoising = False
    # One bounce: the camera ray's surface (the virtual mesh) is shaded by light sampling and a
    # BSDF ray (diffuse or glossy) that may hit an emitter (MIS). With max_bounces 0 Cycles drops
    # the BSDF half and the image is ~3.5 % darker here.
    scene.cycles.max_bounces = 1
    scene.cycles.diffuse_bounces = 1
    scene.cycles.glossy_bounces = 1
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
    layer = scene.view_layers[0]
    layer.use_pass_diffuse_direct = layer.use_pass_diffuse_color = True
    layer.use_pass_glossy_direct = layer.use_pass_glossy_color = True
    # Passes reach files through the compositor: one float EXR per pass in `path`.
    scene.use_nodes = True
    scene.render.use_compositing = True
    tree = scene.node_tree
    tree.nodes.clear()
    layers = tree.nodes.new("CompositorNodeRLayers")
    output = tree.nodes.new("CompositorNodeOutputFile")
    output.base_path = path
    output.format.file_format = "OPEN_EXR"
    output.format.color_depth = "32"
    output.format.color_mode = "RGBA"
    output.file_slots.clear()
    for socket in PASSES:
        output.file_slots.new(socket + "_")
        tree.links.new(layers.outputs[socket], output.inputs[-1])
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


def read_exr(path, width, height):
    """RGBA float EXR -> (RGB list, alpha list), top-down rows."""
    image = bpy.data.images.load(path, check_existing=False)
    pixels = list(image.pixels[:])  # RGBA, bottom-up rows
    bpy.data.images.remove(image)
    rgb, alpha = [0.0] * (3 * width * height), [0.0] * (width * height)
    for y in range(height):
        src = (height - 1 - y) * width
        for x in range(width):
            q = 4 * (src + x)
            p = y * width + x
            rgb[3 * p:3 * p + 3] = pixels[q:q + 3]
            alpha[p] = pixels[q + 3]
    return rgb, alpha


def render_seed(scene, folder, seed, width, height):
    out = os.path.join(folder, "cycles_seed%d" % seed)
    scene.cycles.seed = seed
    scene.node_tree.nodes["File Output"].base_path = out
    bpy.ops.render.render(write_still=False)
    frame = "%04d" % scene.frame_current
    passes = {p: read_exr(os.path.join(out, "%s_%s.exr" % (p, frame)), width, height) for p in PASSES}
    combined, alpha = passes["Image"]
    diffuse = [a * b for a, b in zip(passes["DiffDir"][0], passes["DiffCol"][0])]
    glossy = [a * b for a, b in zip(passes["GlossDir"][0], passes["GlossCol"][0])]
    return {"combined": combined, "alpha": alpha, "diffuse": diffuse, "glossy": glossy}


def main():
    folder, samples = args()
    with open(os.path.join(folder, "scene.json")) as f:
        scene_data = json.load(f)
    width, height = scene_data["width"], scene_data["height"]
    glossy_c = scene_data.get("glossy_c", 1.0 / (2.0 * math.pi))
    clear_scene()
    emitter_object(scene_data["vals"])
    for i, m in enumerate(scene_data["meshes"]):
        mesh_object("mesh%d" % i, m, glossy_c)
    scene = bpy.context.scene
    scene.camera = camera_object(scene_data)
    setup_render(scene, width, height, samples, folder)
    seeds = [render_seed(scene, folder, s, width, height) for s in (0, 1)]
    mean = {key: [0.5 * (a + b) for a, b in zip(seeds[0][key], seeds[1][key])] for key in ("combined", "diffuse", "glossy")}

    for key, name in (("combined", "cycles.f32"), ("diffuse", "cycles_diffuse.f32"), ("glossy", "cycles_glossy.f32")):
        with open(os.path.join(folder, name), "wb") as f:  # the seeds' mean, same layout as ours
            array("f", mean[key]).tofile(f)

    def load(name):
        values = array("f")
        with open(os.path.join(folder, name), "rb") as f:
            values.fromfile(f, 3 * width * height)
        return values

    ours_mask = load("mask.f32")
    mask = [ours_mask[3 * p] > 0.5 and seeds[0]["alpha"][p] > 0.999 and seeds[1]["alpha"][p] > 0.999
            for p in range(width * height)]
    truth, truth_diffuse = load("truth.f32"), load("truth_diffuse.f32")
    truth_glossy = [a - b for a, b in zip(truth, truth_diffuse)]
    result = {"command": "scripts/blender_reference.sh BUILD DIR %d (Blender %s)" % (samples, bpy.app.version_string),
              "samples_per_seed": samples, "seeds": [0, 1], "pixels": sum(mask), "vals": len(scene_data["vals"]),
              "glossy_c": glossy_c}
    # Self-check: the passes must add up to the combined image (else the split below means nothing).
    split = metrics([a + b for a, b in zip(mean["diffuse"], mean["glossy"])], mean["combined"], mask)
    result["passes_sum_vs_combined"] = split
    if split["max"] > 1e-5:  # float sums of the same samples; a larger gap means the pass set-up is wrong
        raise SystemExit("Cycles passes: DiffDir*DiffCol + GlossDir*GlossCol differs from Combined by %g" % split["max"])
    result["cycles_seed0_vs_seed1"] = metrics(seeds[0]["combined"], seeds[1]["combined"], mask)
    result["cycles_glossy_seed0_vs_seed1"] = metrics(seeds[0]["glossy"], seeds[1]["glossy"], mask)
    for name in ("lightskin", "brute", "truth"):
        result[name + "_vs_cycles"] = metrics(load(name + ".f32"), mean["combined"], mask)
    result["truth_diffuse_vs_cycles_diffuse"] = metrics(truth_diffuse, mean["diffuse"], mask)
    result["truth_glossy_vs_cycles_glossy"] = metrics(truth_glossy, mean["glossy"], mask)
    glossy_share = sum(mean["glossy"][3 * p + c] for p in range(width * height) if mask[p] for c in range(3))
    result["glossy_share_of_cycles"] = glossy_share / max(1e-30, sum(
        mean["combined"][3 * p + c] for p in range(width * height) if mask[p] for c in range(3)))
    bounds = []
    for i, m in enumerate(scene_data["meshes"]):
        if max(m.get("specular_albedo", [0.0])) <= 0.0:
            continue
        k = float(m["specular_exponent"])
        knots, steps, weights = glossy_staircase(k, glossy_c)
        entry = {"mesh": i, "k": k, "cones": len(weights), "cone_max_radians": knots[-1],
                 
                 "worst_case_l1": staircase_l1(k, glossy_c, knots, steps),
                 "scene_effect": glossy_scene_effect(scene_data, m, scene_data["eye"], knots, steps, k, glossy_c)}
        bounds.append(entry)
    result["glossy_model_bounds"] = bounds
    result["emitter_shrink"] = EMITTER_SHRINK
    result["emitter_shrink_effect"] = [shrink_effect(scene_data, m, scene_data["eye"]) for m in scene_data["meshes"]]
    with open(os.path.join(folder, "blender_comparison.json"), "w") as f:
        json.dump(result, f, indent=2)
    print("Cycles reference: 2 seeds x %d samples, %d pixels compared, %d VALs" % (samples, result["pixels"], result["vals"]))
    print("passes DiffDir*DiffCol + GlossDir*GlossCol vs Combined: max %.2e" % split["max"])
    print("glossy share of Cycles' light: %.4f" % result["glossy_share_of_cycles"])
    for b in bounds:
        print("glossy staircase, mesh %d (k = %g, %d cones): worst-case L1 %.4f, scene effect %s"
              % (b["mesh"], b["k"], b["cones"], b["worst_case_l1"], b["scene_effect"]))
    print("emitters at %g x radius, same flux: irradiance change per mesh %s" % (EMITTER_SHRINK, result["emitter_shrink_effect"]))
    print("| image | rel. MSE vs Cycles | MAE | max | mean / Cycles mean |")
    for name in ("cycles_seed0_vs_seed1", "cycles_glossy_seed0_vs_seed1", "lightskin_vs_cycles", "brute_vs_cycles",
                 "truth_vs_cycles", "truth_diffuse_vs_cycles_diffuse", "truth_glossy_vs_cycles_glossy"):
        m = result[name]
        print("| %s | %.3e | %.3e | %.3e | %.4f |" % (name, m["relative_mse"], m["mae"], m["max"], m["mean_ratio"]))


main()
