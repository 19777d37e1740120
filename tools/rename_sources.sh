#!/usr/bin/env bash
# Choices as data (issue 40): `photons.technique` -> `photons.emission` (Technique's four photon
# variants -> Emission), `Technique::CausticSpheres` -> `sources.distant = spheres`,
# `surface_caustics` -> `sources.local` (SurfaceCaustics -> LocalSource), `beams.enabled` ->
# `sources.volume`. Idempotent: run it again on a branch that still uses the old names, then let
# the compiler find what is left (imports, struct literals). Usage: tools/rename_sources.sh [FILE...]
set -euo pipefail
cd "$(dirname "$0")/.."
if [ $# -eq 0 ]; then
    mapfile -t files < <(find crates -name '*.rs' -not -path '*/src/settings/*' | sort)
else
    files=("$@")
fi
perl -pi -e '
    s/([\w.\[\]()]+)\.photons\.technique\s*==\s*(?:crate::settings::|caustics::settings::|caustics::render::)?Technique::CausticSpheres/$1.caustic_spheres()/g;
    s/([\w.\[\]()]+)\.photons\.technique\s*!=\s*(?:crate::settings::|caustics::settings::|caustics::render::)?Technique::CausticSpheres/!$1.caustic_spheres()/g;
    s/\.photons\.technique\s*=\s*(?:crate::settings::|caustics::settings::|caustics::render::)?Technique::CausticSpheres/.sources.distant = caustics::settings::DistantSource::Spheres/g;
    s/\bTechnique::(Basic|Hierarchical|AdaptiveLevel|AdaptiveError)\b/Emission::$1/g;
    s/\.photons\.technique\b/.photons.emission/g;
    s/\.photons\.emission\.emission\(\)/.photons.emission/g;
    s/\bSurfaceCaustics::/LocalSource::/g;
    s/\bSurfaceCaustics\b/LocalSource/g;
    s/\.surface_caustics\b(?!_)/.sources.local/g;
    s/\.beams\.enabled\s*=\s*false/.sources.volume = caustics::settings::VolumeSource::None/g;
    s/\.beams\.enabled\s*=\s*true/.sources.volume = caustics::settings::VolumeSource::Beams/g;
    s/--set surface_caustics=beams/--set sources.local=beams/g;
    s/photons\.(?:technique|emission)=caustic-spheres/sources.distant=spheres/g;
    s/photons\.technique=/photons.emission=/g;
    s/surface_caustics: ((?:caustics::(?:settings|render)::)?LocalSource::Beams|sc|surface),/sources: caustics::settings::SourceSettings { local: $1, ..Default::default() },/;
    s/RenderSettings \{ surface_caustics: LocalSource::Beams,/RenderSettings { sources: caustics::settings::SourceSettings { local: LocalSource::Beams, ..Default::default() },/;
    s/\{ beams: BeamSettings \{ enabled: false, \.\.s\.beams \}, \.\.s\.clone\(\)/{ sources: caustics::settings::SourceSettings { volume: caustics::settings::VolumeSource::None, ..s.sources }, ..s.clone()/;
    s/PhotonSettings \{ technique: t,/PhotonSettings { emission: t,/;
    s/PhotonSettings \{ technique,/PhotonSettings { emission: technique,/;
    s/^(\s+)technique: (Emission::\w+|t|technique),$/$1emission: $2,/;
' "${files[@]}"
# Inside the library the crate is `crate`.
perl -pi -e 's/caustics::settings::(DistantSource|VolumeSource)/crate::settings::$1/g' $(printf '%s\n' "${files[@]}" | grep '^crates/caustics/src/' || true) 2>/dev/null || true
