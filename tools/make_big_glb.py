#!/usr/bin/env python3
"""Write a large glTF 2.0 scene for the load benchmark (python3, standard library only).

`python3 tools/make_big_glb.py OUT.glb [TRIANGLES]` (default 1,000,000): a glass sphere
tessellated into about TRIANGLES triangles (a latitude-longitude grid, indexed u32, with
normals) over a floor, under a spot light, with a camera. Not committed (some 30 MB); time it
with `caustics bench OUT.glb --load` (docs/benchmarks.md, "Loading a large glTF scene").
"""

import json
import math
import struct
import sys


def main():
    out = sys.argv[1]
    want = int(sys.argv[2]) if len(sys.argv) > 2 else 1_000_000
    # rows x cols quads, two triangles each but one at the poles: 2 cols (rows - 1) >= want
    cols = max(8, int(math.sqrt(want)))
    rows = max(4, -(-want // (2 * cols)) + 1)
    r, cy = 0.5, 0.6
    pos, nrm, idx = bytearray(), bytearray(), bytearray()

    def vertex(n):
        nonlocal pos, nrm
        pos += struct.pack("<3f", r * n[0], cy + r * n[1], r * n[2])
        nrm += struct.pack("<3f", *n)

    # A closed, welded sphere: one vertex at each pole, `cols` around each inner ring.
    vertex((0.0, 1.0, 0.0))
    for i in range(1, rows):
        th = math.pi * i / rows
        for j in range(cols):
            ph = 2.0 * math.pi * j / cols
            vertex((math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph)))
    vertex((0.0, -1.0, 0.0))
    south = 1 + (rows - 1) * cols

    def at(i, j):
        return 0 if i == 0 else south if i == rows else 1 + (i - 1) * cols + j % cols

    for i in range(rows):
        for j in range(cols):
            a, b, c, d = at(i, j), at(i, j + 1), at(i + 1, j), at(i + 1, j + 1)
            if i > 0:
                idx += struct.pack("<3I", a, c, b)
            if i < rows - 1:
                idx += struct.pack("<3I", b, c, d)
    nv, ni = len(pos) // 12, len(idx) // 4
    floor_pos = struct.pack("<12f", -4, 0, -4, 4, 0, -4, 4, 0, 4, -4, 0, 4)
    floor_nrm = struct.pack("<12f", *([0, 1, 0] * 4))
    floor_idx = struct.pack("<6I", 0, 2, 1, 0, 3, 2)
    blobs = [pos, nrm, idx, floor_pos, floor_nrm, floor_idx]
    views, offset = [], 0
    for b in blobs:
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(b)})
        offset += len(b)
    lo = [-r, cy - r, -r]
    hi = [r, cy + r, r]
    accessors = [
        {"bufferView": 0, "componentType": 5126, "count": nv, "type": "VEC3", "min": lo, "max": hi},
        {"bufferView": 1, "componentType": 5126, "count": nv, "type": "VEC3"},
        {"bufferView": 2, "componentType": 5125, "count": ni, "type": "SCALAR"},
        {"bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-4, 0, -4], "max": [4, 0, 4]},
        {"bufferView": 4, "componentType": 5126, "count": 4, "type": "VEC3"},
        {"bufferView": 5, "componentType": 5125, "count": 6, "type": "SCALAR"},
    ]
    doc = {
        "asset": {"version": "2.0", "generator": "caustics tools/make_big_glb.py"},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_transmission", "KHR_materials_ior"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "spot", "intensity": 40 * 683.0, "spot": {"innerConeAngle": 0.35, "outerConeAngle": 0.5}}]}},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3]}],
        "nodes": [
            {"name": "ball", "mesh": 0},
            {"name": "floor", "mesh": 1},
            {"name": "lamp", "translation": [0, 4, 0], "rotation": [-math.sqrt(0.5), 0, 0, math.sqrt(0.5)],
             "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"name": "camera", "camera": 0, "translation": [0, 1.2, 3.5]},
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.05}}],
        "meshes": [
            {"name": "ball", "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0}]},
            {"name": "floor", "primitives": [{"attributes": {"POSITION": 3, "NORMAL": 4}, "indices": 5, "material": 1}]},
        ],
        "materials": [
            {"name": "glass", "pbrMetallicRoughness": {"metallicFactor": 0, "roughnessFactor": 0},
             "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1}, "KHR_materials_ior": {"ior": 1.5}}},
            {"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0}},
        ],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": offset}],
    }
    js = json.dumps(doc, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    body = b"".join(blobs)
    body += b"\0" * (-len(body) % 4)
    total = 12 + 8 + len(js) + 8 + len(body)
    with open(out, "wb") as f:
        f.write(struct.pack("<4sII", b"glTF", 2, total))
        f.write(struct.pack("<I4s", len(js), b"JSON") + js)
        f.write(struct.pack("<I4s", len(body), b"BIN\0") + body)
    print(f"{out}: {ni // 3} triangles, {nv} vertices, {total / 1e6:.1f} MB")


if __name__ == "__main__":
    main()
