#!/usr/bin/env bash
# own_edges.sh TARGET [BY_FILE]: the coverage edges that corpus/TARGET reaches in ppkat's own
# library sources (files of this repository outside fuzz/; the standard library and the crates
# of the registry left out), as "COVERED of INSTRUMENTED; gap GAP". With a second argument,
# one line per source file first. ROOT is the repository the target was built from (default:
# this one). CORPUS is the folder loaded (default: corpus/TARGET). Loads the corpus once with
# the built target (`cargo +nightly fuzz build -O` first).
#
# An edge counts as ppkat's when its function is in ppkat's sources, and the compiler inlines
# the standard library into those functions (number parsing, Vec growth): such an edge is the
# standard library's logic. GAP counts only what is ppkat's own by line: the edges of ppkat's
# functions that nothing reaches, plus the unreached edges of the reached ones whose line is in
# ppkat's sources (libFuzzer's UNCOVERED_PC). It never grows as a corpus grows, and it falls
# only when an input reaches a new function of ppkat's or a line of one.
set -u
cd "$(dirname "$0")"
. ./common.sh
root=${ROOT:-$(cd .. && pwd)}
root=${root%/}/
bin=target/x86_64-unknown-linux-gnu/release/$1
[ -x "$bin" ] || { echo "own_edges.sh: no $bin; run 'cargo +nightly fuzz build -O $1' first" >&2; exit 2; }
"$bin" -runs=0 -max_len=65536 -print_coverage=1 "${CORPUS:-corpus/$1}" 2>&1 |
    awk -v root="$root" -v by_file="${2:-}" '
    function ours(path) { return index(path, root) == 1 && index(path, root "fuzz/") != 1 }
    /^(UN)?COVERED_FUNC:/ {
        file = $NF; sub(/:[0-9]+$/, "", file)
        own = ours(file)
        if (!own) next
        split($5, e, "/"); cov[file] += e[1]; all[file] += e[2]
        c += e[1]; a += e[2]
        if (e[1] == 0) gap += e[2]
        next
    }
    /UNCOVERED_PC:/ && own && ours($2) { gap++ }
    END {
        if (by_file != "") {
            for (f in cov) printf "%6d of %6d  %s\n", cov[f], all[f], substr(f, length(root) + 1) | "sort -k4"
            close("sort -k4")
        }
        printf "%d of %d; gap %d\n", c, a, gap
    }'
