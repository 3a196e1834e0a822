#!/usr/bin/env python3
"""Every robot description of the example-robot-data wheel (installed by
tools/install-deps.sh into the venv) through dynfilter-model-info, in both backends.

Checks:
- no description crashes a backend (a signal: segfault, abort on an engine's assertion);
- every description loads (exit 0), except the few that are wrong as shipped, which must be
  refused with the file, the line and the reason below (exit 2);
- the engines' own simulators step the robots with mimic joints (DART aborted on its mimic
  motor constraint for Talos and Tiago Pro) — exit 0 (stood) or 3 (fell), never a signal;
- dynfilter-crosscheck passes on every loadable description: DART
  and ODE agree on A, b, J, J̇·v and forward dynamics, and on the points where the robot
  standing 1 mm deep touches the ground (mesh hulls included: their ground contacts come
  from the hull's vertices in both backends, a cylinder's from its rims).

Prints "real descriptions ok" on success; exit 77 (skipped) when the wheel is not installed.
"""
import argparse
import glob
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from example_robot_data import robots_root  # noqa: E402

# Wrong as shipped: (file name, text the error must contain).
REFUSED = {
    "alex_psyonic_hands.urdf": 'leader joint "index_q1" is not defined',
    "romeo.urdf": "moves no mass",
    "romeo_laas_small.urdf": "is not positive semi-definite",
    "ur3.urdf": "no <link> elements",
}
# Described with their mimic joints, simulated by each engine for 50 ms.
SIMULATED = ["talos_full_v2.urdf", "tiago_pro.urdf"]


def run(tool, urdf, backend, seconds):
    p = subprocess.run([tool, "--model", urdf, "--backend", backend, "--seconds", str(seconds)],
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=300)
    return p.returncode, p.stdout


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--model-info", required=True)
    ap.add_argument("--venv", required=True)
    ap.add_argument("--crosscheck", help="dynfilter-crosscheck: also compare DART with ODE")
    args = ap.parse_args()
    root = robots_root(args.venv)
    if root is None:
        return 77
    urdfs = sorted(glob.glob(os.path.join(root, "**", "*.urdf"), recursive=True))
    failures = []
    loaded = crosschecked = 0
    for urdf in urdfs:
        name = os.path.basename(urdf)
        for backend in ("dart", "ode"):
            rc, out = run(args.model_info, urdf, backend, 0)
            where = f"{backend} {os.path.relpath(urdf, root)}"
            last = out.strip().splitlines()[-1] if out.strip() else ""
            if rc < 0:
                failures.append(f"{where}: killed by signal {-rc}: {last}")
            elif name in REFUSED:
                if rc != 2 or REFUSED[name] not in out or f"{name}:" not in out:
                    failures.append(f"{where}: expected exit 2 naming {name}:line and "
                                    f"'{REFUSED[name]}', got {rc}: {last}")
            elif rc != 0:
                failures.append(f"{where}: exit {rc}: {last}")
            else:
                loaded += 1
        if args.crosscheck and name not in REFUSED:
            p = subprocess.run([args.crosscheck, "--model", urdf, "--states", "3"],
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=300)
            if p.returncode != 0:
                bad = [l.strip() for l in p.stdout.splitlines() if l.rstrip().endswith("FAIL")]
                failures.append(f"crosscheck {os.path.relpath(urdf, root)}: exit {p.returncode}: "
                                f"{bad or p.stdout.strip().splitlines()[-1:]}")
            else:
                crosschecked += 1
    for name in SIMULATED:
        for urdf in (u for u in urdfs if os.path.basename(u) == name):
            for backend in ("dart", "ode"):
                rc, out = run(args.model_info, urdf, backend, 0.05)
                if rc not in (0, 3):
                    failures.append(f"{backend} {name} simulated: exit {rc}: {out.strip().splitlines()[-1:]}")
    print(f"{len(urdfs)} descriptions, {loaded} loads in a backend, {crosschecked} pass the "
          f"crosscheck, {len(failures)} failures")
    for f in failures:
        print("  FAIL", f)
    if failures or loaded == 0:
        return 1
    print("real descriptions ok")
    return 0


if __name__ == "__main__":
    sys.exit(main())
