#!/usr/bin/env python3
"""A capture written in another exporter's conventions is read as the same motion.

The CMU walk (data/mocap/cmu/131_01_start_walk_stop.bvh) is re-written four ways, each the
same motion:
- "z-up": the world's axes relabelled so that up is +z and forward -y (exact: each channel
  keeps its value up to sign; the rotations' order becomes Y-Z-X);
- "mixamo": bones renamed as Mixamo exports them ("mixamorig:LeftUpLeg", ...), every
  rotation re-expressed in Z-X-Y order;
- "centimetres": every length in cm instead of the CMU unit (1/0.45 inch);
- "six channels": every joint with position channels holding its OFFSET (LAFAN1-style).
For each, `dynfilter-bvh2ref --suggest-mapping` must find the units, the up and forward axes
and the same link-to-bone pairs (renamed). The shipped mapping (131_01.yaml, the chain mode:
closed form per frame) given the variant's axes, unit and names must retarget it to the
original's reference within 1e-9 rad and m in every column of every frame (`--no-cleanup`).
The IK mode is not compared: at one frame of this walk the right arm's targets lie beyond
the shoulder's limit and its IK has two minima, which differences of 1e-16 select between.
Prints "bvh conventions ok".
"""
import argparse
import csv
import math
import os
import subprocess
import sys
import tempfile

import numpy as np
import yaml

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CMU = os.path.join(REPO, "data", "mocap", "cmu")
WALK = os.path.join(CMU, "131_01_start_walk_stop.bvh")
CMU_UNIT_M = 0.0254 / 0.45
MIXAMO = {"Hips": "Hips", "LHipJoint": "LeftHipJoint", "LeftHip": "LeftUpLeg", "LeftKnee": "LeftLeg",
          "LeftAnkle": "LeftFoot", "LeftToe": "LeftToeBase", "RHipJoint": "RightHipJoint",
          "RightHip": "RightUpLeg", "RightKnee": "RightLeg", "RightAnkle": "RightFoot",
          "RightToe": "RightToeBase", "lowerback": "Spine", "Chest": "Spine1", "Chest2": "Spine2",
          "lowerneck": "Neck", "Neck": "Neck1", "Head": "Head", "LeftCollar": "LeftShoulder",
          "LeftShoulder": "LeftArm", "LeftElbow": "LeftForeArm", "LeftWrist": "LeftHand",
          "lhand": "LeftHandMiddle1", "LFingers": "LeftHandMiddle2", "LThumb": "LeftHandThumb1",
          "RightCollar": "RightShoulder", "RightShoulder": "RightArm", "RightElbow": "RightForeArm",
          "RightWrist": "RightHand", "rhand": "RightHandMiddle1", "RFingers": "RightHandMiddle2",
          "RThumb": "RightHandThumb1"}


def axis_rotation(axis, deg):
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    i = "XYZ".index(axis)
    R = np.eye(3)
    j, k = (i + 1) % 3, (i + 2) % 3
    R[j, j], R[j, k], R[k, j], R[k, k] = c, -s, s, c
    return R


def euler_of(R, order):
    """Angles (deg) a, b, c with R = R_order[0](a) R_order[1](b) R_order[2](c) (BVH's
    channel order); a Tait-Bryan order of three distinct axes."""
    i, j, k = ("XYZ".index(a) for a in order)
    sign = 1.0 if (j - i) % 3 == 1 else -1.0
    b = math.asin(max(-1.0, min(1.0, sign * R[i, k])))
    a = math.atan2(-sign * R[j, k], R[k, k])
    c = math.atan2(-sign * R[i, j], R[i, i])
    return [math.degrees(a), math.degrees(b), math.degrees(c)]


def read_bvh(path):
    text = open(path).read().splitlines()
    m = next(i for i, l in enumerate(text) if l.strip() == "MOTION")
    joints = []  # [name, channels, offset]
    for line in text[:m]:
        s = line.split()
        if s and s[0] in ("ROOT", "JOINT"):
            joints.append([s[1], None, None])
        elif s and s[0] == "CHANNELS":
            joints[-1][1] = s[2:]
        elif s and s[0] == "OFFSET" and joints and joints[-1][2] is None:
            joints[-1][2] = np.array([float(x) for x in s[1:4]])
    frame_time = float(text[m + 2].split()[2])
    data = np.array([[float(x) for x in l.split()] for l in text[m + 3:] if l.strip()])
    return text[:m], joints, frame_time, data


def write_variant(src, dst, axes=None, scale=1.0, order=None, rename=None, six=False):
    """The capture at src written to dst with the world's axes relabelled by `axes` (old axis
    -> (new axis, sign), e.g. {"X": ("X", 1), "Y": ("Z", 1), "Z": ("Y", -1)} for z-up: exact,
    each channel keeps its value up to sign), lengths times `scale`, every rotation
    re-expressed in `order` (default: as read), bones renamed by `rename`, and with `six`
    every joint given position channels equal to its OFFSET."""
    axes = axes or {a: (a, 1) for a in "XYZ"}

    def moved(v):
        out = [0.0, 0.0, 0.0]
        for a, x in zip("XYZ", v):
            b, sign = axes[a]
            out["XYZ".index(b)] = sign * x * scale
        return out

    head, joints, frame_time, data = read_bvh(src)
    columns, col = [], 0
    for name, channels, offset in joints:
        block = data[:, col:col + len(channels)]
        col += len(channels)
        pos = np.tile(offset, (len(data), 1))
        has_pos = False
        for n, ch in enumerate(channels):
            if ch.endswith("position"):
                pos[:, "XYZ".index(ch[0])] = block[:, n]
                has_pos = True
        rotations = [(axes[ch[0]][0], axes[ch[0]][1], n) for n, ch in enumerate(channels) if ch.endswith("rotation")]
        names = [f"{a}rotation" for a, _, _ in rotations]
        angles = np.array([[sign * block[f, n] for _, sign, n in rotations] for f in range(len(data))])
        if order:
            for f in range(len(data)):
                R = np.eye(3)
                for (a, _, _), angle in zip(rotations, angles[f]):
                    R = R @ axis_rotation(a, angle)
                angles[f] = euler_of(R, order)
                Rb = (axis_rotation(order[0], angles[f][0]) @ axis_rotation(order[1], angles[f][1])
                      @ axis_rotation(order[2], angles[f][2]))
                assert np.abs(Rb - R).max() < 1e-12, "Euler round trip"
            names = [f"{a}rotation" for a in order]
        out = [angles]
        if has_pos or six:
            out.insert(0, np.array([moved(p) for p in pos]))
            names = ["Xposition", "Yposition", "Zposition"] + names
        columns.append((names, np.hstack(out)))
    lines, joint = [], -1
    for line in head:
        s = line.split()
        indent = line[:len(line) - len(line.lstrip())]
        if s and s[0] in ("ROOT", "JOINT"):
            joint += 1
            lines.append(f"{indent}{s[0]} {rename(s[1]) if rename else s[1]}")
        elif s and s[0] == "OFFSET":
            v = moved(float(x) for x in s[1:4])
            lines.append(f"{indent}OFFSET {v[0]!r} {v[1]!r} {v[2]!r}")
        elif s and s[0] == "CHANNELS":
            names = columns[joint][0]
            lines.append(f"{indent}CHANNELS {len(names)} {' '.join(names)}")
        else:
            lines.append(line)
    values = np.hstack([c[1] for c in columns])
    with open(dst, "w") as f:
        f.write("\n".join(lines) + f"\nMOTION\nFrames: {len(values)}\nFrame Time: {frame_time!r}\n")
        for row in values:
            f.write(" ".join(repr(float(x)) for x in row) + "\n")


def read_reference(path):
    rows = list(csv.reader(l for l in open(path) if not l.startswith("#")))
    return rows[0], np.array([[float(x) for x in r] for r in rows[1:] if r])


def shipped_mapping_for(variant, up, forward, unit, rename):
    """data/mocap/cmu/mappings/131_01.yaml (the chain mode: closed-form per frame) with the
    variant's axes, unit and bone names."""
    m = yaml.safe_load(open(os.path.join(CMU, "mappings", "131_01.yaml")))
    m["up_axis"], m["bvh_forward"], m["length_scale"] = up, forward, unit
    m["root"]["bvh"] = rename(m["root"]["bvh"])
    m["root"]["position"] = [rename(b) for b in m["root"]["position"]]
    for seg in m["segments"]:
        seg["bvh"] = rename(seg["bvh"])
    with open(variant, "w") as f:
        yaml.safe_dump(m, f)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bvh2ref", required=True)
    args = ap.parse_args()
    mixamo = lambda b: "mixamorig:" + MIXAMO[b]  # noqa: E731
    same = lambda b: b  # noqa: E731
    variants = {
        "original": (dict(), "+y", "+z", CMU_UNIT_M, same),
        "z-up": (dict(axes={"X": ("X", 1), "Y": ("Z", 1), "Z": ("Y", -1)}), "+z", "-y", CMU_UNIT_M, same),
        "mixamo": (dict(order="ZXY", rename=mixamo), "+y", "+z", CMU_UNIT_M, mixamo),
        "centimetres": (dict(scale=CMU_UNIT_M * 100.0), "+y", "+z", 0.01, same),
        "six channels": (dict(six=True), "+y", "+z", CMU_UNIT_M, same),
    }
    failures, refs = [], {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, (how, up, forward, unit, rename) in variants.items():
            tag = name.replace(" ", "_")
            bvh = os.path.join(tmp, tag + ".bvh")
            write_variant(WALK, bvh, **how)
            suggested = os.path.join(tmp, tag + "_suggested.yaml")
            subprocess.run([args.bvh2ref, bvh, "--suggest-mapping", suggested], check=True, stdout=subprocess.DEVNULL)
            m = yaml.safe_load(open(suggested))
            if (m["up_axis"], m["bvh_forward"]) != (up, forward):
                failures.append(f"{name}: axes {m['up_axis']} / {m['bvh_forward']}, want {up} / {forward}")
            if abs(m["length_scale"] - unit) > 1e-12 * unit:
                failures.append(f"{name}: length_scale {m['length_scale']}, want {unit}")
            pairs = {s["link"]: s["bvh"] for s in m["segments"]}
            pairs[m["root"]["link"]] = m["root"]["bvh"]
            shipped = os.path.join(tmp, tag + "_shipped.yaml")
            shipped_mapping_for(shipped, up, forward, unit, rename)
            out = os.path.join(tmp, tag + ".csv")
            subprocess.run([args.bvh2ref, bvh, "--mapping", shipped, "-o", out, "--no-cleanup"], check=True,
                           stdout=subprocess.DEVNULL)
            refs[name] = (pairs, rename) + read_reference(out)
        pairs0, _, header0, values0 = refs["original"]
        for name, (pairs, rename, header, values) in refs.items():
            want = {link: rename(bone) for link, bone in pairs0.items()}
            if pairs != want:
                failures.append(f"{name}: suggested pairs {pairs}, want {want}")
            if header != header0 or values.shape != values0.shape:
                failures.append(f"{name}: columns {len(header)} x {values.shape}, want {len(header0)} x {values0.shape}")
                continue
            diff = np.abs(values - values0).max(axis=0)
            worst = int(np.argmax(diff))
            print(f"{name}: largest difference {diff[worst]:.2e} ({header[worst]})")
            if diff[worst] > 1e-9:
                failures.append(f"{name}: {header[worst]} differs by {diff[worst]:.3e}")
    if failures:
        print("\n".join(failures))
        return 1
    print("bvh conventions ok")
    return 0


if __name__ == "__main__":
    sys.exit(main())
