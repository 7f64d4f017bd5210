#!/usr/bin/env bash
# The 100-flight soak of `ppkat batch` (issue 69): N simulated flights (default 100) run
# here with `ppkat batch`, then as a Slurm job array on the one-node test cluster
# (cluster.sh), one task cancelled mid-run and submitted again; every output compared byte
# for byte (the results' reports but their run times), and the tasks' wall times and peak
# memory summed up from their status files. Not part of the test suite (minutes); run:
#
#   tests/slurm/soak.sh [WORKDIR] [N]      (as root, ppkat built with cargo build --release)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/../.." && pwd)
work=$(realpath -m "${1:-/tmp/ppkat-soak}")
n=${2:-100}
ppkat="$repo/target/release/ppkat"
[ -x "$ppkat" ] || { echo "build ppkat first: cargo build --release" >&2; exit 2; }
rm -rf "$work"
mkdir -p "$work/in"
echo "soak: simulating $n flights in $work/in"
for i in $(seq 1 "$n"); do
    d="$work/in/$(printf 'flight%03d' "$i")"
    "$ppkat" -q simulate --scenario "$repo/fixtures/scenario_small.toml" --seed "$i" -o "$d" >/dev/null
    rm -f "$d/ground_points.csv" "$d/image_observations.csv" "$d/camera.toml"
done
echo "soak: here, ppkat batch --jobs 2"
t0=$(date +%s.%N)
"$ppkat" -q batch "$work/in" -o "$work/out" --jobs 2 >"$work/here.txt" || true
t1=$(date +%s.%N)
mv "$work/out" "$work/here"
eval "$("$here/cluster.sh" up "$work/cluster" | grep '^SLURM_CONF=' | sed 's/^/export /')"
trap '"$here/cluster.sh" down "$work/cluster"' EXIT
echo "soak: Slurm, a job array of $n tasks, 2 at once"
t2=$(date +%s.%N)
sub=$("$ppkat" batch "$work/in" -o "$work/out" --slurm --submit --max-parallel 2 | tee "$work/submit.txt")
job=$(sed -n 's/.*submitted: array job \([0-9]*\).*/\1/p' <<<"$sub")
victim=$(( n / 2 ))
name=$(printf 'flight%03d' $((victim + 1)))
until [ -s "$work/out/status/$name.json" ]; do sleep 0.02; done
scancel "${job}_${victim}"
until [ -s "$work/out/summary.csv" ]; do sleep 0.5; done
echo "soak: the merge after the array: $(grep -c 'NOT RUN' "$work/out/summary.csv") flight(s) not run"
sbatch --parsable --array="$victim" "$work/out/slurm/batch.sbatch" >/dev/null
until [ -s "$work/out/$name/result.json" ]; do sleep 0.2; done
while [ -n "$(squeue -h 2>/dev/null)" ]; do sleep 0.2; done
"$ppkat" -q batch "$work/in" -o "$work/out" --merge >"$work/merge.txt" || true
t3=$(date +%s.%N)
python3 - "$work" "$n" "$t0" "$t1" "$t2" "$t3" <<'PY'
import json, os, sys, statistics
work, n = sys.argv[1], int(sys.argv[2])
t0, t1, t2, t3 = map(float, sys.argv[3:7])
here, out = os.path.join(work, "here"), os.path.join(work, "out")
def files(root):
    skip = ("status", "logs", "slurm")
    found = []
    for d, dirs, fs in os.walk(root):
        rel = os.path.relpath(d, root)
        if rel.split(os.sep)[0] in skip:
            continue
        found += [os.path.normpath(os.path.join(rel, f)) for f in fs]
    return sorted(found)
a, b = files(here), files(out)
same, differ = 0, []
for f in a:
    x, y = open(os.path.join(here, f), "rb").read(), open(os.path.join(out, f), "rb").read()
    if f.endswith("result.json"):
        x, y = json.loads(x), json.loads(y)
        x.pop("report"); y.pop("report")
    if x == y:
        same += 1
    else:
        differ.append(f)
flights = [f for f in sorted(os.listdir(os.path.join(work, "in")))]
whole = sum(os.path.exists(os.path.join(out, f, "result.json")) for f in flights)
status = [json.load(open(os.path.join(out, "status", f + ".json"))) for f in flights]
wall = [s["wall_s"] for s in status]
rss = [s["peak_rss_kib"] / 1024 for s in status]
temps = [f for f in b if f.endswith(".tmp")]
print(f"soak: {n} flights; here {t1 - t0:.1f} s (--jobs 2), Slurm {t3 - t2:.1f} s (2 tasks at once, with the cancelled task's rerun and the merges)")
print(f"  files: {len(a)} here, {len(b)} on Slurm; identical {same}, differing {len(differ)} {differ[:5]}; set equal: {a == b}")
print(f"  results: {whole}/{len(flights)} flights with a result; temporaries left: {len(temps)}")
print(f"  per task: wall {min(wall):.2f} / {statistics.median(wall):.2f} / {max(wall):.2f} s (min / median / max); peak memory {min(rss):.1f} / {statistics.median(rss):.1f} / {max(rss):.1f} MiB")
first, last = statistics.mean(rss[:10]), statistics.mean(rss[-10:])
print(f"  memory over the run: first ten tasks {first:.1f} MiB, last ten {last:.1f} MiB")
PY
