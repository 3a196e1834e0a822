#!/usr/bin/env python3
"""Writes a kinematic squat reference for the human figure (the README demo's input).

The motion is made by hand, not by physics: the pelvis height follows the leg geometry so
that the soles stay near the floor, the knees bend twice as far as hips and ankles, the
arms swing in opposition and the waist turns. It is physically inconsistent (nothing says
the centre of mass stays over the feet or that the arm swing's reaction is balanced),
which is what the dynamics filter is for.

    python3 tools/make_squat_reference.py -o data/squat_reference.csv
"""
import argparse
import math
import xml.etree.ElementTree as ET
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def joint_offsets(urdf_path):
    """Joint names in file order, and the z offset of each joint origin."""
    tree = ET.parse(urdf_path)
    names, offsets = [], {}
    for joint in tree.getroot().iter("joint"):
        if joint.get("type") == "fixed":
            continue
        name = joint.get("name")
        names.append(name)
        origin = joint.find("origin")
        xyz = [float(x) for x in origin.get("xyz").split()] if origin is not None else [0, 0, 0]
        offsets[name] = xyz
    return names, offsets


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", default=str(ROOT / "data" / "squat_reference.csv"))
    parser.add_argument("--rate", type=float, default=120.0, help="frames per second")
    parser.add_argument("--seconds", type=float, default=4.0)
    parser.add_argument("--depth", type=float, default=0.35, help="peak hip flexion (rad)")
    args = parser.parse_args()

    urdf = ROOT / "models" / "human_figure.urdf"
    names, offsets = joint_offsets(urdf)
    thigh = -offsets["l_knee"][2]           # hip to knee (m)
    shank = -offsets["l_ankle_pitch"][2]    # knee to ankle (m)
    import json
    standing = json.loads((ROOT / "models" / "human_figure.json").read_text())["standing_pelvis_height_m"]
    ankle_height = standing - thigh - shank

    frames = int(round(args.seconds * args.rate)) + 1
    with open(args.output, "w", newline="\n") as out:
        out.write("# Kinematic squat with arm swing for models/human_figure.urdf, made by\n")
        out.write("# tools/make_squat_reference.py (physically inconsistent by construction).\n")
        out.write(",".join(["time", "base_x", "base_y", "base_z", "base_qw", "base_qx", "base_qy",
                            "base_qz"] + names) + "\n")
        for k in range(frames):
            t = k / args.rate
            s = 0.5 * args.depth * (1.0 - math.cos(2.0 * math.pi * 0.5 * t))
            q = {n: 0.0 for n in names}
            for side in ("l_", "r_"):
                q[side + "hip_pitch"] = -s
                q[side + "knee"] = 2.0 * s
                q[side + "ankle_pitch"] = -s
            q["l_shoulder_pitch"] = -0.6 * math.sin(2.0 * math.pi * 0.5 * t)
            q["r_shoulder_pitch"] = 0.6 * math.sin(2.0 * math.pi * 0.5 * t)
            q["l_elbow"] = q["r_elbow"] = 0.4 + 0.3 * math.sin(2.0 * math.pi * t)
            q["waist_yaw"] = 0.2 * math.sin(2.0 * math.pi * 0.5 * t)
            # Hip above the ankle: shank and thigh both tilt by s from vertical.
            base_x = (shank - thigh) * math.sin(s)
            base_z = ankle_height + (thigh + shank) * math.cos(s)
            row = [t, base_x, 0.0, base_z, 1.0, 0.0, 0.0, 0.0] + [q[n] for n in names]
            out.write(",".join("%.9g" % x for x in row) + "\n")


if __name__ == "__main__":
    main()
