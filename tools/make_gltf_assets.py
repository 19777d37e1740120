#!/usr/bin/env python3
"""Write the small glTF 2.0 test scenes under scenes/gltf/ (python3, standard library only).

Rerun from the repository root: `python3 tools/make_gltf_assets.py`. The output is deterministic.

- glass_ball.glb: a glass ball over a floor under a spot light, with a camera (GLB, BIN chunk).
- glass_ball.gltf: the same scene, its buffer a base64 data: URI.
- glass_ball.json + meshes/ball.obj + meshes/floor.obj: the same scene in our JSON format, every
  number the f32 the glTF loader computes, so both render the same image bits.
- nested.gltf: nested TRS and matrix transforms, a mirrored (negative scale) node, strip, fan and
  points primitives, a cube without normals, an external .bin buffer, a directional light.
- instanced.glb: one mesh drawn by three nodes, u16 indices, a point light, no camera.
- unsupported.gltf: every feature we warn about (textures, normal map, emissive, alpha blend,
  skin, morph targets, animation, KHR_texture_transform, KHR_materials_dispersion, rough metal,
  thin-walled and absorbing glass, light range), with KHR_materials_volume required.
"""

import base64
import json
import math
import os
import struct

OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenes", "gltf")
LUMENS_PER_WATT = 683.0


def f32(x):
    """x rounded to the nearest f32, as a Python float."""
    return struct.unpack("<f", struct.pack("<f", x))[0]


def to_radians_f32(deg):
    """Rust's f32::to_radians, bit for bit: deg * (PI / 180) in f32."""
    return f32(f32(deg) * f32(f32(math.pi) / 180.0))


def to_degrees_f32(rad):
    """Rust's f32::to_degrees, bit for bit: rad * 57.29577951308232 in f32."""
    return f32(f32(rad) * f32(57.2957795130823208767981548141051703))


class Builder:
    """One binary buffer with its bufferViews and accessors."""

    def __init__(self):
        self.bin = bytearray()
        self.views = []
        self.accessors = []

    def _view(self, data, target=None):
        while len(self.bin) % 4:
            self.bin.append(0)
        view = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if target:
            view["target"] = target
        self.bin += data
        self.views.append(view)
        return len(self.views) - 1

    def vec3(self, points):
        data = b"".join(struct.pack("<3f", *p) for p in points)
        lo = [min(f32(p[k]) for p in points) for k in range(3)]
        hi = [max(f32(p[k]) for p in points) for k in range(3)]
        view = self._view(data, 34962)
        self.accessors.append(
            {"bufferView": view, "componentType": 5126, "count": len(points), "type": "VEC3", "min": lo, "max": hi}
        )
        return len(self.accessors) - 1

    def indices(self, idx, fmt="I"):
        ctype = {"B": 5121, "H": 5123, "I": 5125}[fmt]
        view = self._view(b"".join(struct.pack("<" + fmt, i) for i in idx), 34963)
        self.accessors.append({"bufferView": view, "componentType": ctype, "count": len(idx), "type": "SCALAR"})
        return len(self.accessors) - 1

    def floats(self, values):
        view = self._view(b"".join(struct.pack("<f", v) for v in values))
        self.accessors.append(
            {"bufferView": view, "componentType": 5126, "count": len(values), "type": "SCALAR",
             "min": [min(values)], "max": [max(values)]}
        )
        return len(self.accessors) - 1

    def document(self, uri=None):
        buf = {"byteLength": len(self.bin)}
        if uri is not None:
            buf["uri"] = uri
        return {"asset": {"version": "2.0", "generator": "tools/make_gltf_assets.py"}, "buffers": [buf],
                "bufferViews": self.views, "accessors": self.accessors}


def uv_sphere(center, radius, nu, nv):
    """Closed UV sphere: one vertex per pole, `nu` per ring; unit normals; counter-clockwise seen
    from outside."""
    pos, nrm = [], []
    pos.append((center[0], center[1] + radius, center[2]))
    nrm.append((0.0, 1.0, 0.0))
    for j in range(1, nv):
        theta = math.pi * j / nv
        for i in range(nu):
            phi = 2 * math.pi * i / nu
            n = (math.sin(theta) * math.cos(phi), math.cos(theta), -math.sin(theta) * math.sin(phi))
            pos.append(tuple(center[k] + radius * n[k] for k in range(3)))
            nrm.append(n)
    pos.append((center[0], center[1] - radius, center[2]))
    nrm.append((0.0, -1.0, 0.0))
    bottom = len(pos) - 1
    ring = lambda j, i: 1 + (j - 1) * nu + (i % nu)
    tris = []
    for i in range(nu):
        tris.append((0, ring(1, i), ring(1, i + 1)))
    for j in range(1, nv - 1):
        for i in range(nu):
            a, b, c, d = ring(j, i), ring(j, i + 1), ring(j + 1, i), ring(j + 1, i + 1)
            tris += [(a, c, b), (b, c, d)]
    for i in range(nu):
        tris.append((bottom, ring(nv - 1, i + 1), ring(nv - 1, i)))
    return pos, nrm, tris


def fix_winding(pos, tris):
    """Make every triangle counter-clockwise seen from outside (centroid test, convex meshes)."""
    c = [sum(p[k] for p in pos) / len(pos) for k in range(3)]
    out = []
    for t in tris:
        a, b, d = (pos[i] for i in t)
        e1 = [b[k] - a[k] for k in range(3)]
        e2 = [d[k] - a[k] for k in range(3)]
        n = (e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0])
        m = [(a[k] + b[k] + d[k]) / 3 - c[k] for k in range(3)]
        out.append(t if sum(n[k] * m[k] for k in range(3)) > 0 else (t[0], t[2], t[1]))
    return out


FLOOR = [(-4.0, 0.0, -4.0), (4.0, 0.0, -4.0), (4.0, 0.0, 4.0), (-4.0, 0.0, 4.0)]
FLOOR_TRIS = [(0, 2, 1), (0, 3, 2)]  # counter-clockwise seen from above (+Y)

# A cube of side 0.4 centred at the origin, no normals: the loader makes flat ones.
CUBE = [(x, y, z) for x in (-0.2, 0.2) for y in (-0.2, 0.2) for z in (-0.2, 0.2)]
CUBE_TRIS = fix_winding(CUBE, [
    (0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
    (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3),
])


def col_major(rows):
    """glTF's column-major 16 numbers from a 4x4 given as rows."""
    return [rows[r][c] for c in range(4) for r in range(4)]


def glass_ball(b):
    """The glass-ball scene's document (without buffers' uri) over builder b."""
    ball_pos, ball_nrm, ball_tris = uv_sphere((0.0, 0.9, 0.0), 0.5, 32, 16)
    ball = {"name": "ball", "primitives": [{
        "attributes": {"POSITION": b.vec3(ball_pos), "NORMAL": b.vec3(ball_nrm)},
        "indices": b.indices([i for t in ball_tris for i in t], "H"), "material": 1, "mode": 4}]}
    floor = {"name": "floor", "primitives": [{
        "attributes": {"POSITION": b.vec3(FLOOR)},
        "indices": b.indices([i for t in FLOOR_TRIS for i in t], "B"), "material": 0}]}
    doc = b.document()
    # The spot at (0, 4, 0) shining down -Y: local -Z maps to -Y exactly (a matrix, no rounding).
    spot = col_major([[1, 0, 0, 0], [0, 0, 1, 4], [0, -1, 0, 0], [0, 0, 0, 1]])
    doc.update({
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_transmission", "KHR_materials_ior",
                           "KHR_materials_volume"],
        "scene": 0,
        "scenes": [{"name": "glass_ball", "nodes": [0, 1, 2, 3]}],
        "nodes": [
            {"name": "ball", "mesh": 0},
            {"name": "floor", "mesh": 1},
            {"name": "spot", "matrix": spot, "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"name": "camera", "translation": [0.0, 1.0, 4.0], "camera": 0},
        ],
        "meshes": [ball, floor],
        "materials": [
            {"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0],
                                                      "metallicFactor": 0.0, "roughnessFactor": 1.0}},
            {"name": "glass", "pbrMetallicRoughness": {"metallicFactor": 0.0, "roughnessFactor": 0.0},
             "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                            "KHR_materials_ior": {"ior": 1.5},
                            "KHR_materials_volume": {"thicknessFactor": 1.0}}},
        ],
        "cameras": [{"name": "main", "type": "perspective",
                     "perspective": {"yfov": to_radians_f32(38.0), "aspectRatio": 1.0, "znear": 0.05}}],
        "extensions": {"KHR_lights_punctual": {"lights": [{
            "name": "spot", "type": "spot", "color": [1.0, 1.0, 1.0], "intensity": 40 * LUMENS_PER_WATT,
            "spot": {"innerConeAngle": to_radians_f32(22.0), "outerConeAngle": to_radians_f32(30.0)}}]}},
    })
    return doc, (ball_pos, ball_nrm, ball_tris)


def write_obj(path, pos, nrm, tris):
    with open(path, "w") as f:
        f.write("# written by tools/make_gltf_assets.py: the same f32 numbers as scenes/gltf/glass_ball.glb\n")
        for p in pos:
            f.write("v %r %r %r\n" % tuple(f32(x) for x in p))
        for n in nrm or []:
            f.write("vn %r %r %r\n" % tuple(f32(x) for x in n))
        for t in tris:
            if nrm:
                f.write("f %d//%d %d//%d %d//%d\n" % tuple(i + 1 for i in t for _ in (0, 1)))
            else:
                f.write("f %d %d %d\n" % tuple(i + 1 for i in t))


def glb(doc, bin_data):
    js = json.dumps(doc, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    bin_data = bytes(bin_data) + b"\0" * (-len(bin_data) % 4)
    total = 12 + 8 + len(js) + 8 + len(bin_data)
    return (struct.pack("<4sII", b"glTF", 2, total) + struct.pack("<I4s", len(js), b"JSON") + js
            + struct.pack("<I4s", len(bin_data), b"BIN\0") + bin_data)


def write_glass_ball():
    b = Builder()
    doc, (pos, nrm, tris) = glass_ball(b)
    with open(os.path.join(OUT, "glass_ball.glb"), "wb") as f:
        f.write(glb(doc, b.bin))
    doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(bytes(b.bin)).decode()
    with open(os.path.join(OUT, "glass_ball.gltf"), "w") as f:
        json.dump(doc, f, indent=1)
    os.makedirs(os.path.join(OUT, "meshes"), exist_ok=True)
    write_obj(os.path.join(OUT, "meshes", "ball.obj"), pos, nrm, tris)
    write_obj(os.path.join(OUT, "meshes", "floor.obj"), FLOOR, None, FLOOR_TRIS)
    scene = {
        "schema_version": 1,
        "name": "glass_ball",
        "description": "scenes/gltf/glass_ball.glb written in our format (tools/make_gltf_assets.py): a "
                       "32x16 glass ball mesh over an 8 m floor mesh under a 40 W/sr spot light.",
        "camera": {"position": [0.0, 1.0, 4.0], "look_at": [0.0, 1.0, 3.0], "up": [0, 1, 0],
                   "fov_y_deg": to_degrees_f32(to_radians_f32(38.0)), "width": 600, "height": 600},
        "lights": [{"type": "spot", "position": [0.0, 4.0, 0.0], "direction": [0, -1, 0],
                    "cone_angle_deg": to_degrees_f32(to_radians_f32(30.0)),
                    "falloff_start_deg": to_degrees_f32(to_radians_f32(22.0)), "intensity": [40, 40, 40],
                    "falloff": "gltf"}],
        "materials": {"floor": {"type": "diffuse", "albedo": f32(0.8)},
                      "glass": {"type": "dielectric", "ior": 1.5, "ext_ior": 1.0}},
        "objects": [
            {"type": "mesh", "path": "meshes/ball.obj", "material": "glass"},
            {"type": "mesh", "path": "meshes/floor.obj", "smooth_normals": False, "material": "floor"},
        ],
    }
    with open(os.path.join(OUT, "glass_ball.json"), "w") as f:
        json.dump(scene, f, indent=1)
        f.write("\n")


def quat_axis_angle(axis, deg):
    s = math.sin(math.radians(deg) / 2)
    n = math.sqrt(sum(a * a for a in axis))
    return [axis[0] / n * s, axis[1] / n * s, axis[2] / n * s, math.cos(math.radians(deg) / 2)]


def trs_matrix(t, q, s):
    """Column-major matrix of translation t, unit quaternion q (x, y, z, w), scale s."""
    x, y, z, w = q
    r = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
         [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
         [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    rows = [[r[i][0] * s[0], r[i][1] * s[1], r[i][2] * s[2], t[i]] for i in range(3)] + [[0, 0, 0, 1]]
    return col_major(rows)


def write_nested():
    b = Builder()
    cube = {"name": "cube", "primitives": [{
        "attributes": {"POSITION": b.vec3(CUBE)}, "indices": b.indices([i for t in CUBE_TRIS for i in t], "B"),
        "material": 0}]}
    # A square as a strip (4 vertices) and as a fan (4 vertices), normal +Y, and a points primitive.
    sq = [(-0.3, 0.0, -0.3), (-0.3, 0.0, 0.3), (0.3, 0.0, -0.3), (0.3, 0.0, 0.3)]
    strip = b.vec3(sq)
    fan = b.vec3([(-0.3, 0.0, -0.3), (-0.3, 0.0, 0.3), (0.3, 0.0, 0.3), (0.3, 0.0, -0.3)])
    shapes = {"name": "strip_fan_points", "primitives": [
        {"attributes": {"POSITION": strip}, "mode": 5, "material": 0},
        {"attributes": {"POSITION": fan}, "mode": 6, "material": 0},
        {"attributes": {"POSITION": strip}, "mode": 0, "material": 0},
    ]}
    doc = b.document("nested.bin")
    q = quat_axis_angle((0, 1, 0), 30.0)
    t, s = [0.5, 0.25, -0.5], [1.0, 2.0, 1.0]
    doc.update({
        "extensionsUsed": ["KHR_lights_punctual"],
        "scenes": [{"nodes": [0, 6, 7]}],
        "nodes": [
            # 0: a parent with TRS; its children: a TRS cube (1), a matrix cube with the same
            # transform (2), a mirrored cube (3), a matrix-only grandparent chain (4 -> 5).
            {"name": "parent", "translation": [0.0, 1.0, 0.0], "rotation": quat_axis_angle((1, 0, 0), 20.0),
             "scale": [0.5, 0.5, 0.5], "children": [1, 2, 3, 4]},
            {"name": "trs_cube", "translation": t, "rotation": q, "scale": s, "mesh": 0},
            {"name": "matrix_cube", "matrix": trs_matrix(t, q, s), "mesh": 0},
            {"name": "mirrored_cube", "translation": [-0.5, 0.0, 0.0], "scale": [-1.0, 1.0, 1.0], "mesh": 0},
            {"name": "chain", "matrix": trs_matrix([0.0, 0.0, 1.0], quat_axis_angle((0, 0, 1), 45.0), [1, 1, 1]),
             "children": [5]},
            {"name": "chain_cube", "translation": [0.25, 0.0, 0.0], "mesh": 0},
            {"name": "shapes", "translation": [0.0, 0.0, 0.0], "mesh": 1},
            {"name": "sun", "rotation": quat_axis_angle((1, 0, 0), -60.0),
             "extensions": {"KHR_lights_punctual": {"light": 0}}},
        ],
        "meshes": [cube, shapes],
        "materials": [{"name": "white", "pbrMetallicRoughness": {"metallicFactor": 0.0}}],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"name": "sun", "type": "directional", "intensity": 2.0 * LUMENS_PER_WATT, "color": [1.0, 0.5, 0.25]}]}},
    })
    with open(os.path.join(OUT, "nested.bin"), "wb") as f:
        f.write(b.bin)
    with open(os.path.join(OUT, "nested.gltf"), "w") as f:
        json.dump(doc, f, indent=1)


def write_instanced():
    b = Builder()
    pos, nrm, tris = uv_sphere((0.0, 0.0, 0.0), 0.3, 16, 8)
    ball = {"name": "ball", "primitives": [{
        "attributes": {"POSITION": b.vec3(pos), "NORMAL": b.vec3(nrm)},
        "indices": b.indices([i for t in tris for i in t], "H"), "material": 0}]}
    floor = {"name": "floor", "primitives": [{
        "attributes": {"POSITION": b.vec3(FLOOR)}, "indices": b.indices([i for t in FLOOR_TRIS for i in t], "I"),
        "material": 1}]}
    doc = b.document()
    doc.update({
        "extensionsUsed": ["KHR_lights_punctual"],
        "scenes": [{"nodes": [0, 1, 2, 3, 4]}],
        "nodes": [
            {"name": "ball_a", "translation": [-0.8, 0.3, 0.0], "mesh": 0},
            {"name": "ball_b", "translation": [0.0, 0.3, 0.0], "mesh": 0},
            {"name": "ball_c", "translation": [0.8, 0.3, 0.0], "mesh": 0},
            {"name": "floor", "mesh": 1},
            {"name": "bulb", "translation": [0.0, 2.0, 0.5], "extensions": {"KHR_lights_punctual": {"light": 0}}},
        ],
        "meshes": [ball, floor],
        "materials": [
            {"name": "chrome", "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.9, 0.9, 1.0],
                                                       "metallicFactor": 1.0, "roughnessFactor": 0.05}},
            {"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.6, 0.7, 1.0],
                                                      "metallicFactor": 0.0}},
        ],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 10 * LUMENS_PER_WATT}]}},
    })
    with open(os.path.join(OUT, "instanced.glb"), "wb") as f:
        f.write(glb(doc, b.bin))


def write_unsupported():
    b = Builder()
    pos, nrm, tris = uv_sphere((0.0, 0.5, 0.0), 0.5, 8, 4)
    pos_acc, nrm_acc = b.vec3(pos), b.vec3(nrm)
    idx = b.indices([i for t in tris for i in t], "B")
    target = b.vec3([(0.0, 0.1, 0.0)] * len(pos))
    times = b.floats([0.0, 1.0])
    angles = b.vec3([(0.0, 0.0, 0.0), (0.0, 1.0, 0.0)])
    floor_pos = b.vec3(FLOOR)
    floor_idx = b.indices([i for t in FLOOR_TRIS for i in t], "B")
    doc = b.document("data:application/octet-stream;base64," + base64.b64encode(bytes(b.bin)).decode())
    tex = {"index": 0, "extensions": {"KHR_texture_transform": {"scale": [2.0, 2.0]}}}
    doc.update({
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_transmission", "KHR_materials_volume",
                           "KHR_materials_dispersion", "KHR_texture_transform"],
        "extensionsRequired": ["KHR_materials_volume", "KHR_materials_dispersion"],
        "scenes": [{"nodes": [0, 1, 2, 3, 4, 5]}],
        "nodes": [
            {"name": "blob", "mesh": 0, "skin": 0, "weights": [0.5]},
            {"name": "floor", "mesh": 1},
            {"name": "lamp", "translation": [0.0, 3.0, 0.0], "rotation": quat_axis_angle((1, 0, 0), -90.0),
             "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"name": "bone", "translation": [0.0, 0.0, 0.0]},
            {"name": "glass_block", "translation": [1.0, 0.5, 0.0], "mesh": 2},
            {"name": "window", "translation": [0.0, 1.0, -1.0], "rotation": quat_axis_angle((1, 0, 0), 90.0),
             "scale": [0.2, 0.2, 0.2], "mesh": 3},
        ],
        "skins": [{"joints": [3]}],
        "animations": [{"name": "spin", "samplers": [{"input": times, "output": angles}],
                        "channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}}]}],
        "meshes": [
            {"name": "blob", "weights": [0.0], "primitives": [{
                "attributes": {"POSITION": pos_acc, "NORMAL": nrm_acc}, "indices": idx, "material": 0,
                "targets": [{"POSITION": target}]}]},
            {"name": "floor", "primitives": [{"attributes": {"POSITION": floor_pos}, "indices": floor_idx,
                                              "material": 1}]},
            {"name": "glass_block", "primitives": [{
                "attributes": {"POSITION": pos_acc, "NORMAL": nrm_acc}, "indices": idx, "material": 2}]},
            {"name": "window", "primitives": [{"attributes": {"POSITION": floor_pos}, "indices": floor_idx,
                                               "material": 3}]},
        ],
        "images": [{"uri": "missing.png"}],
        "textures": [{"source": 0}],
        "materials": [
            {"name": "painted", "pbrMetallicRoughness": {"baseColorTexture": tex, "metallicFactor": 0.0},
             "normalTexture": {"index": 0}, "emissiveFactor": [1.0, 0.0, 0.0], "alphaMode": "BLEND"},
            {"name": "brushed", "pbrMetallicRoughness": {"metallicFactor": 1.0, "roughnessFactor": 0.6}},
            {"name": "tinted", "pbrMetallicRoughness": {"metallicFactor": 0.0, "roughnessFactor": 0.0},
             "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                            "KHR_materials_volume": {"thicknessFactor": 0.3, "attenuationDistance": 0.5,
                                                     "attenuationColor": [1.0, 0.5, 0.5]},
                            "KHR_materials_dispersion": {"dispersion": 0.3}}},
            {"name": "window_glass", "pbrMetallicRoughness": {"metallicFactor": 0.0, "roughnessFactor": 0.0},
             "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}}},
        ],
        "extensions": {"KHR_lights_punctual": {"lights": [{
            "name": "lamp", "type": "spot", "intensity": 100.0, "range": 10.0,
            "spot": {"innerConeAngle": 0.3, "outerConeAngle": 0.6}}]}},
    })
    with open(os.path.join(OUT, "unsupported.gltf"), "w") as f:
        json.dump(doc, f, indent=1)


def main():
    os.makedirs(OUT, exist_ok=True)
    write_glass_ball()
    write_nested()
    write_instanced()
    write_unsupported()


if __name__ == "__main__":
    main()
