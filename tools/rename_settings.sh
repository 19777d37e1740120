#!/usr/bin/env bash
# Rename the uses of `RenderSettings` fields to their sections (settings in sections, issue 40):
# `s.medium_steps` -> `s.medium.steps`, `s.photons` -> `s.photons.count`, ... Idempotent: run it
# again after merging a branch that still uses the flat names. Usage:
#   tools/rename_settings.sh [FILE...]     (default: every .rs file under crates/caustics/src)
# Literals: tools/rename_settings_literals.py FILE... (before this script).
# Names that other structs share (photons, technique, tracer, splat, max_depth) are renamed only
# with the receivers that hold settings in each file; the compiler finds any left over.
set -euo pipefail
cd "$(dirname "$0")/.."
if [ $# -eq 0 ]; then
    mapfile -t files < <(find crates/caustics/src -name '*.rs' -not -path '*/settings/*' | sort)
else
    files=("$@")
fi

# Field names no other struct uses: renamed with any receiver. `(?<!sec)` keeps a second run
# from renaming again where the new name ends like the old one.
perl -pi -e '
    s/\.first_hit_from_buffer\b/.testing.first_hit_from_buffer/g unless /testing\.first_hit_from_buffer/;
    s/\.error_skip_hopeless\b/.testing.error_skip_hopeless/g unless /testing\.error_skip_hopeless/;
    s/\.light_second_layer\b/.testing.light_second_layer/g unless /testing\.light_second_layer/;
    s/\.shading_tiles\b/.testing.shading_tiles/g unless /testing\.shading_tiles/;
    s/\.max_error_tolerance\b/.adaptive.error_tolerance/g;
    s/\.error_check_grid\b/.adaptive.check_grid/g;
    s/(?<!adaptive)\.quad_linearity\b/.adaptive.quad_linearity/g;
    s/(?<!adaptive)(?<!plan)\.base_grid\b/.adaptive.base_grid/g;
    s/(?<!photons)\.caustic_map_size\b/.photons.caustic_map_size/g;
    s/(?<!shading)\.shadow_map_size\b/.shading.shadow_map_size/g;
    s/(?<!photons)\.splat_sigma\b/.photons.splat_sigma/g;
    s/\.dielectric_reflection\b/.photons.reflection/g;
    s/(?<!photons)\.internal_reflection\b/.photons.internal_reflection/g;
    s/\.residual_branches\b/.photons.residual/g;
    s/\.photon_memory\b/.photons.memory/g;
    s/(?<!shading)\.tessellation\b/.shading.tessellation/g;
    s/(?<!shading)\.spill_faces\b/.shading.spill_faces/g;
    s/\.medium_steps\b/.medium.steps/g;
    s/\.medium_light_steps\b/.medium.light_steps/g;
    s/\.medium_bounce_grid\b/.medium.bounce_grid/g;
    s/\.medium_bounce_steps\b/.medium.bounce_steps/g;
    s/\.medium_beyond_specular\b/.medium.beyond_specular/g;
    s/(?:(?<=settings)|(?<=settings\(\))|(?<=\bs))\.env_lights\b/.environment.lights/g;
    s/(?:(?<=settings)|(?<=settings\(\))|(?<=\bs))\.env_split\b/.environment.split/g;
    s/(?:(?<=settings)|(?<=settings\(\))|(?<=\bs))\.env_taps\b/.environment.taps/g;
    # Error messages name the field by its path.
    s/cl\("photons",/cl("photons.count",/g;
    s/cl\("base_grid",/cl("adaptive.base_grid",/g;
    s/cl\("photon_memory",/cl("photons.memory",/g;
    s/raise BeamSettings::capacity, --beam-capacity/raise beams.capacity/g;
' "${files[@]}"

# The shared names, per file, with the receivers that hold `RenderSettings` there.
SETTINGS_RECV='(?:\bs|\bsettings|self\.settings|e\.settings|dc\.settings|ec\.settings)'
for f in "${files[@]}"; do
    case "$f" in
        */caustic_spheres/*|*/accel.rs|*/splat.rs|*/output.rs|*/scene/*) continue ;;
    esac
    recv="$SETTINGS_RECV"
    # Statistics are `s` in the techniques' read-back: only the settings' receivers there.
    case "$f" in
        */techniques/mod.rs) recv='(?:\bs(?=\.(?:technique, s\.splat\)|splat\)|tracer\b|max_depth\b))|e\.settings|self\.settings)' ;;
        */budget.rs) recv='(?:\bsettings(?=\.technique)|\bs(?=\.(?:photons|technique)\b))' ;;
    esac
    RECV="$recv" perl -pi -e '
        my $r = $ENV{RECV};
        s/(?<!\.\.)($r)\.photons\b(?!\.(?:count|technique|tracer|max_depth|splat|splat_sigma|caustic_map_size|memory|reflection|internal_reflection|residual)\b)/$1.photons.count/g;
        s/($r)\.technique\b/$1.photons.technique/g;
        s/($r)\.tracer\b/$1.photons.tracer/g;
        s/($r)\.splat\b(?!_)/$1.photons.splat/g;
        s/($r)\.max_depth\b/$1.photons.max_depth/g;
    ' "$f"
done

# Struct literals with the flat names (`RenderSettings { photons: 256, .. }`) are rewritten into
# sections by tools/rename_settings_literals.py (only tests, examples and the command line have
# them). The new lines can be long: format.
cargo fmt --all
