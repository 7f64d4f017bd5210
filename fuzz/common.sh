# What run.sh and saturate.sh share (sourced, not run).

# Every target, in the order the scripts run them when none is named.
ALL_TARGETS=(rinex_obs rinex_nav sp3 clk antex mrk times_csv attitude_csv project_toml patb bal exif pos ubx rtcm sbf xmp photo_meta project_tables micmac colmap rtklib_conf geoid positions names)

# The harness writes each input to a file under TMPDIR: on tmpfs (unless TMPDIR is set
# already) that costs no disk flush.
[ -d /dev/shm ] && [ -w /dev/shm ] && export TMPDIR=${TMPDIR:-/dev/shm}

# fuzz_run TARGET SECONDS LOG: one libFuzzer run from corpus/TARGET, output into LOG. One job,
# -O, 2 GiB RSS limit, 10 s per input, 64 KiB inputs, and dicts/TARGET.dict where there is one.
fuzz_run() {
    local dict=()
    [ -f "dicts/$1.dict" ] && dict=(-dict="dicts/$1.dict")
    cargo +nightly fuzz run -O "$1" "corpus/$1" -- "${dict[@]}" \
        -max_total_time="$2" -rss_limit_mb=2048 -timeout=10 -max_len=65536 >"$3" 2>&1
}

# generated_seeds TARGET: seeds that a script writes into corpus/TARGET (both scripts call it
# after copying seeds/): project_toml's fields with values of every TOML kind, its sections as
# positional arrays and its output projections (project_seeds.py).
generated_seeds() {
    case $1 in
    project_toml) python3 project_seeds.py "corpus/$1" ;;
    esac
}
