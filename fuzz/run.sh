#!/usr/bin/env bash
# Run every fuzz target (or those named) for SECS seconds each, one job, from the seeds; print
# the executions per target. Needs the nightly toolchain and cargo-fuzz
# (`cargo install cargo-fuzz`). Crashes land in artifacts/TARGET/.
set -u
cd "$(dirname "$0")"
. ./common.sh
SECS=${SECS:-60}
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=("${ALL_TARGETS[@]}")
mkdir -p logs
for t in "${targets[@]}"; do
    fill_corpus "$t"
    fuzz_run "$t" "$SECS" "logs/$t.log"
    rc=$?
    done_line=$(grep -E '^Done [0-9]+ runs' "logs/$t.log" | tail -1)
    echo "$t: exit $rc; ${done_line:-no summary (see logs/$t.log)}"
done
