#!/usr/bin/env python3
"""Our scene JSON (docs/scene-format.md, schema_version 1) -> a Mitsuba 3 scene dict.

Usage as a module:   import convert; d = convert.scene_dict("scenes/glass_sphere_fog.json", spp=64)
                     scene = mitsuba.load_dict(d)
Usage as a script:   python3 tools/mitsuba/convert.py SCENE.json   (prints the dict)

Tested with Mitsuba 3.9.1 (`pip install mitsuba`), variant `scalar_rgb` (on this project's
machine `llvm_ad_rgb` stops with an LLVM instruction-selection error). Set the variant before
calling `scene_dict` (it builds `mi.ScalarTransform4f`s). Checked (docs/benchmarks.md): the
glass ball in vacuum against our CPU reference's non-caustic image to 4e-5 in energy (camera,
spot, sphere, rectangle, dielectric, two-sided diffuse), the fog scenes within 0.3 %, and the
environment's orientation pixel by pixel on `glass_sphere_sky` (camera rays that see the sky,
rows 0-8 of a 48x48 image: energy ratio 0.9998). Every catalogue scene converts and renders;
meshes, cylinders, mirrors, conductors and directional lights are converted by the rules
below but not compared number for number.

What maps to what (every rule of docs/scene-format.md that decides agreement):
- camera: `perspective`, `fov_axis = "y"`, `look_at(position, look_at, up)`; box pixel filter
  (`rfilter = box`), `hdrfilm` in linear RGB.
- spot: `spot` with `cutoff_angle = cone_angle_deg` and `beam_width = falloff_start_deg`,
  intensity in W/sr. Mitsuba 3's falloff between beam_width and cutoff_angle is *not* checked
  here to be our linear-in-angle ramp; the scenes compared with it set
  `falloff_start_deg = cone_angle_deg` (no ramp), which both renderers read the same way.
- point: `point` (W/sr); directional: `directional` (W/m^2, `direction` = travel direction).
- environment: `envmap` with `scale`; our lookup is u = 0.5 + atan2(d.x, -d.z)/(2 pi), Mitsuba's
  u = atan2(v.x, -v.z)/(2 pi) with v = to_world^-1 d: the same map when
  to_world = rotate_y(rotate_y_deg - 180) (right-handed rotation about +Y).
- sphere, rectangle (`rectangle` is [-1, 1]^2 in z = 0: columns u*size0/2, v*size1/2, normal),
  cylinder (open tube, `p0`, `p1`), mesh (`obj`; `.obj.gz` is unzipped into a temporary file;
  transform = translate . rotate_y . scale; `face_normals` unless `smooth_normals`).
- diffuse, mirror, conductor: wrapped in `twosided` (ours are two-sided); mirror =
  `conductor` with `material = "none"` (reflectance 1) times `specular_reflectance`;
  dielectric: `dielectric` with `int_ior`, `ext_ior`.
- medium: `homogeneous` (sigma_t = sigma_s + sigma_a, albedo = sigma_s / sigma_t, per channel)
  or, with `density`, `heterogeneous` whose `sigma_t` is a `gridvolume` of the same `.vol`
  file over the box (`scale` = sigma_t: grey sigma_t only) and `albedo` = sigma_s / sigma_t;
  phase `isotropic` or `hg`. The box is a `cube` with a `null` BSDF and the medium inside; the
  camera and every object get the medium as exterior (our media fill the box outside
  dielectrics; an object reaching out of the box is treated as inside it, a documented
  approximation).
"""
import gzip
import json
import math
import os
import sys
import tempfile

import mitsuba as mi


def _v(a):
    return [float(x) for x in a]


def _rgb(x):
    if isinstance(x, (int, float)):
        return [float(x)] * 3
    return _v(x)


def _norm(a):
    n = math.sqrt(sum(x * x for x in a))
    return [x / n for x in a]


def _cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def _dot(a, b):
    return sum(x * y for x, y in zip(a, b))


def _rgb_dict(x):
    return {"type": "rgb", "value": _rgb(x)}


def _any_up(d):
    return [1.0, 0.0, 0.0] if abs(d[1]) > 0.9 else [0.0, 1.0, 0.0]


def _material(m):
    t = m["type"]
    if t == "diffuse":
        return {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": _rgb_dict(m["albedo"])}}
    if t == "dielectric":
        return {"type": "dielectric", "int_ior": float(m["ior"]), "ext_ior": float(m.get("ext_ior", 1.0))}
    if t == "mirror":
        return {"type": "twosided", "bsdf": {"type": "conductor", "material": "none",
                                             "specular_reflectance": _rgb_dict(m["reflectance"])}}
    if t == "conductor":
        return {"type": "twosided", "bsdf": {"type": "conductor", "eta": _rgb_dict(m["eta"]),
                                             "k": _rgb_dict(m["k"])}}
    raise ValueError(f"unknown material type {t}")


def _rect_frame(o):
    n = _norm(_v(o["normal"]))
    if "u_axis" in o:
        u0 = _norm(_v(o["u_axis"]))
    else:
        u0 = [0.0, 0.0, 1.0] if abs(_dot(n, [1.0, 0.0, 0.0])) > math.cos(math.radians(25.0)) else [1.0, 0.0, 0.0]
    u = [a - b * _dot(n, u0) for a, b in zip(u0, n)]
    u = _norm(u)
    return u, _cross(n, u), n


def _shape(o, base, tmp):
    t = o["type"]
    if t == "sphere":
        return {"type": "sphere", "center": _v(o["center"]), "radius": float(o["radius"])}
    if t == "rectangle":
        u, v, n = _rect_frame(o)
        su, sv = float(o["size"][0]) * 0.5, float(o["size"][1]) * 0.5
        c = _v(o["center"])
        m = [[u[0] * su, v[0] * sv, n[0], c[0]],
             [u[1] * su, v[1] * sv, n[1], c[1]],
             [u[2] * su, v[2] * sv, n[2], c[2]],
             [0.0, 0.0, 0.0, 1.0]]
        return {"type": "rectangle", "to_world": mi.ScalarTransform4f(m)}
    if t == "cylinder":
        p0 = _v(o["base_center"])
        a = _norm(_v(o["axis"]))
        h = float(o["height"])
        return {"type": "cylinder", "p0": p0, "p1": [p0[i] + a[i] * h for i in range(3)],
                "radius": float(o["radius"])}
    if t == "mesh":
        path = o["path"] if os.path.isabs(o["path"]) else os.path.join(base, o["path"])
        if path.endswith(".gz"):
            out = os.path.join(tmp, os.path.basename(path)[:-3])
            with gzip.open(path, "rb") as f, open(out, "wb") as g:
                g.write(f.read())
            path = out
        tr = o.get("transform", {})
        s = tr.get("scale", 1.0)
        s = [float(s)] * 3 if isinstance(s, (int, float)) else _v(s)
        T = mi.ScalarTransform4f
        to_world = (T().translate(_v(tr.get("translate", [0, 0, 0])))
                    @ T().rotate([0, 1, 0], float(tr.get("rotate_y_deg", 0.0)))
                    @ T().scale(s))
        return {"type": "obj", "filename": path, "to_world": to_world,
                "face_normals": not o.get("smooth_normals", True)}
    raise ValueError(f"unknown object type {t}")


def _light(l, base):
    t = l["type"]
    T = mi.ScalarTransform4f
    if t == "spot":
        p = _v(l["position"])
        d = _norm(_v(l["direction"]))
        cone = float(l["cone_angle_deg"])
        start = float(l.get("falloff_start_deg", 0.75 * cone))
        return {"type": "spot", "to_world": T().look_at(origin=p, target=[p[i] + d[i] for i in range(3)], up=_any_up(d)),
                "intensity": _rgb_dict(l["intensity"]), "cutoff_angle": cone, "beam_width": start}
    if t == "point":
        return {"type": "point", "position": _v(l["position"]), "intensity": _rgb_dict(l["intensity"])}
    if t == "directional":
        return {"type": "directional", "direction": _norm(_v(l["direction"])), "irradiance": _rgb_dict(l["irradiance"])}
    if t == "environment":
        path = l["path"] if os.path.isabs(l["path"]) else os.path.join(base, l["path"])
        scale = l.get("scale", 1.0)
        if not isinstance(scale, (int, float)):
            if len(set(scale)) != 1:
                raise ValueError("environment: an RGB scale is not converted (Mitsuba's envmap scale is a number)")
            scale = scale[0]
        return {"type": "envmap", "filename": path, "scale": float(scale),
                "to_world": T().rotate([0, 1, 0], float(l.get("rotate_y_deg", 0.0)) - 180.0)}
    raise ValueError(f"unknown light type {t}")


def _medium(m, base):
    ss, sa = _rgb(m["sigma_s"]), _rgb(m["sigma_a"])
    st = [a + b for a, b in zip(ss, sa)]
    albedo = [s / t if t > 0 else 0.0 for s, t in zip(ss, st)]
    ph = m.get("phase", {"type": "isotropic"})
    phase = {"type": "isotropic"} if ph["type"] == "isotropic" else {"type": "hg", "g": float(ph["g"])}
    lo, hi = _v(m["bounds"]["min"]), _v(m["bounds"]["max"])
    if "density" not in m:
        return {"type": "homogeneous", "sigma_t": _rgb_dict(st), "albedo": _rgb_dict(albedo), "scale": 1.0,
                "phase": phase}
    if max(st) - min(st) > 1e-6 * max(st):
        raise ValueError("medium.density: Mitsuba's gridvolume scales by one number; sigma_t must be grey")
    path = m["density"]["path"]
    path = path if os.path.isabs(path) else os.path.join(base, path)
    T = mi.ScalarTransform4f
    box = T().translate(lo) @ T().scale([hi[i] - lo[i] for i in range(3)])
    return {"type": "heterogeneous",
            "sigma_t": {"type": "gridvolume", "filename": path, "to_world": box,
                        "filter_type": "trilinear", "wrap_mode": "clamp"},
            "scale": float(st[0]), "albedo": _rgb_dict(albedo), "phase": phase}


def scene_dict(path, spp=64, integrator=None, seed=0, tmpdir=None):
    """The Mitsuba scene dict of our scene file `path` (spp: sensor samples per pixel)."""
    with open(path) as f:
        s = json.load(f)
    if s.get("schema_version") != 1:
        raise ValueError(f"{path}: schema_version must be 1")
    base = os.path.dirname(os.path.abspath(path))
    tmp = tmpdir or tempfile.mkdtemp(prefix="caustics-mitsuba-")
    c = s["camera"]
    T = mi.ScalarTransform4f
    d = {"type": "scene"}
    d["integrator"] = integrator or {"type": "volpath" if "medium" in s else "path", "max_depth": 64}
    sensor = {
        "type": "perspective", "fov": float(c["fov_y_deg"]), "fov_axis": "y",
        "to_world": T().look_at(origin=_v(c["position"]), target=_v(c["look_at"]), up=_v(c.get("up", [0, 1, 0]))),
        "film": {"type": "hdrfilm", "width": int(c["width"]), "height": int(c["height"]),
                 "rfilter": {"type": "box"}, "pixel_format": "rgb"},
        "sampler": {"type": "independent", "sample_count": int(spp), "seed": int(seed)},
    }
    medium = None
    if "medium" in s:
        medium = _medium(s["medium"], base)
        d["fog"] = medium
        sensor["medium"] = {"type": "ref", "id": "fog"}
        lo, hi = _v(s["medium"]["bounds"]["min"]), _v(s["medium"]["bounds"]["max"])
        ctr = [(a + b) * 0.5 for a, b in zip(lo, hi)]
        half = [(b - a) * 0.5 for a, b in zip(lo, hi)]
        d["medium_box"] = {"type": "cube", "to_world": T().translate(ctr) @ T().scale(half),
                           "bsdf": {"type": "null"}, "interior": {"type": "ref", "id": "fog"}}
    d["sensor"] = sensor
    for i, l in enumerate(s["lights"]):
        d[f"light_{i}"] = _light(l, base)
    for name, m in s["materials"].items():
        d[f"mat_{name}"] = _material(m)
    for i, o in enumerate(s["objects"]):
        sh = _shape(o, base, tmp)
        sh["bsdf"] = {"type": "ref", "id": f"mat_{o['material']}"}
        if medium is not None:
            sh["exterior"] = {"type": "ref", "id": "fog"}
        d[f"object_{i}"] = sh
    return d


if __name__ == "__main__":
    mi.set_variant("scalar_rgb")
    for p in sys.argv[1:]:
        print(scene_dict(p))
