#!/usr/bin/env bash
# own_edges.sh TARGET [BY_FILE]: the coverage edges that corpus/TARGET reaches in ppkat's own
# library sources (files of this repository outside fuzz/; the standard library and the crates
# of the registry left out), as "COVERED of INSTRUMENTED". With a second argument, one line per
# source file. ROOT is the repository the target was built from (default: this one).
# Loads the corpus once with the built target (`cargo +nightly fuzz build -O` first).
set -u
cd "$(dirname "$0")"
. ./common.sh
root=${ROOT:-$(cd .. && pwd)}
root=${root%/}/
bin=target/x86_64-unknown-linux-gnu/release/$1
[ -x "$bin" ] || { echo "own_edges.sh: no $bin; run 'cargo +nightly fuzz build -O $1' first" >&2; exit 2; }
"$bin" -runs=0 -max_len=65536 -print_coverage=1 "corpus/$1" 2>&1 |
    awk -v root="$root" -v by_file="${2:-}" '
    /^(UN)?COVERED_FUNC:/ {
        file = $NF; sub(/:[0-9]+$/, "", file)
        if (index(file, root) != 1 || index(file, root "fuzz/") == 1) next
        split($5, e, "/"); cov[file] += e[1]; all[file] += e[2]
        c += e[1]; a += e[2]
    }
    END {
        if (by_file != "") {
            for (f in cov) printf "%6d of %6d  %s\n", cov[f], all[f], substr(f, length(root) + 1) | "sort -k4"
            close("sort -k4")
        }
        printf "%d of %d\n", c, a
    }'
