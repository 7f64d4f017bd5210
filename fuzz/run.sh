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
# Real files of ../shared/data (beside the repository) seed the newer targets when present;
# they are copied into corpus/ only (cut to the 64 KiB inputs are limited to), never into seeds/.
DATA=../../shared/data
SHARED=$DATA/photo
GNSS=$DATA/gnss
shared_seeds() {
    local t=$1 c=corpus/$1 f k logs
    case $t in
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
mkdir -p logs
for t in "${targets[@]}"; do
    mkdir -p "corpus/$t"
    cp -n seeds/"$t"/* "corpus/$t/" 2>/dev/null
    generated_seeds "$t"
    [ -d "$DATA" ] && shared_seeds "$t"
    fuzz_run "$t" "$SECS" "logs/$t.log"
    rc=$?
    done_line=$(grep -E '^Done [0-9]+ runs' "logs/$t.log" | tail -1)
    echo "$t: exit $rc; ${done_line:-no summary (see logs/$t.log)}"
done
