#!/usr/bin/env bash
# Fuzzes each of luz's loaders for SECONDS (default 180) with cargo-fuzz:
#   fuzz/run.sh [SECONDS] [TARGET...]    (targets: scene ply obj ppm)
# Needs a nightly toolchain and cargo-fuzz (`cargo install cargo-fuzz`).
# New inputs go to fuzz/corpus/TARGET, starting from the committed seeds in
# fuzz/seeds/TARGET; a crash, or an input that takes over 10 s, stops its
# target and leaves the input in fuzz/artifacts/TARGET. Prints executions and coverage per target.
set -euo pipefail
cd "$(dirname "$0")"
seconds="${1:-180}"
shift || true
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then targets=(scene ply obj ppm); fi
# The loaders do not touch Embree; leaving it out spares linking it with
# the sanitizer runtime.
export LUZ_NO_EMBREE=1
status=0
for t in "${targets[@]}"; do
    mkdir -p "corpus/$t"
    log="$(mktemp)"
    if cargo +nightly fuzz run -O "$t" "corpus/$t" "seeds/$t" -- \
        -max_total_time="$seconds" -timeout=10 -print_final_stats=1 >"$log" 2>&1; then
        result="no crash"
    else
        result="CRASH (see fuzz/artifacts/$t)"
        status=1
    fi
    execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo "?")
    cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*' || echo "?")
    echo "$t: ${seconds} s, ${execs} executions, coverage ${cov}, corpus $(ls "corpus/$t" | wc -l) files: $result"
    if [ "$result" != "no crash" ]; then tail -40 "$log"; fi
    rm -f "$log"
done
exit $status
