#!/usr/bin/env python3
"""Probe of docs/balance.md §24, not part of the product and not tested.

Joins the outputs of kinodynamic_probe.py solved in overlapping windows (each later window
started from the previous one's state with --start-from) into one motion and one contact
plan. Window i contributes its frames from its seam on (the first from its start) up to the
next seam; a contact run held across a seam continues the earlier window's run (same pose).

  stitch_windows.py OUT SEAM_1 ... SEAM_K -- WIN_0 ... WIN_K
  (WIN_i.csv and WIN_i.plan.csv; OUT.csv and OUT.plan.csv are written)
"""
import csv
import sys


def main():
    args = sys.argv[1:]
    split = args.index("--")
    out, seams, wins = args[0], [float(s) for s in args[1:split]], args[split + 1:]
    if len(wins) != len(seams) + 1:
        sys.exit("need one more window than seams")
    bounds = [(-1e9 if i == 0 else seams[i - 1], 1e9 if i == len(seams) else seams[i]) for i in range(len(wins))]

    with open(out + ".csv", "w") as fh:
        w = csv.writer(fh)
        header = None
        for win, (a, b) in zip(wins, bounds):
            with open(win + ".csv") as src:
                rows = list(csv.reader(src))
            if header is None:
                header = rows[0]
                w.writerow(header)
            elif rows[0] != header:
                sys.exit("%s.csv: its columns differ from the first window's" % win)
            for r in rows[1:]:
                if a - 1e-6 <= float(r[0]) < b - 1e-6:
                    w.writerow(r)

    plan = []
    plan_header = None
    frame_s = 0.01  # a run starting within this of a seam continues across it (one 120 Hz frame)
    for win, (a, b) in zip(wins, bounds):
        with open(win + ".plan.csv") as src:
            rows = list(csv.reader(src))
        plan_header = rows[0]
        for r in rows[1:]:
            t0, t1 = float(r[1]), float(r[2])
            if t1 <= a + 1e-6 or t0 >= b - 1e-6:
                continue
            held = [p for p in plan if p[0] == r[0] and float(p[2]) >= a - 1e-6]
            if held and t0 <= a + frame_s:
                held[-1][2] = r[2] if t1 < b else repr(b)
                continue
            r = list(r)
            if t1 > b:
                r[2] = repr(b)
            plan.append(r)
    with open(out + ".plan.csv", "w") as fh:
        w = csv.writer(fh)
        w.writerow(plan_header)
        w.writerows(plan)


if __name__ == "__main__":
    main()
