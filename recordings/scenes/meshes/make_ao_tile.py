#!/usr/bin/env python3
"""Writes the small-scale ambient-occlusion test tiles, Python standard library only.

Outputs, beside this script (licence: CC0, written for lightskin):
  ao_tile.bin            the shared geometry: the unit quad [0, 1]^2 at z = 0 (normal +z) as an 8 x 8 grid of
                         quads (81 vertices, 128 triangles; per-vertex techniques need the tessellation),
                         texture coordinates uv = (x, 1 - y): glTF's uv (0, 0) is the image's top-left pixel,
                         so the image appears upright seen from +z with +y up.
  ao_tile.gltf           material "ao_checker": occlusionTexture ao_tile_occlusion.png (strength 0.75) and
                         normalTexture ao_tile_normal.png (scale 1): the occlusion map takes precedence.
  normal_tile.gltf       material "normal_only": normalTexture ao_tile_normal.png with scale 0.5, no occlusion.
  ao_tile_occlusion.png  8 x 8 RGB, 4 x 4 cells of 2 x 2 texels. R (the occlusion glTF reads): 255 where the
                         cell's column + row (from the top) is even, 128 where odd, and 64 in the top-left cell
                         (so a flipped or mirrored lookup is caught). G = 0, B = 255 everywhere (a reader of the
                         wrong channel is caught).
  ao_tile_normal.png     8 x 8 RGB tangent-space normal map (x = +u, y = +v as glTF, z out of the surface),
                         encoded round((n + 1) / 2 * 255): texel columns 0-3 flat (0, 0, 1); columns 4-5 tilted
                         60 degrees toward +x, (sin 60, 0, cos 60); columns 6-7 tilted 30 degrees toward -y,
                         (0, -sin 30, cos 30).
The tests (tests/gi/prt/PrtSmallScaleGLTest.cpp, tests/render/MeshLoaderTest.cpp) decode the PNGs themselves and
use these values; rerun this script after changing it and commit its outputs.
"""
import json
import math
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
CELLS = 8
SIZE = 8


def png(path, rows):
    """rows: SIZE lists of (r, g, b) byte triples, top row first; 8-bit RGB, no filtering."""
    raw = b"".join(b"\x00" + bytes(c for texel in row for c in texel) for row in rows)

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", len(rows[0]), len(rows), 8, 2, 0, 0, 0)
    with open(path, "wb") as out:
        out.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 9)) +
                  chunk(b"IEND", b""))


def encode(n):
    return tuple(int(round((c + 1.0) / 2.0 * 255.0)) for c in n)


def occlusion_rows():
    rows = []
    for row in range(SIZE):
        texels = []
        for column in range(SIZE):
            cell_row, cell_column = row // 2, column // 2
            r = 255 if (cell_row + cell_column) % 2 == 0 else 128
            if cell_row == 0 and cell_column == 0:
                r = 64
            texels.append((r, 0, 255))
        rows.append(texels)
    return rows


def normal_rows():
    flat = encode((0.0, 0.0, 1.0))
    tilt_x = encode((math.sin(math.radians(60)), 0.0, math.cos(math.radians(60))))
    tilt_y = encode((0.0, -math.sin(math.radians(30)), math.cos(math.radians(30))))
    return [[flat if c < 4 else tilt_x if c < 6 else tilt_y for c in range(SIZE)] for _ in range(SIZE)]


def geometry():
    positions, normals, uvs, indices = [], [], [], []
    for j in range(CELLS + 1):
        for i in range(CELLS + 1):
            x, y = i / CELLS, j / CELLS
            positions += [x, y, 0.0]
            normals += [0.0, 0.0, 1.0]
            uvs += [x, 1.0 - y]
    at = lambda i, j: j * (CELLS + 1) + i
    for j in range(CELLS):
        for i in range(CELLS):
            indices += [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j), at(i + 1, j + 1), at(i, j + 1)]
    blobs = [struct.pack("<%df" % len(positions), *positions), struct.pack("<%df" % len(normals), *normals),
             struct.pack("<%df" % len(uvs), *uvs), struct.pack("<%dI" % len(indices), *indices)]
    return blobs, len(positions) // 3, len(indices)


def gltf(material, images, bin_bytes, vertices, index_count, offsets):
    return {
        "asset": {"version": "2.0", "generator": "lightskin recordings/scenes/meshes/make_ao_tile.py"},
        "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, "name": "tile"}],
        "meshes": [{"name": "tile", "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
                                                     "indices": 3, "material": 0}]}],
        "materials": [material],
        "images": [{"uri": name} for name in images],
        "samplers": [{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497}],
        "textures": [{"source": i, "sampler": 0} for i in range(len(images))],
        "buffers": [{"uri": "ao_tile.bin", "byteLength": bin_bytes}],
        "bufferViews": [{"buffer": 0, "byteOffset": offsets[k], "byteLength": offsets[k + 1] - offsets[k]}
                        for k in range(4)],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": vertices, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]},
            {"bufferView": 1, "componentType": 5126, "count": vertices, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": vertices, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5125, "count": index_count, "type": "SCALAR"},
        ],
    }


def main():
    png(os.path.join(HERE, "ao_tile_occlusion.png"), occlusion_rows())
    png(os.path.join(HERE, "ao_tile_normal.png"), normal_rows())
    blobs, vertices, index_count = geometry()
    offsets = [0]
    for blob in blobs:
        offsets.append(offsets[-1] + len(blob))
    with open(os.path.join(HERE, "ao_tile.bin"), "wb") as out:
        out.write(b"".join(blobs))
    ao = {"name": "ao_checker", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0],
                                                         "metallicFactor": 0.0},
          "occlusionTexture": {"index": 0, "strength": 0.75}, "normalTexture": {"index": 1, "scale": 1.0}}
    normal = {"name": "normal_only", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0],
                                                              "metallicFactor": 0.0},
              "normalTexture": {"index": 0, "scale": 0.5}}
    for name, material, images in (("ao_tile.gltf", ao, ["ao_tile_occlusion.png", "ao_tile_normal.png"]),
                                   ("normal_tile.gltf", normal, ["ao_tile_normal.png"])):
        with open(os.path.join(HERE, name), "w") as out:
            json.dump(gltf(material, images, offsets[-1], vertices, index_count, offsets), out, indent=1)
            out.write("\n")


if __name__ == "__main__":
    main()
