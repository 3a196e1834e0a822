#!/usr/bin/env python3
"""Probe of docs/balance.md §37, not part of the product and not tested.

Iterative learning control over a whole clip, offline: the filter is run on a reference,
its joint error against the *original* reference is measured up to --margin-s before the
first re-seed, smoothed (zero-phase Gaussian, --sigma-s) and added, times --gain, to the
joint targets it is given next time. Optionally (--base) the base position the same way.
Each iteration prints the re-seeds, the first one's time and the joint RMS against the
original reference (before the first re-seed, and over the whole clip).

    build/venv/bin/python docs/probes/ilc_probe.py /tmp/w/ref.csv --iterations 6 \\
        --gain 0.3 --sigma-s 0.05 --margin-s 0.5 --offline build/tools/offline/dynfilter-offline

Works on any reference CSV whose columns are time, the 7 base coordinates and the joints
(what dynfilter-bvh2ref writes); extra arguments after -- go to dynfilter-offline.
"""
import argparse
import csv
import math
import os
import subprocess

import numpy as np


def smooth(x, sigma_s, dt):
    if sigma_s <= 0:
        return x
    half = int(4 * sigma_s / dt)
    kernel = np.exp(-0.5 * (np.arange(-half, half + 1) * dt / sigma_s) ** 2)
    kernel /= kernel.sum()
    padded = np.pad(x, ((half, half), (0, 0)), mode="edge")
    return np.stack([np.convolve(padded[:, j], kernel, mode="valid") for j in range(x.shape[1])], 1)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("reference")
    ap.add_argument("--iterations", type=int, default=6)
    ap.add_argument("--gain", type=float, default=0.3)
    ap.add_argument("--sigma-s", type=float, default=0.05)
    ap.add_argument("--margin-s", type=float, default=0.5)
    ap.add_argument("--base", action="store_true", help="correct the base position too")
    ap.add_argument("--offline", default="build/tools/offline/dynfilter-offline")
    ap.add_argument("--work", default="/tmp/ilc_probe")
    ap.add_argument("extra", nargs="*")
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    header = open(a.reference).readline().strip().split(",")
    original = np.loadtxt(a.reference, delimiter=",", skiprows=1)
    t = original[:, 0]
    dt = t[1] - t[0]
    given = original.copy()
    for k in range(a.iterations + 1):
        path = os.path.join(a.work, f"it{k}.csv")
        with open(path, "w") as f:
            f.write(",".join(header) + "\n")
            for row in given:
                f.write(",".join(repr(float(x)) for x in row) + "\n")
        out, events = path[:-4] + ".out.csv", path[:-4] + ".ev.csv"
        subprocess.run([a.offline, path, "-o", out, "--mode", "qp", "--no-progress", "-q",
                        "--events-csv", events] + a.extra, check=True)
        out_header = open(out).readline().strip().split(",")
        o = np.loadtxt(out, delimiter=",", skiprows=1)
        q_out = np.stack([o[:, out_header.index(h)] for h in header[1:]], 1)
        reseeds = [float(e["time"]) for e in csv.DictReader(open(events)) if e["reseed_reason"]]
        q_ref = np.stack([np.interp(o[:, 0], t, original[:, c]) for c in range(1, original.shape[1])], 1)
        error = q_ref - q_out
        first = reseeds[0] if reseeds else math.inf
        before = o[:, 0] < first
        print(f"iteration {k}: {len(reseeds)} re-seeding ticks, first at {first:.3f} s; joint RMS "
              f"{math.sqrt(np.mean(error[before, 7:] ** 2)):.4f} rad before it, "
              f"{math.sqrt(np.mean(error[:, 7:] ** 2)):.4f} over the clip", flush=True)
        if k == a.iterations:
            break
        window = np.clip((first - a.margin_s - t) / 0.1, 0, 1)[:, None]
        at_frames = np.stack([np.interp(t, o[:, 0], error[:, j]) for j in range(error.shape[1])], 1)
        given[:, 8:] += a.gain * smooth(at_frames[:, 7:] * window, a.sigma_s, dt)
        if a.base:
            given[:, 1:4] += a.gain * smooth(at_frames[:, :3] * window, a.sigma_s, dt)


if __name__ == "__main__":
    main()
