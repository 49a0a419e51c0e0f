#!/usr/bin/env bash
# Instructions per sample of a render, counted by callgrind, so that they do
# not depend on machine load: a 64x64 render on one thread at 16 and at 48
# spp, and the difference divided by the 32 x 64 x 64 samples between them,
# which leaves loading and the BVH build out. The build quality is pinned
# to medium: `auto` would pick a different tree for the two runs when the
# scene has about as many triangles as the runs have samples.
#
#   tools/instructions_per_sample.sh SCENE [BACKEND] [BINARY]
#
# BACKEND: rust (default) or embree. BINARY: default target/release/luz.
# LUZ_EXTRA_ARGS: more arguments for both renders, split at spaces (for
# example LUZ_EXTRA_ARGS="--sampler independent").
# Needs valgrind (apt-get install valgrind); meshes from $LUZ_ASSETS.
set -euo pipefail
if [ $# -lt 1 ]; then
    sed -n '2,14p' "$0" >&2
    exit 2
fi
scene=$1
backend=${2:-rust}
luz=${3:-target/release/luz}
export LUZ_ASSETS="${LUZ_ASSETS:-$(dirname "$0")/../../shared/assets}"
read -r -a extra <<<"${LUZ_EXTRA_ARGS:-}"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# Says why the render of $1 spp gave no count, after callgrind's output.
no_count() {
    cat "$work/log" >&2
    echo "$0: $2 (the $1-spp render of $scene; callgrind's output above)" >&2
    return 1
}
instructions() {
    if ! valgrind --tool=callgrind --callgrind-out-file="$work/callgrind.out" "$luz" render "$scene" \
        --backend "$backend" --bvh-quality medium --embree-quality medium --threads 1 --spp "$1" --resolution 64x64 --quiet \
        --checkpoint-every off "${extra[@]}" -o "$work/image.exr" >"$work/log" 2>&1; then
        no_count "$1" "the render failed under callgrind"
        return
    fi
    local count
    count=$(sed -n 's/.*Collected : \([0-9]*\).*/\1/p' "$work/log")
    if [ -z "$count" ]; then
        no_count "$1" "callgrind printed no 'Collected :' line (VALGRIND_OPTS=-q?)"
        return
    fi
    echo "$count"
}
low=$(instructions 16)
high=$(instructions 48)
echo "$scene $backend${LUZ_EXTRA_ARGS:+ $LUZ_EXTRA_ARGS}: $(((high - low) / (32 * 64 * 64))) instructions per sample"
