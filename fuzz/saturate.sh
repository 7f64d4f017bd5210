#!/usr/bin/env bash
# Run each named target (default: all) in rounds of CHUNK seconds from its corpus until a round
# finds no coverage edge beyond the best seen (libFuzzer's "cov": for the first round, the
# count after loading the corpus; after it, the largest of the earlier rounds), or CAP seconds
# in all have run. Prints one line per round and a verdict per target; logs in logs/TARGET.rN.log
# (an earlier run's moved to logs/earlier/TARGET.DATE-TIME/ first).
# Same settings as run.sh (`fuzz_run` of common.sh).
# OWN=1: the verdict counts only the edges in ppkat's own library sources (own_edges.sh, a
# census of the corpus before the first round and after each), for targets whose input runs
# through a large dependency fuzzed upstream (the TOML parser) that goes on yielding edges of
# its own; the line of each round shows both counts.
# OWN=lines: the same, but the verdict counts the gap of own_edges.sh instead (ppkat's edges no
# input reaches, by line: the standard library's code inlined into ppkat's functions left out);
# a round that does not make it smaller is the last.
# QUIET=N: the verdict after N rounds in a row without progress (default 1).
# Judged by libFuzzer's count (no OWN), a round also takes the census and counts as progress
# when it made ppkat's own-line gap smaller: each round's count starts from a fresh load of the
# corpus, which may count fewer edges than the round before reached, and new edges can stay
# under that dip. The gap, not ppkat's edge count, because the count varies from one load of the
# same corpus to the next where a function of ppkat's uses a HashMap (its random hash seed
# takes the inlined probing code down other branches); the gap leaves inlined code out and
# does not vary. CENSUS=0 leaves the census out.
set -u
cd "$(dirname "$0")"
. ./common.sh
CHUNK=${CHUNK:-600}
CAP=${CAP:-3600}
QUIET=${QUIET:-1}
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=("${ALL_TARGETS[@]}")
mkdir -p logs
for t in "${targets[@]}"; do
    fill_corpus "$t"
    # the round logs of an earlier run of this target kept, not overwritten
    if compgen -G "logs/$t.r*.log" >/dev/null; then
        keep=logs/earlier/$t.$(date +%Y%m%d-%H%M%S)
        mkdir -p "$keep" && mv logs/"$t".r*.log "$keep"/
    fi
    spent=0 round=0 quiet=0 runs_all=0 best="" verdict="not saturated after ${CAP} s"
    own="" best_own="" gap="" best_gap=""
    census_on=$({ [ -n "${OWN:-}" ] || [ "${CENSUS:-1}" != 0 ]; } && echo 1)
    if [ -n "$census_on" ]; then
        cargo +nightly fuzz build -O "$t" >/dev/null 2>&1
        census=$(./own_edges.sh "$t")
        best_own=${census%% *} best_gap=${census##* }
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
        if [ -n "$census_on" ]; then
            census=$(./own_edges.sh "$t")
            own=${census%% *} gap=${census##* }
        fi
        echo "$t round $round: exit $rc, ${runs:-?} runs, cov ${inited:-?} -> ${final:-?}${own:+, own ${best_own} -> $own, gap ${best_gap} -> $gap}, ${spent} s in all"
        if [ "$rc" -ne 0 ]; then verdict="stopped: exit $rc (see $log)"; break; fi
        # progress: the round made the count it is judged by better (or gave no count)
        if [ "${OWN:-}" = lines ]; then
            progress=$({ [ -z "$gap" ] || [ -z "$best_gap" ] || [ "$gap" -lt "$best_gap" ]; } && echo 1)
            what="left ppkat's own-line gap at $best_gap"
        elif [ -n "${OWN:-}" ]; then
            progress=$({ [ -z "$own" ] || [ -z "$best_own" ] || [ "$own" -gt "$best_own" ]; } && echo 1)
            what="found no edge of ppkat's beyond $best_own"
        else
            # the corpus load may count fewer edges than the round before reached
            [ -z "$best" ] && best=${inited:-}
            progress=$({ [ -z "${final:-}" ] || [ -z "$best" ] || [ "$final" -gt "$best" ]; } && echo 1)
            what="found no edge beyond $best"
            # nor made ppkat's own-line gap smaller than the census before it
            if [ -n "$census_on" ]; then
                [ -n "$gap" ] && [ -n "$best_gap" ] && [ "$gap" -lt "$best_gap" ] && progress=1
                what="$what and left ppkat's own-line gap at $best_gap"
            fi
        fi
        # the count not judged by is shown from round to round
        [ "${OWN:-}" = lines ] && [ -n "$own" ] && best_own=$own
        [ -n "${OWN:-}" ] && [ "$OWN" != lines ] && [ -n "$gap" ] && best_gap=$gap
        if [ -n "$progress" ]; then
            quiet=0
            if [ -n "$own" ]; then
                best_gap=$gap
                { [ -z "$best_own" ] || [ "$own" -gt "$best_own" ]; } && best_own=$own
            fi
            [ -n "${final:-}" ] && best=$final
            continue
        fi
        quiet=$((quiet + 1))
        if [ "$quiet" -ge "$QUIET" ]; then
            verdict="saturated: $quiet round(s) to round $round (${CHUNK} s each, the last ${runs} runs) $what"
            break
        fi
    done
    echo "$t: $verdict; $runs_all runs in $spent s; cov ${final:-?}${own:+, own $own, gap $gap}"
done
