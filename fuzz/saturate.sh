#!/usr/bin/env bash
# Run each named target (default: all) in rounds of CHUNK seconds from its corpus until a round
# finds no coverage edge beyond the best seen (libFuzzer's "cov": for the first round, the
# count after loading the corpus; after it, the largest of the earlier rounds), or CAP seconds
# in all have run. Prints one line per round and a verdict per target; logs in logs/TARGET.rN.log.
# Same settings as run.sh (`fuzz_run` of common.sh).
# OWN=1: the verdict counts only the edges in ppkat's own library sources (own_edges.sh, a
# census of the corpus before the first round and after each), for targets whose input runs
# through a large dependency fuzzed upstream (the TOML parser) that goes on yielding edges of
# its own; the line of each round shows both counts.
set -u
cd "$(dirname "$0")"
. ./common.sh
CHUNK=${CHUNK:-600}
CAP=${CAP:-3600}
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=("${ALL_TARGETS[@]}")
mkdir -p logs
for t in "${targets[@]}"; do
    mkdir -p "corpus/$t"
    cp -n seeds/"$t"/* "corpus/$t/" 2>/dev/null
    generated_seeds "$t"
    spent=0 round=0 runs_all=0 best="" verdict="not saturated after ${CAP} s"
    own="" best_own=""
    if [ -n "${OWN:-}" ]; then
        cargo +nightly fuzz build -O "$t" >/dev/null 2>&1
        best_own=$(./own_edges.sh "$t" | cut -d' ' -f1)
    fi
    while [ "$spent" -lt "$CAP" ]; do
        round=$((round + 1))
        log=logs/$t.r$round.log
        start=$(date +%s)
        fuzz_run "$t" "$CHUNK" "$log"
        rc=$?
        spent=$((spent + $(date +%s) - start))
        inited=$(grep -oE 'INITED cov: [0-9]+' "$log" | grep -oE '[0-9]+$' | tail -1)
        final=$(grep -oE 'cov: [0-9]+' "$log" | grep -oE '[0-9]+$' | sort -n | tail -1)
        runs=$(grep -oE '^Done [0-9]+ runs' "$log" | grep -oE '[0-9]+' | tail -1)
        runs_all=$((runs_all + ${runs:-0}))
        [ -n "${OWN:-}" ] && own=$(./own_edges.sh "$t" | cut -d' ' -f1)
        echo "$t round $round: exit $rc, ${runs:-?} runs, cov ${inited:-?} -> ${final:-?}${own:+, own ${best_own} -> $own}, ${spent} s in all"
        if [ "$rc" -ne 0 ]; then verdict="stopped: exit $rc (see $log)"; break; fi
        if [ -n "${OWN:-}" ]; then
            if [ -n "$own" ] && [ "$own" -le "$best_own" ]; then
                verdict="saturated in ppkat's own code: round $round (${CHUNK} s, ${runs} runs) found no edge of it beyond $best_own"
                break
            fi
            [ -n "$own" ] && best_own=$own
            continue
        fi
        # the corpus load may count fewer edges than the round before reached
        [ -z "$best" ] && best=${inited:-}
        if [ -n "$best" ] && [ -n "${final:-}" ] && [ "$final" -le "$best" ]; then
            verdict="saturated: round $round (${CHUNK} s, ${runs} runs) found no edge beyond $best"
            break
        fi
        [ -n "${final:-}" ] && best=$final
    done
    echo "$t: $verdict; $runs_all runs in $spent s; cov ${final:-?}${own:+, own $own}"
done
