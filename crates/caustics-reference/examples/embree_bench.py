#!/usr/bin/env python3
"""Shoot the rays of `bvh_bench` (examples/bvh_bench.rs) with Embree, on one core, and compare.

Not part of CI. Needs `embreex` (Embree 4's Python binding) and numpy, e.g.

    python3 -m venv /tmp/embvenv && /tmp/embvenv/bin/pip install embreex numpy
    taskset -c 0 target/release/examples/bvh_bench [mesh] [rays] /tmp/bvh_bench.bin
    taskset -c 0 /tmp/embvenv/bin/python crates/caustics-reference/examples/embree_bench.py /tmp/bvh_bench.bin

One core: embreex shoots its rays one at a time in a plain loop (rtcIntersect1 / rtcOccluded1),
so traversal is single threaded whatever the machine; Embree's scene build runs on TBB's
threads, which `taskset -c 0` confines to one core. The rays are timed through `scene.run`,
which includes embreex's per-ray copy in and out of numpy (a small overhead, counted against
Embree). Closest-hit rays have tfar = inf; occlusion rays tfar = the file's tmax.
"""

import json
import struct
import sys
import time

import numpy as np
from embreex import rtcore as rtc
from embreex import rtcore_scene as rtcs
from embreex.mesh_construction import TriangleMesh


def main():
    path = sys.argv[1] if len(sys.argv) > 1 else "/tmp/bvh_bench.bin"
    reps = int(sys.argv[2]) if len(sys.argv) > 2 else 5
    data = open(path, "rb").read()
    assert data[:4] == b"CBVH", "not a bvh_bench file"
    ntri, nray = struct.unpack_from("<II", data, 4)
    off = 12
    tris = np.frombuffer(data, np.float32, ntri * 9, off).reshape(ntri, 3, 3)
    off += ntri * 36
    rays = np.frombuffer(data, np.float32, nray * 7, off).reshape(nray, 7)
    off += nray * 28
    ours_t = np.frombuffer(data, np.float32, nray, off)
    off += nray * 4
    ours_occ = np.frombuffer(data, np.uint8, nray, off).astype(bool)
    off += nray
    ours = json.loads(data[off:].decode())

    org = np.ascontiguousarray(rays[:, 0:3])
    dirs = np.ascontiguousarray(rays[:, 3:6])
    tmax = np.ascontiguousarray(rays[:, 6])

    def timed(f):
        """(result, wall s, on-CPU s of this thread): on a shared machine the second leaves
        out the time other processes hold the core (bvh_bench reports the same two)."""
        w, c = time.perf_counter(), time.thread_time()
        r = f()
        return r, time.perf_counter() - w, time.thread_time() - c

    def build():
        device = rtc.EmbreeDevice()
        scene = rtcs.EmbreeScene(device)
        TriangleMesh(scene, np.ascontiguousarray(tris))
        # embreex commits on the first query: shoot one ray to include the build.
        scene.run(org[:1], dirs[:1])
        return scene

    builds = [timed(build) for _ in range(reps)]
    scene = builds[-1][0]
    build_ms = float(np.median([b[1] for b in builds])) * 1e3
    build_cpu_ms = float(np.median([b[2] for b in builds])) * 1e3

    cl = [timed(lambda: scene.run(org, dirs, output=1)) for _ in range(reps)]
    oc = [timed(lambda: scene.run(org, dirs, dists=tmax.copy(), query="OCCLUDED")) for _ in range(reps)]
    res, occ = cl[-1][0], oc[-1][0]
    closest = nray / float(np.median([c[1] for c in cl])) * 1e-6
    closest_cpu = nray / float(np.median([c[2] for c in cl])) * 1e-6
    occluded = nray / float(np.median([c[1] for c in oc])) * 1e-6
    occluded_cpu = nray / float(np.median([c[2] for c in oc])) * 1e-6

    hit = res["geomID"] != -1
    et = np.where(hit, res["tfar"], np.inf).astype(np.float32)
    both = np.isfinite(et) & np.isfinite(ours_t)
    same_hit = np.count_nonzero(np.isfinite(et) == np.isfinite(ours_t))
    rel = np.abs(et[both] - ours_t[both]) / np.maximum(et[both], 1e-30)
    agree = np.count_nonzero(np.isfinite(et) == np.isfinite(ours_t)) - np.count_nonzero(both) + np.count_nonzero(rel < 1e-4)
    e_occ = np.asarray(occ) != -1 if np.asarray(occ).dtype != bool else np.asarray(occ)
    # embreex returns, for OCCLUDED, the geometry id (-1: not occluded) or a bool per version.
    print(f"embree: {ntri} triangles, {nray} rays, {reps} reps (medians), one core")
    print(f"embree build {build_ms:7.1f} ms ({build_cpu_ms:6.1f} on-CPU)  closest {closest:5.3f} Mrays/s"
          f" ({closest_cpu:5.3f} on-CPU)  occluded {occluded:5.3f} ({occluded_cpu:5.3f} on-CPU)")
    print(f"hit/miss agree: {same_hit}/{nray}; closest t within 1e-4 relative (or both miss): {agree}/{nray}"
          f" ({agree / nray:.5f}); occlusion agrees: {np.count_nonzero(e_occ == ours_occ)}/{nray}")
    if both.any():
        print(f"  max relative t difference on common hits: {rel.max():.3e}")
    print("ours / embree (wall; on-CPU):")
    for name, r in ours.items():
        print(f"  {name:24} build time {r['build_ms'] / build_ms:5.2f}x; {r['build_cpu_ms'] / build_cpu_ms:5.2f}x"
              f"  closest {r['closest_mrays'] / closest:5.3f}x; {r['closest_cpu_mrays'] / closest_cpu:5.3f}x"
              f"  occluded {r['occluded_mrays'] / occluded:5.3f}x; {r['occluded_cpu_mrays'] / occluded_cpu:5.3f}x")


if __name__ == "__main__":
    main()
