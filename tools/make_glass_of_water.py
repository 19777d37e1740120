#!/usr/bin/env python3
"""Writes the meshes of scenes/glass_of_water.json: a glass tumbler holding water, as three
open meshes, one per interface, each triangle's normal pointing out of the medium of its
material's `ior` into the medium of its `ext_ior`:

- glass_of_water_glass.obj: glass against air (outer wall, bottom, rim, inner wall above the
  water), material `glass` (ior 1.5, ext_ior 1);
- glass_of_water_inner.obj: glass against water (inner wall below the water line, the inner
  bottom), material `glass_in_water` (ior 1.5, ext_ior 1.33);
- glass_of_water_top.obj: water against air (the water's flat surface), material `water`
  (ior 1.33, ext_ior 1).

Units: metres; the glass stands on y = 0 (its bottom 0.5 mm above it). Rerun:
python3 tools/make_glass_of_water.py
"""
import math, os

R_OUT, R_IN = 0.040, 0.036
Y0, Y_BOTTOM, Y_WATER, Y_TOP = 0.0005, 0.008, 0.080, 0.110
SEG = 96


def ring(r, y):
    return [(r * math.cos(2 * math.pi * k / SEG), y, r * math.sin(2 * math.pi * k / SEG)) for k in range(SEG)]


class Mesh:
    def __init__(self):
        self.v, self.f = [], []

    def add(self, pts):
        base = len(self.v)
        self.v += pts
        return base

    def quad_band(self, lo, hi, outward):
        """Quads between two rings; normals away from the axis when `outward`."""
        a, b = self.add(lo), self.add(hi)
        for k in range(SEG):
            k1 = (k + 1) % SEG
            t1, t2 = (a + k, b + k, b + k1), (a + k, b + k1, a + k1)
            if not outward:
                t1, t2 = t1[::-1], t2[::-1]
            self.f += [t1, t2]

    def disk(self, r, y, up, r_in=None):
        """A disk (or annulus from r_in) at height y, normal +y when `up`."""
        outer = self.add(ring(r, y))
        if r_in is None:
            c = self.add([(0.0, y, 0.0)])
            for k in range(SEG):
                t = (c, outer + (k + 1) % SEG, outer + k)
                self.f.append(t if up else t[::-1])
        else:
            inner = self.add(ring(r_in, y))
            for k in range(SEG):
                k1 = (k + 1) % SEG
                for t in ((inner + k, outer + k1, outer + k), (inner + k, inner + k1, outer + k1)):
                    self.f.append(t if up else t[::-1])

    def write(self, path, note):
        with open(path, "w") as f:
            f.write(f"# {note} (tools/make_glass_of_water.py)\n")
            for x, y, z in self.v:
                f.write(f"v {x:.6f} {y:.6f} {z:.6f}\n")
            for t in self.f:
                f.write("f %d %d %d\n" % tuple(i + 1 for i in t))


here = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenes", "meshes")
glass = Mesh()
glass.quad_band(ring(R_OUT, Y0), ring(R_OUT, Y_TOP), outward=True)     # outer wall
glass.disk(R_OUT, Y0, up=False)                                          # outer bottom
glass.disk(R_OUT, Y_TOP, up=True, r_in=R_IN)                             # rim
glass.quad_band(ring(R_IN, Y_WATER), ring(R_IN, Y_TOP), outward=False)  # inner wall, air
glass.write(os.path.join(here, "glass_of_water_glass.obj"), "glass against air")
inner = Mesh()
inner.quad_band(ring(R_IN, Y_BOTTOM), ring(R_IN, Y_WATER), outward=False)  # inner wall, water
inner.disk(R_IN, Y_BOTTOM, up=True)                                          # inner bottom
inner.write(os.path.join(here, "glass_of_water_inner.obj"), "glass against water")
top = Mesh()
top.disk(R_IN, Y_WATER, up=True)
top.write(os.path.join(here, "glass_of_water_top.obj"), "water against air")
