#!/usr/bin/env bash
# queue.sh TARGET…: saturate.sh over the named targets in LANES lanes (default 2, one per
# core), each lane taking the next target from one queue as soon as its last one is done, so
# a target that saturates early gives its core to the next. saturate.sh's settings (CHUNK,
# CAP, QUIET, OWN) pass through; each lane's output goes to logs/lane.N.txt, one line per
# round as saturate.sh prints it. An argument may put settings for its target alone before
# it, in one word: queue.sh 'OWN=1 patb' names. Ends when the queue is empty and every lane
# has finished.
set -u
cd "$(dirname "$0")"
[ $# -eq 0 ] && { echo "usage: queue.sh TARGET…" >&2; exit 2; }
mkdir -p logs
queue=logs/queue.txt
printf '%s\n' "$@" >"$queue"
: >logs/queue.lock
lane() {
    local n=$1
    while true; do
        # take the first line off the queue under a lock
        t=$(flock logs/queue.lock sh -c 'head -n 1 "$1"; sed -i 1d "$1"' _ "$queue")
        [ -z "$t" ] && break
        echo "== $(date +%T) lane $n starts $t"
        # an entry may set saturate.sh's settings for its target alone: "OWN=1 patb"
        set -- $t
        env "${@:1:$#-1}" ./saturate.sh "${@: -1}"
    done
    echo "== $(date +%T) lane $n done"
}
for n in $(seq 1 "${LANES:-2}"); do
    lane "$n" >"logs/lane.$n.txt" 2>&1 &
done
wait
