#!/usr/bin/env python3
"""The CMU walk retargeted to TALOS (example-robot-data's talos_reduced.urdf, installed by
tools/install-deps.sh) and filtered in the QP mode with the defaults.

TALOS falls in this walk (its balance is issue 13's, as the human figure's), and while it
falls its ankle links touch the floor beside its soles: contact rows that depend on each
other. Checks that the contacts then give way as a rigid floor does and never all break:
- some tick used the floor's rungs (relaxation bits 8, 16, 32) — the case is exercised;
- no tick released every contact (bit 4): before the rungs, 131 ticks did, and a leg sank
  396 mm into the floor;
- the deepest penetration of any body is below 5 mm; no pulling contact; Eq. 12's base rows
  within 1e-8 of the body weight.

Prints "talos walk ok"; exit 77 (skipped) when the wheel is not installed.
"""
import argparse
import csv
import os
import re
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from example_robot_data import robots_root  # noqa: E402
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bvh2ref", required=True)
    ap.add_argument("--offline", required=True)
    ap.add_argument("--venv", required=True)
    args = ap.parse_args()
    root = robots_root(args.venv)
    if root is None:
        return 77
    urdf = os.path.join(root, "talos_data", "robots", "talos_reduced.urdf")
    cmu = os.path.join(REPO, "data", "mocap", "cmu")
    with tempfile.TemporaryDirectory() as tmp:
        ref = os.path.join(tmp, "talos_walk.csv")
        subprocess.run([args.bvh2ref, os.path.join(cmu, "131_01_start_walk_stop.bvh"),
                        "--mapping", os.path.join(cmu, "mappings", "131_01_talos.yaml"),
                        "--model", urdf, "--package-path", root, "-o", ref],
                       check=True, stdout=subprocess.DEVNULL)
        events = os.path.join(tmp, "events.csv")
        out = subprocess.run([args.offline, ref, "--model", urdf, "--package-path", root,
                              "--mode", "qp", "--no-progress", "-o", os.path.join(tmp, "out.csv"),
                              "--events-csv", events],
                             check=True, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True).stdout
        with open(events) as f:
            relaxations = [int(r["qp_relaxation"]) for r in csv.DictReader(f)]
    failures = []
    rungs = sum(1 for r in relaxations if r & (8 | 16 | 32))
    released = sum(1 for r in relaxations if r & 4)
    if rungs == 0:
        failures.append("no tick used the floor's rungs: the case is not exercised")
    if released:
        failures.append(f"{released} ticks released every contact")
    penetration = float(re.search(r"max penetration\s+([0-9.]+) mm", out).group(1))
    if not penetration < 5.0:
        failures.append(f"max penetration {penetration} mm (bound 5 mm)")
    pulling = int(re.search(r"(\d+) ticks with a pulling contact", out).group(1))
    if pulling:
        failures.append(f"{pulling} ticks with a pulling contact")
    base_rel = float(re.search(r"N on the base rows \(([0-9.eE+-]+) of body weight\)", out).group(1))
    if not base_rel <= 1e-8:
        failures.append(f"Eq. 12 base rows {base_rel} of body weight")
    print(f"talos walk: {rungs} ticks on the floor's rungs, {released} released, "
          f"penetration {penetration} mm, pulling {pulling}, base rows {base_rel:.1e} of body weight")
    if failures:
        print("\n".join(failures))
        return 1
    print("talos walk ok")
    return 0


if __name__ == "__main__":
    sys.exit(main())
