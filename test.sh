#!/usr/bin/env bash
# Runs luz's test suite the way CI does: installs Embree 3 when it is missing
# (Debian's libembree-dev), tests with Embree required, then tests the
# native-only build so the fallback cannot rot.
set -euo pipefail
cd "$(dirname "$0")"

if [ ! -f /usr/include/embree3/rtcore.h ] && [ -z "${EMBREE_DIR:-}" ]; then
    sudo=""
    if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
    echo "test.sh: installing libembree-dev (Embree 3)" >&2
    $sudo env DEBIAN_FRONTEND=noninteractive apt-get update -qq
    $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends libembree-dev >/dev/null
fi

export LUZ_ASSETS="${LUZ_ASSETS:-$PWD/../shared/assets}"

echo "test.sh: tests with the Embree and native backends" >&2
LUZ_REQUIRE_EMBREE=1 cargo test --all-targets
echo "test.sh: a 4-task Slurm array render and merge on a local single-node Slurm" >&2
deploy/slurm/test-local-cluster.sh
echo "test.sh: tests of the native-only build (Embree hidden)" >&2
LUZ_NO_EMBREE=1 cargo test --all-targets
