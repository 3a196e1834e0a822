#!/usr/bin/env bash
# Tick-time statistics of the filter over every tick of the four CMU results (walk, walk on
# a 5° slope, jump, kick), as BENCHMARKS.md reports them ("QP tick, every tick").
# Usage: [RUN_PREFIX="nice -n -20 taskset -c 1"] [CONFIG=c.yaml] [RUNS=3] tools/qp_tick_bench.sh [build-dir] [paper|qp] [work-dir]
# (RUN_PREFIX: the filter at the highest nice priority on one CPU, so that other load
# interrupts it less; SCHED_FIFO would be throttled for 50 ms after 0.95 s of full load.
# CONFIG: a filter configuration for every run, e.g. one with qp: {engine: proxqp}.
# RUNS: filter every clip this many times (the filter is deterministic: the same ticks in
# each run) and add a table of each tick's fastest run: the tick's own time, without the
# preemptions one run meets, which a single run's maximum mostly is on a shared machine.)
set -euo pipefail
B=${1:-build}; MODE=${2:-qp}; W=${3:-/tmp/dynfilter-tick-bench}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
PY=${PYTHON:-python3}
mkdir -p "$W"
ref() {  # bvh id -> reference csv
  [ -f "$W/$2.csv" ] || "$B/tools/bvh2ref/dynfilter-bvh2ref" "$ROOT/data/mocap/cmu/$1.bvh" \
      --mapping "$ROOT/data/mocap/cmu/mappings/$2.yaml" -o "$W/$2.csv" > "$W/$2_bvh2ref.log" 2>&1
}
ref 131_01_start_walk_stop 131_01; ref 01_01_forward_jumps 01_01; ref 10_01_soccer_kick 10_01
heading=$("$PY" - "$W/131_01.csv" <<'PY'
import csv, math, sys
rows = list(csv.DictReader(l for l in open(sys.argv[1]) if not l.startswith('#')))
dx = float(rows[-1]["base_x"]) - float(rows[0]["base_x"]); dy = float(rows[-1]["base_y"]) - float(rows[0]["base_y"])
print(f"{math.degrees(math.atan2(dy, dx)):.1f}")
PY
)
RUNS=${RUNS:-1}
run() {  # name ref extra...
  local name=$1 ref=$2; shift 2
  for ((k = 1; k <= RUNS; ++k)); do
    local out="$W/${name}_$MODE.csv"; [ "$k" -gt 1 ] && out="$W/${name}_${MODE}_run$k.csv"
    ${RUN_PREFIX:-} "$B/tools/offline/dynfilter-offline" "$W/$ref.csv" -o "$out" --mode "$MODE" \
        --every-tick ${CONFIG:+--config "$CONFIG"} "$@" > "$W/${name}_$MODE.log" 2>&1
  done
}
run walk 131_01; run slope 131_01 --slope-deg 5 --slope-heading-deg "$heading"
run jump 01_01; run kick 10_01
"$PY" - "$W" "$MODE" "$RUNS" <<'PY'
import csv, sys
w, mode, runs = sys.argv[1], sys.argv[2], int(sys.argv[3])
def ticks(path):
    return [float(r["tick_time_s"]) for r in csv.DictReader(l for l in open(path) if not l.startswith('#'))]
def stats(ts):
    ts = sorted(ts); n = len(ts)
    q = lambda p: ts[min(n - 1, int(p * n))]
    return n, q(0.5), q(0.99), q(0.999), ts[-1], sum(ts) / n
def table(name, ts):
    n, med, p99, p999, mx, mean = stats(ts)
    print(f"| {name} | {n} | {med*1e6:.0f} | {mean*1e6:.0f} | {p99*1e6:.0f} | {p999*1e6:.0f} | {mx*1e6:.0f} |")
def report(title, per_clip):
    print(title)
    print("| clip | ticks | median | mean | p99 | p99.9 | max |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    every = []
    for name, ts in per_clip.items():
        every += ts
        table(name, ts)
    table("all four", every)
clips = ("walk", "slope", "jump", "kick")
report(f"mode {mode}: tick time (µs) over every tick", {c: ticks(f"{w}/{c}_{mode}.csv") for c in clips})
if runs > 1:
    fastest = {}
    for c in clips:
        each = [ticks(f"{w}/{c}_{mode}.csv")] + [ticks(f"{w}/{c}_{mode}_run{k}.csv") for k in range(2, runs + 1)]
        if len({len(t) for t in each}) != 1:
            sys.exit(f"{c}: the runs have different numbers of ticks")
        fastest[c] = [min(t) for t in zip(*each)]
    print()
    report(f"mode {mode}: each tick's fastest of {runs} runs (µs)", fastest)
PY
