"""Batch throughput with 1 and with N local workers (BENCHMARKS.md, "Batch filtering").

    PYTHONPATH=build/python build/venv/bin/python python/bench/batch_throughput.py \\
        [--copies 2] [--max-seconds 4] [--workers 2] [--mode paper] [--repeat 3]

The collection: every shipped clip (the three CMU BVH clips and data/squat_reference.csv),
``--copies`` times each under different names, each filtered for its first
``--max-seconds`` so the clips are of similar length. Each run starts from an empty output
folder (``--force``), so nothing is skipped. Prints the wall time of every run, the median
per worker count, the speed-up and the load average before and after (the machine is
shared: measure when it is idle).
"""
import argparse
import os
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

from dynfilter import batch, default_model_path

ROOT = Path(__file__).resolve().parents[2]


def collection(copies, max_seconds):
    cmu = ROOT / "data" / "mocap" / "cmu"
    base = [batch.Clip("walk", str(cmu / "131_01_start_walk_stop.bvh"),
                       str(cmu / "mappings" / "131_01.yaml")),
            batch.Clip("jumps", str(cmu / "01_01_forward_jumps.bvh"),
                       str(cmu / "mappings" / "01_01.yaml")),
            batch.Clip("kick", str(cmu / "10_01_soccer_kick.bvh"),
                       str(cmu / "mappings" / "10_01.yaml")),
            batch.Clip("squat", str(ROOT / "data" / "squat_reference.csv"))]
    return [batch.Clip(f"{c.name}_{k}", c.input, c.mapping, max_seconds)
            for k in range(copies) for c in base]


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--copies", type=int, default=2)
    p.add_argument("--max-seconds", type=float, default=4.0)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--mode", default="paper", choices=["paper", "qp"])
    p.add_argument("--repeat", type=int, default=3)
    a = p.parse_args()
    clips = collection(a.copies, a.max_seconds)
    print(f"{len(clips)} clips of {a.max_seconds} s, mode {a.mode}; "
          f"load average before: {os.getloadavg()}")
    times = {1: [], a.workers: []}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(a.repeat):
            for w in (1, a.workers):
                out = Path(tmp) / f"out_{w}"
                shutil.rmtree(out, ignore_errors=True)
                settings = batch.Settings(out_dir=str(out), model=default_model_path(),
                                          mode=a.mode, force=True)
                t0 = time.perf_counter()
                rows = batch.run_batch(clips, settings, workers=w, progress="none")
                wall = time.perf_counter() - t0
                failed = [x for x in rows if x["status"] != "ok"]
                if failed:
                    sys.exit(f"a clip failed: {failed[0]}")
                times[w].append(wall)
                print(f"run {r + 1}, {w} worker(s): {wall:.2f} s ({len(clips) / wall:.2f} clips/s)")
    one, many = statistics.median(times[1]), statistics.median(times[a.workers])
    print(f"median: 1 worker {one:.2f} s, {a.workers} workers {many:.2f} s: "
          f"speed-up {one / many:.2f}x; load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
