#!/usr/bin/env bash
# Compressed glTF made by the tools people use (npm's gltfpack and gltf-transform, and
# Basis Universal's encoder through PyPI's alktx2), to check capture's decoders against
# the encoders' own.
#
#   scripts/make-compressed-fixtures.sh
#       rewrites capture/tests/fixtures/wavy_grid-{draco,meshopt,meshopt-filters,etc1s,uastc}.glb
#       from the test suite's wavy grid (capture/tests/compressed.rs tests them), and
#       wavy_grid-{etc1s,uastc}.png, Basis Universal's own decode of their texture;
#   scripts/make-compressed-fixtures.sh --scene SCENE.glb...
#       makes the same five variants of each scene in a temporary folder and prints how
#       their captured triangles and texels compare with the scene's own.
#
# Needs Node.js, npm and python3 (the tools are installed into a temporary folder).
set -euo pipefail
cd "$(dirname "$0")/.."
tools=$(mktemp -d)
trap 'rm -rf "$tools"' EXIT
(cd "$tools" && npm install --silent --no-audit --no-fund gltfpack@1.3.0 @gltf-transform/cli@4.5.1 >/dev/null)
python3 -m venv "$tools/py" && "$tools/py/bin/pip" install -q alktx2==0.1.7
gltfpack=$tools/node_modules/.bin/gltfpack
transform=$tools/node_modules/.bin/gltf-transform

# variants SOURCE OUT_PREFIX: Draco (gltf-transform, Google's encoder), meshopt without
# filters (gltfpack -c), meshopt with filters (gltf-transform meshopt --level high), and
# KTX2 textures in ETC1S and in Zstandard-supercompressed UASTC (scripts/ktx2-variant.py;
# GLB only). REFERENCE_PNG, if set, receives Basis Universal's decode of the first texture.
variants() {
  "$transform" draco "$1" "$2-draco.glb" >/dev/null
  "$gltfpack" -i "$1" -o "$2-meshopt.glb" -c >/dev/null
  "$transform" meshopt "$1" "$2-meshopt-filters.glb" --level high >/dev/null
  for codec in etc1s uastc; do
    "$tools/py/bin/python" scripts/ktx2-variant.py "$1" "$2-$codec.glb" $codec ${REFERENCE_PNG:+"$2-$codec.png"}
  done
}

if [ "${1:-}" != "--scene" ]; then
  src=$(mktemp -d)
  SHADETRACE_FIXTURE_DIR=$src cargo test --release --quiet -p shadetrace-capture --test compressed -- \
    --ignored write_fixture_source >/dev/null
  REFERENCE_PNG=1 variants "$src/wavy_grid.glb" capture/tests/fixtures/wavy_grid
  rm -rf "$src"
  ls -l capture/tests/fixtures/wavy_grid-*
  exit 0
fi
shift
for scene in "$@"; do
  scene=$(realpath "$scene")
  name=$(basename "$scene" | sed 's/\.[^.]*$//')
  variants "$scene" "$tools/$name"
  SHADETRACE_VARIANTS="$scene,$tools/$name-draco.glb,$tools/$name-meshopt.glb,$tools/$name-meshopt-filters.glb,$tools/$name-etc1s.glb,$tools/$name-uastc.glb" \
    cargo test --release --quiet -p shadetrace-capture --test compressed -- --ignored compare_scene_variants --nocapture |
    grep -E '^/' | sed "s|$tools/||"
done
