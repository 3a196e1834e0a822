#!/usr/bin/env python3
"""dynfilter-bvh2ref --suggest-mapping on two public humanoids of the example-robot-data
wheel (installed by tools/install-deps.sh): the mapping found from the structure of the
CMU walk's skeleton and of the robot pairs the same links with the same BVH joints as the
mappings written by hand (data/mocap/cmu/mappings/131_01_g1.yaml, 131_01_talos.yaml), with
the same units, axes and base position point (within 2.5 cm: the written points are
rounded, TALOS's hip joints sit at x = -0.02 m). Then the jump, which has no
G1 mapping of its own, is retargeted onto the G1 with its suggested mapping: every target
is met within 30 mm RMS. iCub, whose base frame faces -x and whose link frames are turned
at q = 0, keeps its left leg left and is retargeted within 5 deg (chest) and 80 mm (feet) RMS;
Alex, an upper body standing on its hands, is refused.

Prints "suggest mapping ok"; exit 77 (skipped) when the wheel is not installed.
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile

import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from example_robot_data import robots_root  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
CMU = os.path.join(REPO, "data", "mocap", "cmu")


def pairs(mapping):
    out = {mapping["root"]["link"]: mapping["root"]["bvh"]}
    out.update({s["link"]: s["bvh"] for s in mapping["segments"]})
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bvh2ref", required=True)
    ap.add_argument("--venv", required=True)
    args = ap.parse_args()
    root = robots_root(args.venv)
    if root is None:
        return 77
    robots = {"131_01_g1.yaml": os.path.join(root, "g1_description", "urdf", "g1_29dof_rev_1_0.urdf"),
              "131_01_talos.yaml": os.path.join(root, "talos_data", "robots", "talos_reduced.urdf")}
    failures = []
    with tempfile.TemporaryDirectory() as tmp:
        for shipped, urdf in robots.items():
            out = os.path.join(tmp, "suggested_" + shipped)
            subprocess.run([args.bvh2ref, os.path.join(CMU, "131_01_start_walk_stop.bvh"), "--model", urdf,
                            "--package-path", root, "--suggest-mapping", out],
                           check=True, stdout=subprocess.DEVNULL)
            with open(out) as f:
                got = yaml.safe_load(f)
            with open(os.path.join(CMU, "mappings", shipped)) as f:
                want = yaml.safe_load(f)
            if pairs(got) != pairs(want):
                failures.append(f"{shipped}: suggested {pairs(got)}, written {pairs(want)}")
            for key in ("length_scale", "up_axis", "bvh_forward", "mode"):
                if got[key] != want[key] and not (key == "length_scale" and abs(got[key] - want[key]) < 1e-12):
                    failures.append(f"{shipped}: {key} {got[key]} (written: {want[key]})")
            if got["root"]["position"] != want["root"]["position"]:
                failures.append(f"{shipped}: root.position {got['root']['position']}")
            offset = [a - b for a, b in zip(got["root"]["offset_xyz"], want["root"]["offset_xyz"])]
            if max(abs(x) for x in offset) > 0.025:  # the written ones are rounded (TALOS hips at x = -0.02)
                failures.append(f"{shipped}: root.offset_xyz {got['root']['offset_xyz']} "
                                f"(written: {want['root']['offset_xyz']})")
            print(f"{shipped}: {len(pairs(got))} links paired as written, base point "
                  f"{got['root']['offset_xyz']} (written {want['root']['offset_xyz']})")

        g1 = robots["131_01_g1.yaml"]
        jump_map = os.path.join(tmp, "jump_g1.yaml")
        subprocess.run([args.bvh2ref, os.path.join(CMU, "01_01_forward_jumps.bvh"), "--model", g1,
                        "--suggest-mapping", jump_map], check=True, stdout=subprocess.DEVNULL)
        report = subprocess.run([args.bvh2ref, os.path.join(CMU, "01_01_forward_jumps.bvh"), "--model", g1,
                                 "--mapping", jump_map, "--no-cleanup",  # the IK's table: before the clean-up
                                 "-o", os.path.join(tmp, "jump_g1.csv")],
                                check=True, stdout=subprocess.PIPE, text=True).stdout
        targets = report.split("IK targets", 1)[1].split("joint limits", 1)[0]  # that table only
        rms = [float(x) for x in re.findall(r"^\s+\S+\s+([0-9.]+) /\s+[0-9.]+", targets, re.M)]
        if len(rms) < 9 or max(rms) > 30.0:
            failures.append(f"jump on the G1: target position RMS {rms} mm (bound 30)")
        print(f"jump on the G1 with its suggested mapping: target position RMS up to {max(rms):.1f} mm")

        # iCub's base frame faces -x and its link frames are turned at q = 0: its left leg is
        # still the capture's left, and the IK meets the targets (chest 58.7 deg and feet
        # 375 mm RMS off when the frames' turn was not taken in).
        icub = os.path.join(root, "icub_description", "robots", "icub_reduced.urdf")
        icub_map = os.path.join(tmp, "walk_icub.yaml")
        subprocess.run([args.bvh2ref, os.path.join(CMU, "131_01_start_walk_stop.bvh"), "--model", icub,
                        "--package-path", root, "--suggest-mapping", icub_map],
                       check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        with open(icub_map) as f:
            got = yaml.safe_load(f)
        want_pairs = {"l_lower_leg": "LeftKnee", "l_foot": "LeftAnkle", "r_lower_leg": "RightKnee",
                      "r_foot": "RightAnkle", "l_hand": "LeftWrist", "r_hand": "RightWrist"}
        wrong = {k: pairs(got).get(k) for k, v in want_pairs.items() if pairs(got).get(k) != v}
        if wrong or got["bvh_forward"] != "-z":
            failures.append(f"iCub: pairs off {wrong}, bvh_forward {got['bvh_forward']} (want -z)")
        report = subprocess.run([args.bvh2ref, os.path.join(CMU, "131_01_start_walk_stop.bvh"), "--model", icub,
                                 "--package-path", root, "--mapping", icub_map, "--no-cleanup",
                                 "-o", os.path.join(tmp, "walk_icub.csv")],
                                check=True, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True).stdout
        targets = report.split("IK targets", 1)[1].split("joint limits", 1)[0]
        chest = re.search(r"^\s+chest\s+-\s+([0-9.]+) /", targets, re.M)
        feet = [float(x) for x in re.findall(r"^\s+[lr]_foot\s+([0-9.]+) /", targets, re.M)]
        if chest is None or float(chest.group(1)) > 5.0 or len(feet) != 2 or max(feet) > 80.0:
            failures.append(f"iCub: chest orientation RMS {chest and chest.group(1)} deg (bound 5), "
                            f"feet {feet} mm (bound 80)")
        print(f"iCub: left leg left, bvh_forward {got['bvh_forward']}, chest "
              f"{chest and chest.group(1)} deg, feet {feet} mm RMS")

        # Alex, an upper body whose hands reach below its pelvis: refused, not mapped arms-as-legs.
        alex = os.path.join(root, "alex_description", "urdf", "alex_nub_hands.urdf")
        if os.path.exists(alex):
            r = subprocess.run([args.bvh2ref, os.path.join(CMU, "131_01_start_walk_stop.bvh"), "--model", alex,
                                "--package-path", root, "--suggest-mapping", os.path.join(tmp, "alex.yaml")],
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            if r.returncode == 0 or "arms, not legs" not in r.stderr:
                failures.append(f"Alex: exit {r.returncode}, {r.stderr.strip()[-200:]}")
            print(f"Alex: refused ({r.stderr.strip().splitlines()[-1][-80:] if r.stderr.strip() else ''})")
    if failures:
        print("\n".join(failures))
        return 1
    print("suggest mapping ok")
    return 0


if __name__ == "__main__":
    sys.exit(main())
