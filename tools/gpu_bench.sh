#!/usr/bin/env bash
# The GPU checks and benchmarks that docs/benchmarks.md records, in order of priority, each
# under a time limit and all under one deadline, for a machine with a real GPU and little time
# on it (build the binary elsewhere and bring it along).
#
#   tools/gpu_bench.sh [CAUSTICS_BINARY] [OUT_DIR] [DEADLINE_SECONDS] [ADAPTER]
#
# Defaults: target/release/caustics, ./gpu_bench, 420 s, the first adapter. Writes OUT_DIR/log.txt
# (everything printed), the bench tables (markdown and JSON) in one folder per run, and the EXRs
# of the correctness renders; `tar czf` the folder to carry it back.
#
# 1. the volume-caustic scene first (beams; every pipeline build named and timed by
#    CAUSTICS_LOG_PIPELINES, so a driver whose compiler stalls names its stage), twice: the
#    same image bit for bit; then the built-in scene twice;
# 2. the beams at 1920x1080 for the grids of the budgets (frame loop: full and camera;
#    the beams alone: the floor's glow off), the lit floor's glow on and off, the medium beyond
#    glass off, and the fog scene's frame loop;
# 3. the frame loop of the built-in scene at 1920x1080;
# 4. the photon emission techniques (Table 1 of Wyman & Nichols 2009) up to 16384^2;
# 5. the CPU reference on this machine's cores.
set -u
B=${1:-target/release/caustics}
OUT=${2:-gpu_bench}
DEADLINE=${3:-420}
A=()
[ -n "${4:-}" ] && A=(--adapter "$4")
mkdir -p "$OUT"
exec > >(tee "$OUT/log.txt") 2>&1
log() { echo "=== $(date +%T) (${SECONDS}s) $*"; }
# run LIMIT CMD...: CMD under LIMIT seconds, or not at all once the deadline is near.
run() {
    local t=$1
    shift
    if [ $((SECONDS + 10)) -gt "$DEADLINE" ]; then
        log "SKIPPED (deadline) $*"
        return
    fi
    [ $((SECONDS + t)) -gt "$DEADLINE" ] && t=$((DEADLINE - SECONDS))
    log "$*"
    timeout "$t" "$@" 2>&1 | grep -v '^\s*$' | tail -n 80
    echo "rc=${PIPESTATUS[0]}"
}
same() {
    if cmp -s "$1" "$2"; then echo "SAME BITS: $1 $2"; else echo "DIFFERENT: $1 $2"; return 1; fi
}
command -v nvidia-smi >/dev/null && nvidia-smi -L
"$B" info 2>&1 | head -30

log "1. correctness and determinism"
export CAUSTICS_LOG_PIPELINES=1
run 90 "$B" render scenes/volume_caustic_fog.json "${A[@]}" -o "$OUT/fog.exr" --caustic-output "$OUT/fog_c.exr"
unset CAUSTICS_LOG_PIPELINES
run 60 "$B" render scenes/volume_caustic_fog.json "${A[@]}" -o "$OUT/fog_2.exr"
same "$OUT/fog.exr" "$OUT/fog_2.exr" && rm -f "$OUT/fog_2.exr"
run 60 "$B" render "${A[@]}" -o "$OUT/glass_sphere.exr"
run 60 "$B" render "${A[@]}" -o "$OUT/glass_sphere_2.exr"
same "$OUT/glass_sphere.exr" "$OUT/glass_sphere_2.exr" && rm -f "$OUT/glass_sphere_2.exr"

log "2. beams at 1920x1080 (grid levels linearity)"
for cfg in "16 3 0.05" "64 0 0.05" "16 2 0.05" "16 2 0.03" "24 1 0.05" "32 0 0.05" "128 0 0.05" "16 3 0.03"; do
    set -- $cfg
    run 60 "$B" bench --frames 12 scenes/volume_caustic_fog.json "${A[@]}" --technique basic --photons 1024 \
        --size 1920x1080 --phases full,camera --beam-grid "$1" --beam-levels "$2" \
        --set beams.linearity_threshold="$3" --set medium.bounce_grid=0 --out "$OUT/beams_$1_$2_$3"
done
run 40 "$B" render scenes/volume_caustic_fog.json "${A[@]}" --size 1920x1080 -o "$OUT/fog_1080.png"
# The lit floor's glow (medium_bounce_* passes: GPU ms per pass in the render's table), on and off.
run 40 "$B" render scenes/glass_sphere_fog.json "${A[@]}" --size 1920x1080 -o "$OUT/sphere_fog_1080.png"
run 40 "$B" render scenes/glass_sphere_fog.json "${A[@]}" --size 1920x1080 --set medium.bounce_grid=0 -o "$OUT/sphere_fog_1080_noglow.png"
# The medium beyond glass (`medium_*_segments`, `beam_gather_segments` in the table), off.
run 40 "$B" render scenes/glass_sphere_fog.json "${A[@]}" --size 1920x1080 --set medium.beyond_specular=false -o "$OUT/sphere_fog_1080_nobeyond.png"
# The frame loop of the fog scene with everything on (camera-only frames keep the lights' VPLs).
run 60 "$B" bench --frames 12 scenes/glass_sphere_fog.json "${A[@]}" --technique basic --photons 1024 \
    --size 1920x1080 --phases full,camera --out "$OUT/sphere_fog_loop"

# The animated pool (issue 41, item 6): its waves every frame at 1920x1080 (BVH refit per pass),
# from above and from under water (target: under 16 ms a frame).
run 60 "$B" bench --frames 20 scenes/pool_sun.json "${A[@]}" --technique basic --photons 1024 \
    --size 1920x1080 --phases camera,mesh --out "$OUT/pool_sun_loop"
run 60 "$B" bench --frames 20 scenes/pool_sun_under.json "${A[@]}" --technique basic --photons 1024 \
    --size 1920x1080 --phases camera,mesh --out "$OUT/pool_sun_under_loop"
# Light that bounces (issue 44): the Cornell room with and without the interreflection cache
# (targets: at most 2x the first-hit frame; camera-only frames at least 10x cheaper).
run 60 "$B" bench --frames 12 scenes/cornell_glass.json "${A[@]}" --technique basic --photons 1024 \
    --size 1920x1080 --phases full,camera,light --out "$OUT/cornell_first_hit"
run 60 "$B" bench --frames 12 scenes/cornell_glass.json "${A[@]}" --technique basic --photons 1024 \
    --size 1920x1080 --phases full,camera,light --set indirect.photons=262144 --out "$OUT/cornell_indirect"
run 60 "$B" bench --frames 12 scenes/cornell_glass.json "${A[@]}" --technique basic --photons 1024 \
    --size 1920x1080 --phases light --set indirect.photons=65536 --set indirect.history=8 \
    --out "$OUT/cornell_indirect_progressive"

log "3. frame loop, built-in scene, 1920x1080"
run 90 "$B" bench --frames 20 "${A[@]}" --technique basic,adaptive-level --photons 1024,2048 --size 1920x1080 \
    --out "$OUT/frameloop"

log "4. photon emission techniques"
run 120 "$B" bench "${A[@]}" --photons 256..16384 --repeat 3 --out "$OUT/photons_sphere"
run 90 "$B" bench scenes/glass_dragon.json "${A[@]}" --photons 1024..8192 --repeat 3 --out "$OUT/photons_dragon"

log "5. CPU reference"
nproc
run 60 "$B" bench --technique none --cpu-photons 134217728 --out "$OUT/cpu"
log "done"
