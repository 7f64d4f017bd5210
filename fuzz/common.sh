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

# generated_seeds TARGET: seeds that a script writes into corpus/TARGET (by fill_corpus):
# project_toml's fields with values of every TOML kind, its sections as positional arrays and
# its output projections (project_seeds.py).
generated_seeds() {
    case $1 in
    project_toml) python3 project_seeds.py "corpus/$1" ;;
    esac
}

# shared_seeds TARGET: real files of ../shared/data (beside the repository) seed some targets
# when present (by fill_corpus); they are copied into corpus/ only (cut to the 64 KiB inputs
# are limited to), never into seeds/.
DATA=../../shared/data
SHARED=$DATA/photo
GNSS=$DATA/gnss
shared_seeds() {
    local t=$1 c=corpus/$1 f k logs
    [ -d "$DATA" ] || return 0
    case $t in
    rinex_obs)
        # RINEX 2, 3 and Hatanaka heads, each also gzipped
        python3 obs_seeds.py "$c" "$GNSS"/bell-ebre-2002-030/bell0300.02o "$GNSS"/onsa-2005-224/onsa2240.05o \
            "$GNSS"/cssrlib-2021-265/SEPT265G.21O "$GNSS"/spirent-rose-2023/Rover-dynamic_MO_Spirent.obs \
            "$GNSS"/esbc-2020-177/ESBC00DNK_R_20201770000_01D_30S_MO.crx.gz "$GNSS"/ubx-navsol-2025/F9T-L2-5min_convbin.obs ;;
    xmp)
        for f in "$SHARED"/brighton-beach/DJI_001[89].JPG; do
            [ -f "$f" ] && python3 -c 'import sys; d=open(sys.argv[1],"rb").read(); a=d.find(b"<x:xmpmeta"); b=d.find(b"</x:xmpmeta>"); sys.stdout.buffer.write(d[a:b+12] if a>=0<b else b"")' "$f" >"$c/shared-$(basename "$f").xmp"
        done ;;
    photo_meta)
        for f in "$SHARED"/brighton-beach/DJI_001[89].JPG; do
            [ -f "$f" ] && head -c 65536 "$f" >"$c/shared-$(basename "$f")"
        done ;;
    micmac)
        for f in "$SHARED"/micmac-formats/*.xml "$SHARED"/micmac-formats/Saisies-MMV1/*.xml "$SHARED"/micmac-formats/Saisies-MMV1/Ori-Ground_mm3d/*.xml; do
            [ -f "$f" ] && cp "$f" "$c/shared-$(basename "$f")"
        done ;;
    colmap)
        k=0
        for f in cameras.txt images.txt points3D.txt; do
            f=$SHARED/brighton-beach/colmap-3.8/$f
            [ -f "$f" ] && { printf "\\x0$k"; head -c 65000 "$f"; } >"$c/shared-$(basename "$f")"
            k=$((k + 1))
        done ;;
    ubx)
        # GPS and Galileo subframes as the bare payloads the target also decodes
        logs=("$GNSS"/ubx-navsol-*/*.ubx)
        [ -f "${logs[0]}" ] && python3 sfrbx_seeds.py "$c" "${logs[@]}" ;;
    esac
}

# fill_corpus TARGET: corpus/TARGET made if need be, and given seeds/TARGET (files already there
# kept), the generated seeds and the shared data's; both scripts call it before fuzzing.
fill_corpus() {
    mkdir -p "corpus/$1"
    cp -n seeds/"$1"/* "corpus/$1/" 2>/dev/null
    generated_seeds "$1"
    shared_seeds "$1"
}
