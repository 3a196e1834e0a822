"""tools/diagnose_reseeds.py's evidence on small synthetic inputs with closed-form answers:
the capture point (ω = √(g / h)) of a CoM moving at constant speed leaves a square support
at a known time by known distances; a teleport in the re-seed's output row (and in the
previous re-seed's) does not leak into those numbers through the central differences;
re-seeds less than 0.1 s apart form one episode; a reference foot sliding within 5 mm of
the ground, or sinking more than 5 mm into it, is named, and one at rest or in the air is
not; a sole held in contact while the reference turns it about the vertical (by more than
20°, the filter's by less than half) is named, per run of held rows; a non-foot body within
2 cm of the ground is named; the soles are the bodies of the
reference's contact schedule; a joint beyond its URDF range and a
torque at its limit are named. The kinematics go through the tool's own Body on a small URDF.

With --build-dir, instead: the tool end to end on the soccer kick with that build's
dynfilter-bvh2ref and dynfilter-offline; diagnosis.json has one entry per re-seed episode
of the events CSV it wrote, each with the documented fields.

Run with the venv's python (ctest diagnose_reseeds_evidence, diagnose_reseeds_kick); exits
77 (skipped) without numpy or matplotlib.

    build/venv/bin/python tests/tools/diagnose_reseeds_test.py [--build-dir build]
"""
import argparse
import csv
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SKIP = 77

URDF = """<robot name="probe">
  <link name="pelvis"><inertial><mass value="10"/></inertial></link>
  <link name="l_foot">
    <inertial><mass value="1"/></inertial>
    <collision><geometry><box size="0.2 0.1 0.04"/></geometry></collision>
  </link>
  <link name="r_hand">
    <inertial><mass value="1"/></inertial>
    <collision><origin xyz="0 0 -0.3"/><geometry><sphere radius="0.05"/></geometry></collision>
  </link>
  <joint name="l_hip" type="revolute">
    <parent link="pelvis"/><child link="l_foot"/>
    <origin xyz="0 0.1 -0.9"/><axis xyz="0 1 0"/>
    <limit lower="-0.5" upper="0.5" effort="100" velocity="10"/>
  </joint>
  <joint name="r_shoulder" type="revolute">
    <parent link="pelvis"/><child link="r_hand"/>
    <origin xyz="0 -0.3 -0.2"/><axis xyz="1 0 0"/>
    <limit lower="-1" upper="2" effort="50" velocity="10"/>
  </joint>
</robot>
"""
FOOT_DROP = 0.92  # pelvis to the sole of l_foot at l_hip = 0
HAND_DROP = 0.55  # pelvis to the bottom of r_hand at r_shoulder = 0


class Failure(Exception):
    pass


def check(cond, text):
    if not cond:
        raise Failure(text)


def near(a, b, tol=1e-9):
    return abs(a - b) <= tol


# ----------------------------------------------------------------------------- capture point
OMEGA = 3.0
DT = 0.01


def ramp(dr, teleports=()):
    """200 rows at 100 Hz of a CoM at h = g / ω² moving +x at 0.3 m/s from x = -0.3: its
    capture point is at x = -0.2 + 0.3 t, outside the ±0.1 m square by 0.3 t - 0.3 (t > 1).
    teleports: (row, dx): from that row on the CoM is dx further (a re-seed's jump)."""
    np = dr.np
    t = np.arange(200) / 100
    c = np.zeros((len(t), 3))
    c[:, 0] = -0.3 + 0.3 * t
    c[:, 2] = dr.G / OMEGA ** 2
    for row, dx in teleports:
        c[row:, 0] += dx
    return t, c, np.gradient(c, t, axis=0)


def square(dr):
    # Interior and duplicate points too: the hull keeps the four corners.
    pts = [(-0.1, -0.1), (0.1, -0.1), (0.1, 0.1), (-0.1, 0.1), (0.0, 0.05), (0.1, 0.1), (0.02, -0.1)]
    return dr.hull(dr.np.array(pts))


def test_capture_point(dr):
    np = dr.np
    h = dr.G / OMEGA ** 2
    cp = dr.capture_point(np.array([0.2, -0.1, h + 0.5]), np.array([0.3, 0.6, -2.0]), 0.5)
    check(near(cp[0], 0.3) and near(cp[1], 0.1), f"capture point {cp}, expected (0.3, 0.1) with ω = 3")
    low = dr.capture_point(np.array([0.0, 0.0, 0.1]), np.array([1.0, 0.0, 0.0]), 0.0)
    check(near(low[0], math.sqrt(0.2 / dr.G)), f"a CoM 0.1 m high is taken at 0.2 m: {low[0]}")


def test_capture_exit(dr):
    t, c, cd = ramp(dr)
    sq = square(dr)
    check(len(sq) == 4, f"hull of the square: {sq}")
    ks, k_end = dr.window_rows(t, 1.5, -math.inf, DT)
    first, worst = dr.capture_exit(ks, t, c, cd, lambda k: sq, lambda p: 0.0)
    # 1 cm outside at t = 31/30 s: first row after it 1.04 s (1.2 cm); last row 1.48 s.
    check(first is not None and near(first[0], 1.04) and near(first[1], 0.012),
          f"first exit {first}, expected (1.04 s, 0.012 m)")
    check(near(worst, 0.144), f"worst {worst}, expected 0.144 m at 1.48 s")
    first, worst = dr.capture_exit(range(90, 100), t, c, cd, lambda k: sq, lambda p: 0.0)
    check(first is None and worst == 0.0, f"inside the support before 1 s: {first}, {worst}")
    # Without a support (no contact) the distance is infinite: counted as an exit, not a worst.
    first, worst = dr.capture_exit(range(10, 20), t, c, cd, lambda k: dr.np.zeros((0, 2)), lambda p: 0.0)
    check(first == (t[10], math.inf) and worst == 0.0, f"no support: {first}, {worst}")


def test_window_rows(dr):
    t = dr.np.arange(200) / 100
    ks, k_end = dr.window_rows(t, 1.5, -math.inf, DT)
    check((ks.start, ks.stop, k_end) == (100, 149, 150), f"window {ks}, re-seed row {k_end}")
    ks, k_end = dr.window_rows(t, 1.495, -math.inf, DT)
    check((ks.start, ks.stop, k_end) == (100, 149, 150), f"re-seed between rows: window {ks}, row {k_end}")
    ks, _ = dr.window_rows(t, 1.5, 1.295, DT)
    check((ks.start, ks.stop) == (132, 149), f"after a re-seed at 1.295 s: window {ks}")
    ks, _ = dr.window_rows(t, 0.005, -math.inf, DT)
    check(len(ks) == 0, f"re-seed on the first row: window {ks}")


def test_teleport_does_not_leak(dr):
    sq = square(dr)
    for t_r in (1.5, 1.495):
        t, c, cd = ramp(dr, teleports=[(150, 5.0)])
        ks, k_end = dr.window_rows(t, t_r, -math.inf, DT)
        first, worst = dr.capture_exit(ks, t, c, cd, lambda k: sq, lambda p: 0.0)
        check(near(first[0], 1.04) and near(first[1], 0.012) and near(worst, 0.144),
              f"teleport in the re-seed's row (t_r = {t_r}) leaks: first {first}, worst {worst}")
        # The same rows up to the re-seed's would see it (this test can tell).
        _, seen = dr.capture_exit(range(ks.start, k_end), t, c, cd, lambda k: sq, lambda p: 0.0)
        check(seen > 50.0, f"the teleport is not in the central difference before its row: {seen}")
    # The previous re-seed (1.295 s) put the figure 3 m back in row 130.
    t, c, cd = ramp(dr, teleports=[(0, -3.0), (130, 3.0), (150, 5.0)])
    ks, _ = dr.window_rows(t, 1.5, 1.295, DT)
    first, worst = dr.capture_exit(ks, t, c, cd, lambda k: sq, lambda p: 0.0)
    check(near(first[0], 1.32) and near(first[1], 0.096) and near(worst, 0.144),
          f"previous re-seed's teleport leaks: first {first}, worst {worst}")


# ----------------------------------------------------------------------------- episodes
def test_episodes(dr, tmp):
    events = tmp / "events.csv"
    events.write_text(
        "time,tick,status,reseed_reason,qp_relaxation,qp_violated,base_error_m,base_rotation_rad,"
        "max_joint_error_rad,base_tilt_rad,base_heading_rad\n"
        '1.00,480,16,base rotation error,0,"",0.3,1.0,0.5,0.9,0.1\n'
        '1.05,504,528,joint error,1,"equality,cop",0.1,0.2,2.1,0.1,0.0\n'
        '1.10,528,512,,1,"torque",0.1,0.2,0.3,0.1,0.0\n'
        '1.14,547,16,base rotation error,0,"",0.3,1.0,0.5,0.9,0.1\n'
        '1.30,624,16,base position error,0,"",0.6,0.3,0.5,0.2,0.0\n'
        '1.395,670,16,base position error,0,"",0.6,0.3,0.5,0.2,0.0\n'
        '2.00,960,256,,1,"",0.1,0.2,0.3,0.1,0.0\n')
    eps, relaxed = dr.episodes(events)
    got = [(ep["times"], ep["reasons"], ep["row"]["time"]) for ep in eps]
    want = [([1.00, 1.05, 1.14], {"base rotation error", "joint error"}, "1.00"),
            ([1.30, 1.395], {"base position error"}, "1.30")]
    check(got == want, f"episodes {got}, expected {want}")
    check([(r[0], r[1], r[2]) for r in relaxed] ==
          [(1.05, 528, "equality,cop"), (1.10, 512, "torque"), (2.00, 256, "")],
          f"relaxed ticks {relaxed}")


# ----------------------------------------------------------------------------- reference body
def pose(body, x, z, hip=0.0, shoulder=0.0):
    return body.fk([x, 0.0, z], [1.0, 0.0, 0.0, 0.0], {"l_hip": hip, "r_shoulder": shoulder})


def test_foot_slide_and_sink(dr, body):
    times = [k * DT for k in range(10)]

    def findings(speed, sole_z, ground=0.0):
        states = [pose(body, speed * t, FOOT_DROP + sole_z) for t in times]
        track = dr.foot_track(body, states, times, "l_foot", lambda p: ground)
        return dr.foot_findings("l_foot", track)

    track = dr.foot_track(body, [pose(body, 0.0, FOOT_DROP + 0.002)], [0.0], "l_foot", lambda p: 0.0)
    check(near(track[0][2], 0.002) and near(track[0][1][1], 0.1) and near(track[0][1][2], 0.022),
          f"foot track at rest: {track}")
    got = findings(0.3, 0.002)
    check(got == ["reference l_foot slides at up to 0.30 m/s in stance"], f"sliding foot 2 mm up: {got}")
    got = findings(0.0, 0.002)
    check(got == [], f"foot at rest: {got}")
    got = findings(0.1, 0.0)
    check(got == [], f"foot creeping at 0.1 m/s: {got}")
    got = findings(0.3, 0.02)
    check(got == [], f"foot swinging 2 cm up: {got}")
    got = findings(0.0, -0.008)
    check(got == ["reference l_foot sinks 8 mm"], f"foot 8 mm into the ground: {got}")
    got = findings(0.0, -0.004)
    check(got == [], f"foot 4 mm into the ground: {got}")
    # Heights are above the ground, here a platform 0.5 m high.
    got = findings(0.3, 0.502, ground=0.5)
    check(got == ["reference l_foot slides at up to 0.30 m/s in stance"], f"sliding on the platform: {got}")
    got = findings(0.0, 0.49, ground=0.5)
    check(got == ["reference l_foot sinks 10 mm"], f"foot 10 mm into the platform: {got}")


def test_held_while_turned(dr, body):
    # The reference turns the whole probe about the vertical by 0.6 rad over 10 rows (its
    # l_foot with it); the filter's stays. Headings wrap past ±π without a false turn.
    def turned(yaw0, total):
        out = []
        for k in range(10):
            a = yaw0 + total * k / 9
            out.append(body.fk([0.0, 0.0, FOOT_DROP], [math.cos(a / 2), 0.0, 0.0, math.sin(a / 2)], {}))
        return out

    times = [k * DT for k in range(10)]
    ref, still = turned(0.0, 0.6), turned(0.0, 0.0)
    got = dr.held_while_turned("l_foot", times, [True] * 10, ref, still)
    check(got == ["l_foot held in contact 0.00–0.09 s while the reference turns it by 34° (the filter's by 0°)"],
          f"held while turned: {got}")
    check(dr.held_while_turned("l_foot", times, [False] * 10, ref, still) == [], "not held: no finding")
    check(dr.held_while_turned("l_foot", times, [True] * 10, ref, turned(0.0, 0.4)) == [],
          "the filter turning it by 0.4 rad of the reference's 0.6 is no finding")
    check(dr.held_while_turned("l_foot", times, [True] * 10, turned(0.0, 0.3), still) == [],
          "a turn of 0.3 rad (17°) is within the bound")
    got = dr.held_while_turned("l_foot", times, [True] * 10, turned(math.pi - 0.1, 0.6), turned(math.pi - 0.1, 0.0))
    check(len(got) == 1 and "by 34°" in got[0], f"turning through ±π: {got}")
    # Held over rows 0-4 and 6-9: two runs, each with its own share of the turn (0.27 and
    # 0.2 rad): neither is named; over 0-7 the run turns by 0.47 rad (27°).
    check(dr.held_while_turned("l_foot", times, [k != 5 for k in range(10)], ref, still) == [], "split runs")
    got = dr.held_while_turned("l_foot", times, [k < 8 for k in range(10)], ref, still)
    check(got == ["l_foot held in contact 0.00–0.07 s while the reference turns it by 27° (the filter's by 0°)"],
          f"a run over rows 0-7: {got}")


def test_soles(dr, body, tmp):
    # From the contact schedule beside the reference (its columns that are links of the
    # model), whatever their names; without one, the links named like a foot.
    ref = tmp / "probe_reference.csv"
    (tmp / "probe_reference.stance.csv").write_text("time,r_hand,no_such_link\n0,1,0\n")
    check(dr.soles_of(ref, body) == ["r_hand"], f"soles from the schedule: {dr.soles_of(ref, body)}")
    check(dr.soles_of(tmp / "other_reference.csv", body) == ["l_foot"], "soles without a schedule")
    check(dr.foot_findings("l_foot", []) == [], "an empty window has no findings")


def test_reference_contacts(dr, body):
    ground = lambda p: 0.0  # noqa: E731
    touched = dr.touching(body, [pose(body, 0.0, 1.0), pose(body, 0.0, HAND_DROP + 0.01)], ["r_hand"], ground)
    check(touched == {"r_hand"}, f"hand 1 cm above the ground: {touched}")
    touched = dr.touching(body, [pose(body, 0.0, HAND_DROP + 0.03)], ["r_hand"], ground)
    check(touched == set(), f"hand 3 cm above the ground: {touched}")
    # Raised sideways by the shoulder (90° about x): 0.3 m higher.
    touched = dr.touching(body, [pose(body, 0.0, HAND_DROP + 0.01, shoulder=-math.pi / 2)], ["r_hand"], ground)
    check(touched == set(), f"hand raised by the shoulder: {touched}")


def test_limits(dr, body):
    check(body.lower == {"l_hip": -0.5, "r_shoulder": -1.0} and body.upper == {"l_hip": 0.5, "r_shoulder": 2.0},
          f"URDF ranges {body.lower} {body.upper}")
    got = dr.joints_beyond(body.lower, body.upper, {"l_hip": 0.7, "r_shoulder": -1.03})
    check(len(got) == 1 and got[0][1] == "l_hip" and near(got[0][0], 0.2), f"l_hip 0.2 rad beyond: {got}")
    got = dr.joints_beyond(body.lower, body.upper, {"l_hip": -0.6, "r_shoulder": 2.3})
    check([j for _, j in got] == ["r_shoulder", "l_hip"] and near(got[0][0], 0.3) and near(got[1][0], 0.1),
          f"both beyond, largest first: {got}")
    check(dr.joints_beyond(body.lower, body.upper, {"r_shoulder": 1.9}) == [], "within range flagged")
    check(body.tree.effort == {"l_hip": 100.0, "r_shoulder": 50.0}, f"URDF efforts {body.tree.effort}")
    np = dr.np
    table = {"l_hip.tau": np.array([99.5, -100.0, 99.2, 10, 10, 10, 10, 10, 10, 10]),
             "r_shoulder.tau": np.array([49.0] * 10)}
    got = dr.saturated_torques(table, body.tree.effort, list(range(10)))
    check(len(got) == 1 and got[0][1] == "l_hip" and near(got[0][0], 0.3), f"l_hip at its limit 30 %: {got}")
    got = dr.saturated_torques(table, body.tree.effort, list(range(3, 10)))
    check(got == [], f"rows without saturation: {got}")


# ----------------------------------------------------------------------------- end to end
def end_to_end(build_dir):
    for exe in ("tools/offline/dynfilter-offline", "tools/bvh2ref/dynfilter-bvh2ref"):
        if not (build_dir / exe).exists():
            print(f"FAIL: no {build_dir / exe} (build it first)")
            return 1
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        run = subprocess.run([sys.executable, str(ROOT / "tools" / "diagnose_reseeds.py"), "--only", "kick",
                              "--out", str(out), "--build-dir", str(build_dir)],
                             capture_output=True, text=True)
        if run.returncode != 0:
            print(run.stdout + run.stderr)
            print(f"FAIL: diagnose_reseeds.py exited {run.returncode}")
            return 1
        with open(out / "kick_qp.events.csv", newline="") as f:
            reseeds = [r for r in csv.DictReader(f) if int(r["status"]) & 16]
        groups = []
        for r in reseeds:
            if groups and float(r["time"]) - float(groups[-1][-1]["time"]) < 0.1:
                groups[-1].append(r)
            else:
                groups.append([r])
        report = json.loads((out / "diagnosis.json").read_text())
        md = (out / "diagnosis.md").read_text().splitlines()
    errors = []
    if len(report) != len(groups):
        errors.append(f"{len(report)} entries for {len(groups)} re-seed episodes")
    if len(md) != 2 + len(report):
        errors.append(f"diagnosis.md has {len(md) - 2} rows for {len(report)} entries")
    if f"kick: {len(groups)} re-seed episodes" not in run.stdout:
        errors.append(f"the tool's summary says otherwise: {run.stdout.splitlines()[:1]}")
    for entry, g in zip(report, groups):
        want = {"clip": "kick", "time_s": round(float(g[0]["time"]), 3), "count": len(g),
                "reason": ", ".join(sorted({r["reseed_reason"] for r in g}))}
        if set(entry) != set(want) | {"findings"}:
            errors.append(f"fields {sorted(entry)}")
        elif {k: entry[k] for k in want} != want:
            errors.append(f"entry {entry}, expected {want}")
        elif not (isinstance(entry["findings"], list) and all(isinstance(s, str) and s for s in entry["findings"])):
            errors.append(f"findings {entry['findings']!r}")
    for e in errors:
        print(f"FAIL: {e}")
    if errors:
        return 1
    print(f"kick: {len(report)} re-seed episodes, each entry as its events rows say")
    print("diagnose_reseeds kick ok")
    return 0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build-dir", help="run the tool end to end on the kick with this build's binaries")
    args = ap.parse_args()
    try:
        import numpy  # noqa: F401
        import matplotlib  # noqa: F401  (paper_results, which the tool imports, needs it)
    except ImportError as e:
        print(f"{e}: skipped")
        return SKIP
    if args.build_dir:
        return end_to_end(Path(args.build_dir).resolve())
    sys.path.insert(0, str(ROOT / "tools"))
    import diagnose_reseeds as dr
    failed = 0
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "probe.urdf").write_text(URDF)
        body = dr.Body(tmp / "probe.urdf")
        tests = [(test_capture_point, ()), (test_capture_exit, ()), (test_window_rows, ()),
                 (test_teleport_does_not_leak, ()), (test_episodes, (tmp,)),
                 (test_foot_slide_and_sink, (body,)), (test_held_while_turned, (body,)),
                 (test_reference_contacts, (body,)), (test_limits, (body,)),
                 (test_soles, (body, tmp))]
        for fn, extra in tests:
            try:
                fn(dr, *extra)
                print(f"ok   {fn.__name__}")
            except Failure as e:
                failed += 1
                print(f"FAIL {fn.__name__}: {e}")
            except Exception as e:  # a broken tool may raise rather than answer wrong
                failed += 1
                print(f"FAIL {fn.__name__}: {type(e).__name__}: {e}")
    if failed:
        print(f"{failed} of {len(tests)} failed")
        return 1
    print("diagnose_reseeds evidence ok")
    return 0


if __name__ == "__main__":
    sys.exit(main())
