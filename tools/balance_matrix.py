#!/usr/bin/env python3
"""Issue 13's check matrix: the CMU clips and their variants in one mode and configuration.

    build/venv/bin/python tools/balance_matrix.py [--out build/balance_matrix] [--mode qp]
        [--config c.yaml] [--cleanup '{balance: false}'] [--only walk,jump] [--jobs 2]
        [--markdown table.md] [--refilter]

Cases: walk, jump, kick (level ground, DART), the walk with the ODE backend, played 0.8× and
1.25× as fast (the reference's time column scaled), on a 10° downhill and a 5° uphill slope
along its heading, mirrored left↔right (the BVH mirrored before retargeting), and its
straight stretch alone (3.9–6.3 s, retargeted as a clip of its own). References
come from dynfilter-bvh2ref with its default clean-up. Per case: re-seeding ticks (every
tick, --events-csv), joint RMS overall and per group, base position RMS against the
reference as received, the largest per-frame base jump, stance skate, penetration, frames
with a pulling contact / a force outside its cone / a CoP outside its support / a torque at
its limit, and Eq. 12's base rows relative to the body weight. With --refilter, also whether the filter gives
a physically consistent motion back unchanged: its own output before the first re-seed,
written every tick, filtered again; when its joints first leave that reference by more than
0.01 rad RMS, the largest RMS, and its re-seeds.
"""
import argparse
import concurrent.futures as cf
import csv
import math
import subprocess
import sys
from collections import namedtuple
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import paper_results as pr  # noqa: E402

# window: (start, end) in s of the clip (dynfilter-bvh2ref --start-s/--end-s), None: all of it.
Case = namedtuple("Case", "bvh mapping speed slope backend mirrored window", defaults=(None,))
WALK = ("131_01_start_walk_stop.bvh", "131_01.yaml")
CASES = {
    # name: bvh, mapping, time scale, slope (deg, + down), backend, mirrored[, window]
    "walk": Case(*WALK, 1.0, 0.0, "dart", False),
    "jump": Case("01_01_forward_jumps.bvh", "01_01.yaml", 1.0, 0.0, "dart", False),
    "kick": Case("10_01_soccer_kick.bvh", "10_01.yaml", 1.0, 0.0, "dart", False),
    "walk_ode": Case(*WALK, 1.0, 0.0, "ode", False),
    "walk_0.8x": Case(*WALK, 0.8, 0.0, "dart", False),
    "walk_1.25x": Case(*WALK, 1.25, 0.0, "dart", False),
    "walk_10_down": Case(*WALK, 1.0, 10.0, "dart", False),
    "walk_5_up": Case(*WALK, 1.0, -5.0, "dart", False),
    "walk_mirrored": Case(*WALK, 1.0, 0.0, "dart", True),
    # The walk's straight stretch alone: five steps along +x with no foot gliding under load.
    "walk_forward": Case(*WALK, 1.0, 0.0, "dart", False, (3.9, 6.3)),
}


def window_args(case):
    """dynfilter-bvh2ref's arguments for the case's window of its clip."""
    return [] if case.window is None else ["--start-s", f"{case.window[0]:g}", "--end-s", f"{case.window[1]:g}"]


def mirror_bvh(src, dst):
    """Mirror a BVH about its sagittal plane (x = 0; the CMU skeletons: x lateral, y up):
    Left/Right swapped in the bone names, x offsets and positions negated, and the rotations
    about y and z."""
    text = Path(src).read_text().splitlines()
    i_motion = next(i for i, l in enumerate(text) if l.strip() == "MOTION")
    channels, names, out = [], [], []
    for line in text[:i_motion]:
        s = line.strip()
        if s.startswith(("ROOT", "JOINT")):
            kw, name = s.split()[0], s.split()[1]
            names.append(name)
            swapped = name.replace("Left", "\0").replace("Right", "Left").replace("\0", "Right")
            line = line.replace(f"{kw} {name}", f"{kw} {swapped}")
        elif s.startswith("OFFSET"):
            v = [float(x) for x in s.split()[1:]]
            v[0] = -v[0]
            line = line[:line.index("OFFSET")] + "OFFSET " + " ".join(f"{x:.6f}" for x in v)
        elif s.startswith("CHANNELS"):
            channels.append((names[-1], s.split()[2:]))
        out.append(line)
    # The bone at each place now carries the other side's name and its offsets mirrored, so
    # its own channels, mirrored, are the mirrored subject's motion.
    cols = [c for _, ch in channels for c in ch]
    out += text[i_motion:i_motion + 3]
    for line in text[i_motion + 3:]:
        if not line.strip():
            continue
        v = [float(x) for x in line.split()]
        w = [-x if c in ("Xposition", "Yrotation", "Zrotation") else x for x, c in zip(v, cols)]
        out.append(" ".join(f"{x:.6f}" for x in w))
    Path(dst).write_text("\n".join(out) + "\n")


def scale_time(src, dst, speed):
    lines = Path(src).read_text().splitlines()
    out = []
    for line in lines:
        if line.startswith("#") or line.startswith("time"):
            out.append(line)
            continue
        f = line.split(",")
        f[0] = repr(float(f[0]) / speed)
        out.append(",".join(f))
    Path(dst).write_text("\n".join(out) + "\n")


def make_reference(name, build, out, mapping_path, extra_args=()):
    """The case's reference, out/<name>_reference.csv: its clip (mirrored if the case says so)
    through dynfilter-bvh2ref with @p mapping_path, its window and @p extra_args, then its time
    scaled by the case's speed."""
    case = CASES[name]
    bvh_path = pr.CMU / case.bvh
    if case.mirrored:
        bvh_path = out / f"{name}.bvh"
        mirror_bvh(pr.CMU / case.bvh, bvh_path)
    ref = out / f"{name}_reference.csv"
    subprocess.run([str(build / "tools/bvh2ref/dynfilter-bvh2ref"), str(bvh_path), "--mapping",
                    str(mapping_path), "-o", str(ref), *extra_args, *window_args(case)],
                   check=True, capture_output=True)
    if case.speed != 1.0:
        scale_time(ref, ref, case.speed)
    return ref


# The re-filtered motion has left its reference once its joints' RMS error passes this (rad).
DEPARTURE_RAD = 0.01


def departure(filtered_csv, threshold_rad=DEPARTURE_RAD):
    """(The first time the joints' RMS tracking error (the err.* columns but the base's) passes
    @p threshold_rad, or None; the largest RMS over the file) of a dynfilter-offline output."""
    table = pr.read_table(filtered_csv)
    joints = [k for k in table if k.startswith("err.") and not k.startswith("err.base")]
    e = np.sqrt(np.mean([table[k] ** 2 for k in joints], axis=0))
    over = np.nonzero(e > threshold_rad)[0]
    return (float(table["time"][over[0]]) if len(over) else None), float(e.max())


def refilter(offline, reference, out, stem, filter_args, until_s=None):
    """Whether the filter gives its own output back: @p reference filtered with every tick
    written (up to @p until_s, e.g. the first re-seed: the motion before it is physically
    consistent), and that output filtered again as a reference with the same @p filter_args.
    Returns departure() of the second pass, and its re-seeding ticks and falls."""
    first = out / f"{stem}_every_tick.csv"
    subprocess.run([str(offline), str(reference), "-o", str(first), "--every-tick", *filter_args],
                   check=True, capture_output=True)
    if until_s is not None:
        lines = first.read_text().splitlines()
        keep = [lines[0]] + [l for l in lines[1:] if float(l.split(",", 1)[0]) < until_s]
        first.write_text("\n".join(keep) + "\n")
    second = out / f"{stem}_refiltered.csv"
    events = out / f"{stem}_refiltered.events.csv"
    subprocess.run([str(offline), str(first), "-o", str(second), "--skip-extra-columns", "--events-csv",
                    str(events), *filter_args], check=True, capture_output=True)
    departs_s, max_rms = departure(second)
    ticks, falls = pr.count_reseeds(events)
    return {"refilter_departs_s": departs_s, "refilter_max_rms_rad": max_rms, "refilter_reseed_ticks": ticks,
            "refilter_reseed_falls": falls}


def run_case(name, args, build, out):
    pr.MODEL_INFO = build / "tools" / "model_info" / "dynfilter-model-info"
    slope, backend = CASES[name].slope, CASES[name].backend
    mapping_path = (Path(args.mappings) if args.mappings else pr.CMU / "mappings") / CASES[name].mapping
    if args.cleanup:
        mapping_text = mapping_path.read_text()
        mapping_path = out / f"{name}_mapping.yaml"
        mapping_path.write_text(mapping_text + f"\ncleanup: {args.cleanup}\n")
    ref = make_reference(name, build, out, mapping_path, ["--report", str(out / f"{name}_bvh2ref.txt")])
    fil = out / f"{name}_{args.mode}.csv"
    events = out / f"{name}_{args.mode}.events.csv"
    bodies = out / f"{name}_{args.mode}.bodies.csv"
    offline = build / "tools/offline/dynfilter-offline"
    filter_args = ["--no-progress", "-q", "--mode", args.mode, "--backend", backend]
    if slope:
        heading, _ = pr.heading_of(ref)
        filter_args += ["--slope-deg", f"{slope:g}", "--slope-heading-deg", f"{heading:.1f}"]
    if args.config:
        filter_args += ["--config", args.config]
    subprocess.run([str(offline), str(ref), "-o", str(fil), "--events-csv", str(events), "--bodies-csv", str(bodies),
                    *filter_args], check=True, capture_output=True)
    model = pr.Model(pr.URDF)
    m = pr.metrics_of(fil, out / f"{name}_{args.mode}.contacts.csv", model)
    m.update(pr.motion_metrics(fil, ref, bodies, out / f"{name}_{args.mode}.contacts.csv", events, model))
    if args.refilter:
        with open(events, newline="") as f:
            times = [float(r["time"]) for r in csv.DictReader(f) if int(r["status"]) & 16]
        m.update(refilter(offline, ref, out, f"{name}_{args.mode}", filter_args,
                          times[0] - REFILTER_MARGIN_S if times else None))
    return name, m


COLUMNS = [
    ("reseed_ticks", "re-seeds", "{:d}"),
    ("reseed_falls", "falls", "{:d}"),
    ("joint_rms_rad", "joints (rad)", "{:.3f}"),
    ("joint_rms_legs_rad", "legs", "{:.3f}"),
    ("joint_rms_arms_rad", "arms", "{:.3f}"),
    ("joint_rms_spine_rad", "spine", "{:.3f}"),
    ("base_rms_m", "base (m)", "{:.3f}"),
    ("max_base_jump_mm", "base jump (mm)", "{:.0f}"),
    ("max_stance_skate_mm", "skate (mm)", "{:.0f}"),
    ("max_penetration_mm", "penetration (mm)", "{:.1f}"),
    ("frames_pulling_contact", "pulling", "{:d}"),
    ("frames_friction_violation", "cone", "{}"),
    ("frames_cop_outside", "CoP", "{}"),
    ("frames_torsion_violation", "torsion", "{}"),
    ("frames_torque_over_limit", "torque", "{}"),
    ("frames_pivoting", "pivoting", "{}"),
    ("frames_sliding", "sliding", "{}"),
    ("max_base_residual_rel_bw", "Eq. 12 base / weight", "{:.1e}"),
]
# --refilter: the filter's output before its first re-seed, filtered again.
REFILTER_COLUMNS = [
    ("refilter_departs_s", "re-filter departs (s)", "{:.3f}"),
    ("refilter_max_rms_rad", "re-filter joints max (rad)", "{:.3f}"),
    ("refilter_reseed_ticks", "re-filter re-seeds", "{:d}"),
    ("refilter_reseed_falls", "re-filter falls", "{:d}"),
]
# The re-filtered motion ends this long before the first re-seed: the figure falling into it
# is consistent, but the guard's teleport is not (s).
REFILTER_MARGIN_S = 0.05


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(pr.ROOT / "build" / "balance_matrix"))
    ap.add_argument("--build-dir", default=str(pr.ROOT / "build"))
    ap.add_argument("--mode", default="qp", choices=["qp", "paper"])
    ap.add_argument("--config")
    ap.add_argument("--cleanup", help="clean-up options for every clip, YAML flow map, e.g. "
                    "'{balance: false}' (the mapping's cleanup: section)")
    ap.add_argument("--mappings", help="folder of the clips' mappings (131_01.yaml, 01_01.yaml, 10_01.yaml) "
                    "instead of data/mocap/cmu/mappings, e.g. ones written by --suggest-mapping")
    ap.add_argument("--only", default=",".join(CASES))
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--markdown")
    ap.add_argument("--refilter", action="store_true",
                    help="also filter each case's output (every tick, up to its first re-seed) again as a "
                    "reference, and report when and how far that leaves it (a consistent motion should come "
                    "back unchanged)")
    args = ap.parse_args()
    columns = COLUMNS + (REFILTER_COLUMNS if args.refilter else [])
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    build = Path(args.build_dir).resolve()
    names = [n.strip() for n in args.only.split(",") if n.strip()]
    results = {}
    with cf.ProcessPoolExecutor(max_workers=args.jobs) as pool:
        for name, m in pool.map(run_case, names, [args] * len(names), [build] * len(names), [out] * len(names)):
            results[name] = m
            print(name, " ".join(f"{k}={m.get(k)}" for k, _, _ in columns), flush=True)
    L = ["| case | " + " | ".join(h for _, h, _ in columns) + " |", "|---|" + "---:|" * len(columns)]
    for name in names:
        L.append(f"| {name} | " + " | ".join(pr.fmt(results[name], k, f) for k, _, f in columns) + " |")
    total = sum(int(results[n]["reseed_ticks"]) for n in names)
    falls = sum(int(results[n]["reseed_falls"]) for n in names)
    L.append(f"\nre-seeding ticks over all cases: {total}, of which falls: {falls}")
    text = "\n".join(L) + "\n"
    print(text)
    (out / "matrix.md").write_text(text)
    if args.markdown:
        Path(args.markdown).write_text(text)


if __name__ == "__main__":
    main()
