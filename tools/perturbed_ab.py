#!/usr/bin/env python3
"""Two builds of the filter compared over perturbed copies of the check matrix's clips.

    build/venv/bin/python tools/perturbed_ab.py --builds /work/main/build,build \
        [--configs ,c.yaml] [--only walk,jump] [--seeds 24] [--noise 1e-6] [--mode qp] \
        [--reference-per-build] [--out build/perturbed_ab]

The counts of tools/balance_matrix.py (relaxed ticks, re-seeding ticks) and the joint RMS
are chaotic in the reference: Gaussian noise of 1e-6 (rad, m) on every joint and base
position sample moves the CMU walk's relaxed ticks anywhere between 30 and 310 with the
same build (48 references). One run per build says nothing about a change; this runs each
case with seed 0 (the reference as retargeted) and seeds 1..N−1 (noise added, base
quaternion untouched) through both builds and prints per build the median, mean and range, and the paired
differences (second build − first, same seed) with their standard error.
"""
import argparse
import concurrent.futures as cf
import csv
import math
import subprocess
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import balance_matrix as bm  # noqa: E402
import paper_results as pr  # noqa: E402


def perturb(src, dst, seed, noise):
    lines = Path(src).read_text().splitlines()
    header = lines[0].split(",")
    rng = np.random.default_rng(seed)
    out = [lines[0]]
    for line in lines[1:]:
        if not line.strip() or line.startswith("#") or seed == 0:
            out.append(line)
            continue
        f = line.split(",")
        for i, h in enumerate(header):
            if i > 0 and not h.startswith("base_q"):
                f[i] = repr(float(f[i]) + noise * rng.standard_normal())
        out.append(",".join(f))
    Path(dst).write_text("\n".join(out) + "\n")


def run(job):
    name, seed, b, build, config, ref, args, out = job
    pr.MODEL_INFO = build / "tools" / "model_info" / "dynfilter-model-info"
    slope, backend = bm.CASES[name].slope, bm.CASES[name].backend
    stem = out / f"{name}_s{seed}_b{b}"
    fil, events = Path(f"{stem}.csv"), Path(f"{stem}.events.csv")
    cmd = [str(build / "tools/offline/dynfilter-offline"), str(ref), "-o", str(fil), "--no-progress", "-q",
           "--mode", args.mode, "--backend", backend, "--events-csv", str(events)]
    if config:
        cmd += ["--config", config]
    if slope:
        heading, _ = pr.heading_of(ref)
        cmd += ["--slope-deg", f"{slope:g}", "--slope-heading-deg", f"{heading:.1f}"]
    subprocess.run(cmd, check=True, capture_output=True)
    with open(events, newline="") as f:
        rows = list(csv.DictReader(f))
    m = pr.metrics_of(fil, Path(f"{stem}.contacts.csv"), pr.Model(pr.URDF))
    return (name, seed, b, sum(1 for r in rows if int(r["qp_relaxation"]) > 0),
            pr.reseed_counts(rows)[0], m["joint_rms_legs_rad"])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--builds", required=True, help="two build directories, comma-separated")
    ap.add_argument("--configs", default=",",
                    help="a filter configuration per build, comma-separated (empty: the defaults)")
    ap.add_argument("--only", default="walk,jump,kick,walk_1.25x")
    ap.add_argument("--seeds", type=int, default=24)
    ap.add_argument("--noise", type=float, default=1e-6)
    ap.add_argument("--mode", default="qp", choices=["qp", "paper"])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--reference-per-build", action="store_true",
                    help="each build retargets the clips itself (compares clean-up changes too); "
                    "default: build 0's reference for both")
    ap.add_argument("--out", default=str(pr.ROOT / "build" / "perturbed_ab"))
    args = ap.parse_args()
    builds = [Path(b).resolve() for b in args.builds.split(",")]
    if len(builds) != 2:
        sys.exit("--builds takes two build directories")
    configs = [str(Path(c).resolve()) if c.strip() else "" for c in args.configs.split(",")]
    if len(configs) != 2:
        sys.exit("--configs takes two entries (either may be empty), comma-separated")
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    names = [n.strip() for n in args.only.split(",") if n.strip()]
    jobs = []
    for name in names:
        per_build = (0, 1) if args.reference_per_build else (0,)
        refs = {}
        for b in per_build:
            (out / f"b{b}").mkdir(exist_ok=True)
            refs[b] = bm.make_reference(name, builds[b], out / f"b{b}", pr.CMU / "mappings" / bm.CASES[name].mapping)
        for seed in range(args.seeds):
            perturbed = {}  # one perturbed copy per reference, shared when both builds use it
            for b in per_build:
                perturbed[b] = out / f"{name}_s{seed}_b{b}_reference.csv"
                perturb(refs[b], perturbed[b], seed, args.noise)
            for b in (0, 1):
                ref_s = perturbed[b if args.reference_per_build else 0]
                jobs.append((name, seed, b, builds[b], configs[b], ref_s, args, out))
    res = {}
    with cf.ProcessPoolExecutor(max_workers=args.jobs) as pool:
        for name, seed, b, relaxed, reseeds, legs in pool.map(run, jobs):
            res[(name, seed, b)] = (relaxed, reseeds, legs)
    print(f"{args.seeds} references per case (noise {args.noise:g}); builds 0 = {builds[0]} {configs[0]}, "
          f"1 = {builds[1]} {configs[1]}")
    labels = ("relaxed ticks", "re-seeds", "leg RMS (rad)")
    for name in names:
        v = np.array([[res[(name, s, b)] for s in range(args.seeds)] for b in (0, 1)])  # build, seed, metric
        for k, label in enumerate(labels):
            cells = [f"build {b}: median {np.median(v[b, :, k]):.4g} mean {v[b, :, k].mean():.4g} "
                     f"[{v[b, :, k].min():.4g}, {v[b, :, k].max():.4g}]" for b in (0, 1)]
            d = v[1, :, k] - v[0, :, k]
            se = d.std(ddof=1) / math.sqrt(len(d)) if len(d) > 1 else float("nan")
            print(f"{name:12s} {label:14s} " + "; ".join(cells) +
                  f"; 1−0: mean {d.mean():+.4g} ± {se:.2g} (up {int((d > 0).sum())}, down {int((d < 0).sum())})")


if __name__ == "__main__":
    main()
