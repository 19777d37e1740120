#!/usr/bin/env python3
"""A closed water body with a wavy top, written as OBJ (metres, +Y up, normals facing out).

The top is a heightfield of Gerstner waves (Tessendorf 2001, "Simulating Ocean Water", eq. 9:
each wave moves the surface points horizontally as well as up); the sides and the bottom close
it into a watertight box, so the body is a valid dielectric (docs/scene-format.md: closed, normals
out). `--time T` gives the surface at time T (seconds), for animated frames.

    python3 tools/make_pool.py --size 2 2 --depth 0.42 --bottom -0.02 --grid 64 -o scenes/meshes/pool_water.obj
"""
import argparse
import math

# (amplitude m, wavelength m, direction deg, steepness 0..1, phase rad): a calm pool's few
# crossing wind waves.
WAVES = [
    (0.012, 0.9, 20.0, 0.6, 0.0),
    (0.008, 0.55, 75.0, 0.5, 1.3),
    (0.006, 0.37, -40.0, 0.5, 2.1),
    (0.004, 0.23, 130.0, 0.4, 0.7),
]
G = 9.81


def gerstner(x, z, t):
    """Displaced point of the rest point (x, z): (dx, y, dz)."""
    dx = dy = dz = 0.0
    for a, lam, deg, q, ph in WAVES:
        k = 2.0 * math.pi / lam
        w = math.sqrt(G * k)
        kx, kz = math.cos(math.radians(deg)), math.sin(math.radians(deg))
        th = k * (kx * x + kz * z) - w * t + ph
        qa = q / (k * a * len(WAVES)) * a  # steepness shared between the waves (no loops)
        dx += qa * kx * math.cos(th)
        dz += qa * kz * math.cos(th)
        dy += a * math.sin(th)
    return dx, dy, dz


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--size", type=float, nargs=2, default=[2.0, 2.0], help="extent in x and z (m)")
    ap.add_argument("--depth", type=float, default=0.42, help="rest height of the surface (m)")
    ap.add_argument("--bottom", type=float, default=-0.02, help="height of the bottom face (m)")
    ap.add_argument("--grid", type=int, default=64, help="quads per side of the surface")
    ap.add_argument("--time", type=float, default=0.0, help="time of the waves (s)")
    ap.add_argument("-o", "--output", required=True)
    a = ap.parse_args()
    sx, sz = a.size[0] / 2.0, a.size[1] / 2.0
    n = a.grid
    v = []
    # The surface: rest grid points displaced; the border points stay on the box's sides
    # (horizontal displacement across a side is removed) so the body stays closed.
    for j in range(n + 1):
        for i in range(n + 1):
            x = -sx + 2.0 * sx * i / n
            z = -sz + 2.0 * sz * j / n
            dx, dy, dz = gerstner(x, z, a.time)
            if i in (0, n):
                dx = 0.0
            if j in (0, n):
                dz = 0.0
            v.append((x + dx, a.depth + dy, z + dz))
    f = []
    idx = lambda i, j: j * (n + 1) + i + 1
    for j in range(n):
        for i in range(n):
            # counter-clockwise seen from above (+Y)
            f.append((idx(i, j), idx(i, j + 1), idx(i + 1, j + 1)))
            f.append((idx(i, j), idx(i + 1, j + 1), idx(i + 1, j)))
    # Bottom points under the border, in the same order as the border walk.
    border = [(i, 0) for i in range(n)] + [(n, j) for j in range(n)] + \
             [(i, n) for i in range(n, 0, -1)] + [(0, j) for j in range(n, 0, -1)]
    base = len(v) + 1
    for i, j in border:
        x, _, z = v[idx(i, j) - 1]
        v.append((x, a.bottom, z))
    m = len(border)
    for k in range(m):
        i0, j0 = border[k]
        i1, j1 = border[(k + 1) % m]
        t0, t1 = idx(i0, j0), idx(i1, j1)
        b0, b1 = base + k, base + (k + 1) % m
        # The walk goes +x along z = -sz, so the wall faces -z: outward when wound t0, t1, b1.
        f.append((t0, t1, b1))
        f.append((t0, b1, b0))
    # The bottom: a fan from its centre, facing -Y.
    v.append((0.0, a.bottom, 0.0))
    c = len(v)
    for k in range(m):
        f.append((c, base + k, base + (k + 1) % m))
    with open(a.output, "w") as out:
        out.write(f"# tools/make_pool.py --size {a.size[0]} {a.size[1]} --depth {a.depth} "
                  f"--bottom {a.bottom} --grid {n} --time {a.time}\n")
        for p in v:
            out.write("v %.6f %.6f %.6f\n" % p)
        for t in f:
            out.write("f %d %d %d\n" % t)


if __name__ == "__main__":
    main()
