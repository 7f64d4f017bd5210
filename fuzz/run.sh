#!/usr/bin/env bash
# Run every fuzz target (or those named) for SECS seconds each, one job, from the seeds; print
# the executions per target. Needs the nightly toolchain and cargo-fuzz
# (`cargo install cargo-fuzz`). Crashes land in artifacts/TARGET/.
set -u
cd "$(dirname "$0")"
SECS=${SECS:-60}
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=(rinex_obs rinex_nav sp3 clk antex mrk times_csv attitude_csv project_toml patb bal exif pos ubx rtcm)
mkdir -p logs
for t in "${targets[@]}"; do
    mkdir -p "corpus/$t"
    cp -n seeds/"$t"/* "corpus/$t/" 2>/dev/null
    cargo +nightly fuzz run -O "$t" "corpus/$t" -- \
        -max_total_time="$SECS" -rss_limit_mb=2048 -timeout=10 -max_len=65536 \
        >"logs/$t.log" 2>&1
    rc=$?
    done_line=$(grep -E '^Done [0-9]+ runs' "logs/$t.log" | tail -1)
    echo "$t: exit $rc; ${done_line:-no summary (see logs/$t.log)}"
done
