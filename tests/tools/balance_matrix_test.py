"""tools/balance_matrix.py's mirrored case: mirroring a BVH twice gives the original back,
and the mirrored CMU walk retargeted to the human figure is the walk with its sides
swapped: in the raw retargeting (no clean-up) the left knee of the mirrored reference bends
as the right knee of the original and the base keeps its height, frame by frame and exactly. Also the matrix's re-seed
columns: every tick with the re-seed bit, and the falls among them by the guard's reason,
read from an events file whose quoted fields hold commas. And its --refilter check: the
departure time of a synthetic output, and the squat (a physically consistent motion once
filtered, both soles flat throughout) given back by the QP mode unchanged. Run with the venv's
python (ctest balance_matrix_mirror); exits 77 (skipped) when numpy is missing.

    build/venv/bin/python tests/tools/balance_matrix_test.py --bvh2ref build/tools/bvh2ref/dynfilter-bvh2ref \
        --offline build/tools/offline/dynfilter-offline
"""
import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SKIP = 77
BVH = ROOT / "data" / "mocap" / "cmu" / "131_01_start_walk_stop.bvh"
MAPPING = ROOT / "data" / "mocap" / "cmu" / "mappings" / "131_01.yaml"


def fail(text):
    print(f"FAIL: {text}")
    sys.exit(1)


def motion(path):
    lines = Path(path).read_text().splitlines()
    i = lines.index("MOTION")
    return lines[:i], [[float(v) for v in l.split()] for l in lines[i + 3:] if l.strip()]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bvh2ref", required=True)
    ap.add_argument("--offline", required=True)
    args = ap.parse_args()
    try:
        import numpy as np
    except ImportError:
        print("numpy missing: skipped")
        return SKIP
    sys.path.insert(0, str(ROOT / "tools"))
    import balance_matrix as bm
    import paper_results as pr

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        events = tmp / "events.csv"
        events.write_text(
            "time,tick,status,reseed_reason,qp_relaxation,qp_violated,base_error_m,base_rotation_rad,max_joint_error_rad\n"
            '1.0,480,528,joint error,1,"equality,unilateral",0.1,0.2,2.1\n'
            '1.5,720,512,,1,"equality,unilateral,friction",0.1,0.2,0.3\n'
            '2.0,960,16,base rotation error,0,"",0.3,1.01,0.5\n'
            '2.5,1200,16,base position error,0,"",0.51,0.4,0.5\n')
        if pr.count_reseeds(events) != (3, 2):
            fail(f"re-seeds and falls of the events file: {pr.count_reseeds(events)}, expected (3, 2)")
        # With the base's tilt and heading: an upright figure whose heading lags is no fall.
        split = tmp / "split.csv"
        split.write_text(
            "time,tick,status,reseed_reason,qp_relaxation,qp_violated,base_error_m,base_rotation_rad,"
            "max_joint_error_rad,base_tilt_rad,base_heading_rad\n"
            '2.0,960,16,base rotation error,0,"",0.3,1.01,0.5,0.93,-0.5\n'
            '2.5,1200,16,base rotation error,0,"",0.2,1.0,0.6,0.12,0.98\n'
            '3.0,1440,16,base position error,0,"",0.51,0.6,0.4,0.56,0.2\n'
            '3.5,1680,16,base position error,0,"",0.5,0.3,0.5,0.13,0.34\n')
        if pr.count_reseeds(split) != (4, 2):
            fail(f"re-seeds and falls by tilt: {pr.count_reseeds(split)}, expected (4, 2)")
        if pr.count_reseeds(tmp / "none.csv") != (0, 0):
            fail("a missing events file does not count as no re-seed")
        # Departure: the joints' RMS error (base columns left out) passes 0.01 rad at 0.2 s.
        synthetic = tmp / "synthetic.csv"
        synthetic.write_text("time,err.base_x,err.a,err.b\n0.0,0.5,0.0,0.0\n0.1,0.5,0.008,0.011\n"
                             "0.2,0.0,0.012,0.012\n0.3,0.0,0.0,0.03\n")
        departs_s, max_rms = bm.departure(synthetic)
        if departs_s != 0.2 or abs(max_rms - 0.03 / np.sqrt(2)) > 1e-12:
            fail(f"departure of the synthetic output: {departs_s} s, {max_rms} rad; expected 0.2 s, 0.0212 rad")
        squat = bm.refilter(args.offline, ROOT / "data" / "squat_reference.csv", tmp, "squat",
                            ["--no-progress", "-q", "--mode", "qp"])
        print(f"squat re-filtered: departs {squat['refilter_departs_s']}, joints max "
              f"{squat['refilter_max_rms_rad']:.2e} rad RMS, re-seeds {squat['refilter_reseed_ticks']}")
        if squat["refilter_departs_s"] is not None or squat["refilter_max_rms_rad"] > 2e-3 or \
                squat["refilter_reseed_ticks"]:
            fail(f"the squat's filtered motion filtered again is not given back: {squat}")

        once, twice = tmp / "once.bvh", tmp / "twice.bvh"
        bm.mirror_bvh(BVH, once)
        bm.mirror_bvh(once, twice)
        head0, m0 = motion(BVH)
        head1, m1 = motion(once)
        head2, m2 = motion(twice)
        if any("Left" in a and "Left" in b for a, b in zip(head0, head1) if "JOINT" in a):
            fail("mirroring kept a Left bone's name")
        if [l.split()[:2] for l in head2 if "JOINT" in l] != [l.split()[:2] for l in head0 if "JOINT" in l]:
            fail("mirroring twice does not give the original bone names back")
        if np.max(np.abs(np.array(m2) - np.array(m0))) > 1e-5:
            fail("mirroring twice does not give the original motion back")
        if np.max(np.abs(np.array(m1) - np.array(m0))) < 1e-3:
            fail("mirroring left the motion unchanged")

        refs = {}
        for name, bvh in (("original", BVH), ("mirrored", once)):
            out = tmp / f"{name}.csv"
            subprocess.run([args.bvh2ref, str(bvh), "--mapping", str(MAPPING), "--no-cleanup", "-o", str(out)],
                           check=True, capture_output=True)
            refs[name] = pr.read_table(out)
        a, b = refs["original"], refs["mirrored"]
        knee = float(np.sqrt(np.mean((b["l_knee"] - a["r_knee"]) ** 2)))
        same_side = float(np.sqrt(np.mean((b["l_knee"] - a["l_knee"]) ** 2)))
        height = float(np.sqrt(np.mean((b["base_z"] - a["base_z"]) ** 2)))
        print(f"knee RMS mirrored-left vs original-right {knee:.2e} rad "
              f"(same side {same_side:.4f}); base height RMS {height:.2e} m")
        # The raw retargeting (no clean-up) of a mirror-symmetric figure: the mirrored walk's
        # left knee is the original's right one to rounding.
        if knee > 1e-9:
            fail(f"the mirrored left knee does not follow the original right knee ({knee:.4f} rad RMS)")
        if same_side < 5 * knee:
            fail("the mirrored left knee follows the original left knee: sides not swapped")
        if height > 1e-9:
            fail(f"mirroring changed the base height by {height:.2e} m RMS")
    print("balance_matrix mirror ok")
    return 0


if __name__ == "__main__":
    sys.exit(main())
