#!/usr/bin/env python3
"""Writes the glTF 2.0 samples of the animation tests (tests/data/meshes), whose motion has a closed form.

swinging_box.gltf: a 0.1 m box on node "Tip" (static translation [0.2, 0, 0]) under "Arm" (rest translation
  [0, 0.5, 0]; clip "Swing": translation [0, 0.5, 0] -> [0, 1.5, 0] over 0..1 s and rotation about +z 0 -> 90
  degrees over 0..2 s; clip "Lift": translation [0, 0.5, 0] -> [0, 0.5, 1] over 0..0.5 s) under "Base" (static
  translation [1, 0, 0]).
bending_cylinder.gltf: a capped cylinder, radius 0.2 m, y from 0 to 2 m, skinned to two bones: "Lower" at the
  origin and its child "Upper" at the joint [0, 1, 0]. A vertex at height y weighs the upper bone
  w = clamp((y - 0.75) / 0.5, 0, 1). Clip "Bend": "Upper" turns about +z from 0 to 90 degrees over 0..1 s.
  Skinned position at time t: (1 - w) p + w (J + Rz(90 t deg) (p - J)), J = [0, 1, 0].

swinging_box_nan_key.gltf: swinging_box.gltf with a NaN in the second translation key of "Swing" (an error case).
swinging_box_stretched_base.gltf: swinging_box.gltf with "Base" scaled [1, 2, 1] (an error case: a stretched
  parent turns the clip's rotation into a shear).
All are the project's own (CC0). Run: python3 scripts/make_gltf_samples.py (rewrites the files).
"""
import base64
import json
import math
import os
import struct

OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "data", "meshes")


class Writer:
    def __init__(self):
        self.data = bytearray()
        self.views = []
        self.accessors = []

    def add(self, fmt, values, count, type_, component, target=None, minmax=False):
        while len(self.data) % 4:
            self.data.append(0)
        offset = len(self.data)
        self.data += struct.pack("<" + fmt * len(values), *values)
        view = {"buffer": 0, "byteOffset": offset, "byteLength": len(self.data) - offset}
        if target:
            view["target"] = target
        self.views.append(view)
        accessor = {"bufferView": len(self.views) - 1, "componentType": component, "count": count, "type": type_}
        if minmax:
            width = len(values) // count
            accessor["min"] = [min(values[i::width]) for i in range(width)]
            accessor["max"] = [max(values[i::width]) for i in range(width)]
        self.accessors.append(accessor)
        return len(self.accessors) - 1

    def floats(self, rows, type_, minmax=False, target=None):
        flat = [float(x) for row in rows for x in (row if isinstance(row, (list, tuple)) else [row])]
        return self.add("f", flat, len(rows), type_, 5126, target, minmax)

    def gltf(self, extra):
        doc = {"asset": {"version": "2.0", "generator": "lightskin scripts/make_gltf_samples.py",
                         "copyright": "lightskin project, CC0"},
               "buffers": [{"byteLength": len(self.data),
                            "uri": "data:application/octet-stream;base64," + base64.b64encode(self.data).decode()}],
               "bufferViews": self.views, "accessors": self.accessors}
        doc.update(extra)
        return doc


def box(w, half):
    positions, normals, indices = [], [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            n = [0.0, 0.0, 0.0]
            n[axis] = sign
            u, v = (axis + 1) % 3, (axis + 2) % 3
            base = len(positions)
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [0.0, 0.0, 0.0]
                p[axis], p[u], p[v] = sign * half, a * half, b * half
                positions.append(p)
                normals.append(n)
            quad = [base, base + 1, base + 2, base, base + 2, base + 3]
            if sign < 0:
                quad = [base, base + 2, base + 1, base, base + 3, base + 2]
            indices += quad
    return positions, normals, indices


def swinging_box(nan_key=False, base_scale=None):
    w = Writer()
    positions, normals, indices = box(w, 0.05)
    pos = w.floats(positions, "VEC3", minmax=True, target=34962)
    nor = w.floats(normals, "VEC3", target=34962)
    idx = w.add("H", indices, len(indices), "SCALAR", 5123, 34963)
    swing_t = w.floats([0.0, 1.0], "SCALAR", minmax=True)
    swing_p = w.floats([[0, 0.5, 0], [0, float("nan") if nan_key else 1.5, 0]], "VEC3")
    rot_t = w.floats([0.0, 2.0], "SCALAR", minmax=True)
    s = math.sin(math.radians(45.0))
    rot_q = w.floats([[0, 0, 0, 1], [0, 0, s, s]], "VEC4")  # glTF quaternions are x, y, z, w
    lift_t = w.floats([0.0, 0.5], "SCALAR", minmax=True)
    lift_p = w.floats([[0, 0.5, 0], [0, 0.5, 1]], "VEC3")
    return w.gltf({
        "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [dict({"name": "Base", "translation": [1, 0, 0], "children": [1]},
                       **({"scale": base_scale} if base_scale else {})),
                  {"name": "Arm", "translation": [0, 0.5, 0], "children": [2]},
                  {"name": "Tip", "translation": [0.2, 0, 0], "mesh": 0}],
        "meshes": [{"name": "box", "primitives": [{"attributes": {"POSITION": pos, "NORMAL": nor}, "indices": idx}]}],
        "animations": [
            {"name": "Swing",
             "samplers": [{"input": swing_t, "output": swing_p}, {"input": rot_t, "output": rot_q}],
             "channels": [{"sampler": 0, "target": {"node": 1, "path": "translation"}},
                          {"sampler": 1, "target": {"node": 1, "path": "rotation"}}]},
            {"name": "Lift", "samplers": [{"input": lift_t, "output": lift_p}],
             "channels": [{"sampler": 0, "target": {"node": 1, "path": "translation"}}]}]})


def upper_weight(y):
    return min(max((y - 0.75) / 0.5, 0.0), 1.0)


def bending_cylinder():
    w = Writer()
    radius, segments, rings = 0.2, 16, 17  # rings every 0.125 m
    positions, normals, weights, indices = [], [], [], []
    for r in range(rings):
        y = 2.0 * r / (rings - 1)
        for s in range(segments):
            a = 2.0 * math.pi * s / segments
            positions.append([radius * math.cos(a), y, -radius * math.sin(a)])
            normals.append([math.cos(a), 0.0, -math.sin(a)])
            weights.append(upper_weight(y))
    for r in range(rings - 1):
        for s in range(segments):
            a, b = r * segments + s, r * segments + (s + 1) % segments
            indices += [a, b, b + segments, a, b + segments, a + segments]
    for y, ny in ((0.0, -1.0), (2.0, 1.0)):  # caps: a centre and their own ring (flat normals)
        centre = len(positions)
        positions.append([0.0, y, 0.0])
        normals.append([0.0, ny, 0.0])
        weights.append(upper_weight(y))
        for s in range(segments):
            a = 2.0 * math.pi * s / segments
            positions.append([radius * math.cos(a), y, -radius * math.sin(a)])
            normals.append([0.0, ny, 0.0])
            weights.append(upper_weight(y))
        for s in range(segments):
            a, b = centre + 1 + s, centre + 1 + (s + 1) % segments
            indices += [centre, a, b] if ny > 0 else [centre, b, a]
    count = len(positions)
    pos = w.floats(positions, "VEC3", minmax=True, target=34962)
    nor = w.floats(normals, "VEC3", target=34962)
    joints = w.add("B", [j for _ in range(count) for j in (0, 1, 0, 0)], count, "VEC4", 5121, 34962)
    wts = w.floats([[1.0 - u, u, 0.0, 0.0] for u in weights], "VEC4", target=34962)
    idx = w.add("H", indices, len(indices), "SCALAR", 5123, 34963)
    # inverse bind matrices, column-major: Lower at the origin, Upper at the joint [0, 1, 0]
    ibm = w.floats([[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1],
                    [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, -1, 0, 1]], "MAT4")
    bend_t = w.floats([0.0, 1.0], "SCALAR", minmax=True)
    s = math.sin(math.radians(45.0))
    bend_q = w.floats([[0, 0, 0, 1], [0, 0, s, s]], "VEC4")
    return w.gltf({
        "scene": 0, "scenes": [{"nodes": [0, 2]}],
        "nodes": [{"name": "Lower", "children": [1]},
                  {"name": "Upper", "translation": [0, 1, 0]},
                  {"name": "Cylinder", "mesh": 0, "skin": 0}],
        "skins": [{"joints": [0, 1], "inverseBindMatrices": ibm, "skeleton": 0}],
        "meshes": [{"name": "cylinder", "primitives": [{"attributes": {
            "POSITION": pos, "NORMAL": nor, "JOINTS_0": joints, "WEIGHTS_0": wts}, "indices": idx}]}],
        "animations": [{"name": "Bend", "samplers": [{"input": bend_t, "output": bend_q}],
                        "channels": [{"sampler": 0, "target": {"node": 1, "path": "rotation"}}]}]})


if __name__ == "__main__":
    for name, doc in (("swinging_box.gltf", swinging_box()), ("swinging_box_nan_key.gltf", swinging_box(nan_key=True)),
                      ("swinging_box_stretched_base.gltf", swinging_box(base_scale=[1, 2, 1])),
                      ("bending_cylinder.gltf", bending_cylinder())):
        with open(os.path.join(OUT, name), "w") as f:
            json.dump(doc, f, indent=1)
            f.write("\n")
