#!/usr/bin/env bash
# Regenerates ffi/embree3.rs, luz's bindings to Embree 3, from the installed
# headers. Only needed when the Embree headers change (a new 3.x release, or
# an rtcore_config.h built with other RTC_MAX_INSTANCE_LEVEL_COUNT or
# RTC_MIN_WIDTH, which build.rs detects and refuses): a normal build reads the
# committed file and needs neither bindgen nor libclang.
#
#   apt-get install --no-install-recommends bindgen libclang-dev   # Debian 12: bindgen 0.60
#   ffi/generate.sh [EMBREE_INCLUDE_DIR]                           # default /usr/include
#
# The allow-list is the functions src/accel/embree/sys3.rs calls and the
# types they exchange; bindgen's layout tests come along and run with
# `cargo test --lib`. Header-inline functions (rtcInitIntersectContext) and
# cast macros (RTC_INVALID_GEOMETRY_ID) are not generated: sys3.rs writes
# them in Rust.
set -euo pipefail
cd "$(dirname "$0")"
include="${1:-/usr/include}"
header="$include/embree3/rtcore.h"
[ -f "$header" ] || { echo "generate.sh: $header not found (apt-get install libembree-dev)" >&2; exit 1; }

functions='rtcNewDevice|rtcRetainDevice|rtcReleaseDevice|rtcGetDeviceProperty|rtcGetDeviceError|rtcSetDeviceErrorFunction'
functions+='|rtcNewScene|rtcReleaseScene|rtcSetSceneBuildQuality|rtcSetSceneFlags|rtcAttachGeometryByID|rtcCommitScene'
functions+='|rtcSetSceneProgressMonitorFunction'
functions+='|rtcIntersect1|rtcOccluded1'
functions+='|rtcNewGeometry|rtcReleaseGeometry|rtcCommitGeometry|rtcSetGeometryBuildQuality|rtcSetNewGeometryBuffer|rtcSetSharedGeometryBuffer'
functions+='|rtcSetGeometryUserData|rtcSetGeometryUserPrimitiveCount|rtcSetGeometryBoundsFunction'
functions+='|rtcSetGeometryIntersectFunction|rtcSetGeometryOccludedFunction'
types='RTC(Ray|Hit|RayHit|RayN|RayHitN|HitN|IntersectContext|Bounds|Error|DeviceProperty|Format|BufferType'
types+='|GeometryType|BuildQuality|SceneFlags|IntersectContextFlags|FilterFunctionNArguments'
types+='|BoundsFunctionArguments|IntersectFunctionNArguments|OccludedFunctionNArguments|ProgressMonitorFunction)'

bindgen "$header" \
    --allowlist-function "($functions)" \
    --allowlist-type "$types" \
    --allowlist-var 'RTC_.*' \
    --no-prepend-enum-name \
    --size_t-is-usize \
    --use-core --ctypes-prefix core::ffi \
    --no-doc-comments \
    -o embree3.rs \
    -- -I"$include"
echo "generate.sh: wrote ffi/embree3.rs from $header" >&2
