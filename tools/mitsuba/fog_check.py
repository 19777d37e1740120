#!/usr/bin/env python3
"""Independent check of the CPU reference with a medium: Mitsuba 3 (volpath) against our
reference's non-caustic component on the same scene, as image energy (the sum over pixels
and channels) with standard errors.

Usage: python3 tools/mitsuba/fog_check.py [SCENE.json] [--spp 512] [--passes 8] [--ours ours.json]
         [--variant scalar_rgb] [--exr mitsuba.exr]

Why the non-caustic component: Mitsuba's volpath cannot find light from a delta light (spot,
point) through glass (no path hits a delta light, and next-event estimation stops at the
glass, as ours does), so it renders exactly what our reference calls non-caustic: every path
whose first interaction after the light is a diffuse surface or a scattering in the medium
(docs/scene-format.md). Our number comes from `cargo run --release -p caustics-reference
--example medium_energy SCENE SPP` (a JSON line; pass it with --ours, or this script runs it).

Mitsuba renders in `passes` independent passes (seeds 0..passes-1); the standard error of
the energy is the spread of the pass sums / sqrt(passes).
"""
import argparse
import json
import math
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import mitsuba as mi  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene", nargs="?", default="scenes/glass_sphere_fog.json")
    ap.add_argument("--spp", type=int, default=512)
    ap.add_argument("--passes", type=int, default=8)
    ap.add_argument("--variant", default="scalar_rgb")
    ap.add_argument("--seed0", type=int, default=0, help="first pass's seed (passes use seed0, seed0 + 1, ...)")
    ap.add_argument("--ours", help="the JSON line of examples/medium_energy.rs (else it is run)")
    ap.add_argument("--our-spp", type=int, default=256)
    ap.add_argument("--exr", help="write Mitsuba's mean image here")
    ap.add_argument("--mitsuba-json", help="reuse Mitsuba's numbers from an earlier --mitsuba-only run")
    ap.add_argument("--mitsuba-only", action="store_true", help="print Mitsuba's numbers and stop")
    a = ap.parse_args()
    mi.set_variant(a.variant)
    import convert
    import numpy as np

    if a.mitsuba_json:
        m = json.loads(open(a.mitsuba_json).read())
        mean, sd, secs = m["mitsuba_sum"], m["mitsuba_sd"], m["mitsuba_seconds"]
    else:
        per = a.spp // a.passes
        sums, acc = [], None
        t0 = time.time()
        for k in range(a.seed0, a.seed0 + a.passes):
            d = convert.scene_dict(a.scene, spp=per, seed=k)
            img = np.array(mi.render(mi.load_dict(d), seed=k), dtype=np.float64)
            sums.append(float(img.sum()))
            acc = img if acc is None else acc + img
        secs = time.time() - t0
        mean = sum(sums) / len(sums)
        sd = math.sqrt(sum((s - mean) ** 2 for s in sums) / (len(sums) - 1) / len(sums))
        if a.exr:
            mi.util.write_bitmap(a.exr, (acc / a.passes).astype(np.float32))
    if a.mitsuba_only:
        print(json.dumps({"scene": a.scene, "mitsuba_sum": mean, "mitsuba_sd": sd, "mitsuba_seconds": round(secs, 1),
                          "mitsuba_spp": a.spp, "mitsuba_passes": a.passes}))
        return
    if a.ours:
        ours = json.loads(open(a.ours).read())
    else:
        out = subprocess.run(
            ["cargo", "run", "--release", "-q", "-p", "caustics-reference", "--example", "medium_energy",
             a.scene, str(a.our_spp)], check=True, capture_output=True, text=True).stdout
        ours = json.loads(out.strip().splitlines()[-1])
    o, osd = ours["sum_nocaustic"], ours["sd_nocaustic"]
    diff = o / mean - 1.0
    comb = math.sqrt((osd / o) ** 2 + (sd / mean) ** 2)
    res = {
        "scene": a.scene, "mitsuba": mi.__version__, "variant": a.variant,
        "mitsuba_spp": a.spp, "mitsuba_passes": a.passes, "mitsuba_seconds": secs, "mitsuba_seed0": a.seed0,
        "mitsuba_sum": mean, "mitsuba_sd": sd,
        "ours_spp": ours["spp"], "ours_seconds": ours.get("seconds"),
        "ours_sum_nocaustic": o, "ours_sd": osd,
        "relative_difference": diff, "combined_relative_sd": comb,
        "within_2_percent": abs(diff) < 0.02, "sigmas": diff / comb if comb > 0 else None,
    }
    print(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
