#!/usr/bin/env bash
# luz built with profile-guided optimisation (PGO): an instrumented build
# renders a small training set, llvm-profdata merges what it counted, and a
# second build lays out and inlines the code by those counts. The images are
# byte for byte those of a plain build (PGO changes no arithmetic); only the
# speed differs: 4.8-6.5% fewer instructions on the peer scenes
# (docs/performance.md, "2026-12-07 (late night)").
#
#   scripts/build-pgo.sh [OUT]
#
# OUT: where the binary goes (default target/pgo/luz). RUSTFLAGS, for
# example "-C target-cpu=native", go into both builds. The training set is
# scenes/ of this repository, at low resolution, with the Embree backend
# too where it is built in; with the meshes of $LUZ_ASSETS (default
# ../shared/assets) it includes the bunny.
# Needs llvm-profdata of rustc's own LLVM: `rustup component add llvm-tools`.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
# OUT and LUZ_ASSETS are relative to where the script was called from.
absolute() {
    case $1 in
    /*) echo "$1" ;;
    *) echo "$PWD/$1" ;;
    esac
}
out=$(absolute "${1:-$repo/target/pgo/luz}")
export LUZ_ASSETS="$(absolute "${LUZ_ASSETS:-$repo/../shared/assets}")"
cd "$repo"

sysroot=$(rustc --print sysroot)
host=$(rustc -vV | sed -n 's/^host: //p')
profdata="$sysroot/lib/rustlib/$host/bin/llvm-profdata"
if [ ! -x "$profdata" ]; then
    echo "$0: no llvm-profdata at $profdata: run \`rustup component add llvm-tools\`" >&2
    exit 1
fi

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
flags="${RUSTFLAGS:-}"

# Without --target, the build scripts and proc macros are instrumented too
# and write counts of their own into the same folder, which do no harm:
# with --target the build measured slower (docs/performance.md, same
# entry).
echo "$0: instrumented build" >&2
RUSTFLAGS="$flags -C profile-generate=$work/raw" \
    cargo build --release --quiet --target-dir target/pgo-generate
luz=target/pgo-generate/release/luz
# Where the training renders write their counts, whatever the caller's
# environment says.
export LLVM_PROFILE_FILE="$work/raw/luz-%p-%m.profraw"

scenes=(cornell-area cornell-point materials rough-materials smooth-shading soft-shadows-sphere caustics-sphere)
if [ -f "$LUZ_ASSETS/stanford/bunny/bun_zipper.ply" ]; then
    scenes+=(bunny)
fi
backends=(rust)
if "$luz" info | grep -q '^backends:.*embree'; then
    backends+=(embree)
fi
echo "$0: training on ${scenes[*]} with ${backends[*]}" >&2
for scene in "${scenes[@]}"; do
    for backend in "${backends[@]}"; do
        "$luz" render "scenes/$scene.toml" --backend "$backend" --resolution 96x96 \
            --spp 16 --quiet --checkpoint-every off -o "$work/$scene-$backend.exr"
    done
done
"$profdata" merge -o "$work/luz.profdata" "$work/raw"

echo "$0: optimised build" >&2
RUSTFLAGS="$flags -C profile-use=$work/luz.profdata" \
    cargo build --release --quiet --target-dir target/pgo-use
mkdir -p "$(dirname "$out")"
cp target/pgo-use/release/luz "$out"
echo "$0: built $out" >&2
