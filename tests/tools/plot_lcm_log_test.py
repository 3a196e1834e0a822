"""tools/plot_lcm_log.py on a small synthetic log: writes a few messages of each dynfilter
type with lcm.EventLog (known values), runs the tool on it as a process and checks the PNG
(signature, size, dimensions) and the printed summary (counts, duration, max tick_us,
missed ticks, rejected frames, contact forces). Run with the venv's python (ctest
plot_lcm_log); exits 77 (skipped) when matplotlib or numpy is missing from the venv.

    build/venv/bin/python tests/tools/plot_lcm_log_test.py [--types-path DIR] [--work-dir DIR]
"""
import argparse
import re
import struct
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
TOOL = ROOT / "tools" / "plot_lcm_log.py"
SKIP = 77

JOINTS = ["l_hip_pitch", "l_knee", "l_ankle_pitch", "waist_yaw", "r_knee"]
T0 = 5_000_000_000  # µs, a steady clock's value
TICK_US = [110.0, 120.5, 987.5, 130.0]  # max 987.5
MISSED = [0, 0, 2, 3]
REJECTED = [0, 1, 1, 4]
N_STATE = 5
N_REFERENCE = 3


def fail(text):
    print("FAIL: " + text)
    sys.exit(1)


def offset(joint):
    """Each joint's values are offset by its index: a mix-up of names shows."""
    return float(JOINTS.index(joint))


def write_log(path, dynfilter, lcm):
    log = lcm.EventLog(str(path), "w", overwrite=True)

    def put(channel, utime, msg):
        log.write_event(utime, channel, msg.encode())

    # The reference sends its joints in another order than the model's.
    ref_names = list(reversed(JOINTS))
    for i in range(N_REFERENCE):
        m = dynfilter.reference_frame_t()
        m.utime = T0 + 100_000 * i
        m.sequence = i
        m.base_position = [0.0, 0.0, 0.9]
        m.base_quaternion = [1.0, 0.0, 0.0, 0.0]
        m.task_quaternion = [1.0, 0.0, 0.0, 0.0]
        m.num_joints = len(ref_names)
        m.joint_names = ref_names
        m.q = [offset(name) + 0.1 * i for name in ref_names]
        m.qd = [0.0] * len(ref_names)
        m.qdd = [0.0] * len(ref_names)
        m.num_contact_hints = 0
        put("DYNFILTER_REFERENCE", m.utime, m)
    for i in range(N_STATE):
        m = dynfilter.robot_state_t()
        m.utime = T0 + 50_000 + 100_000 * i
        m.base_quaternion = [1.0, 0.0, 0.0, 0.0]
        m.num_joints = len(JOINTS)
        m.joint_names = JOINTS
        m.q = [offset(name) + 0.09 * i for name in JOINTS]
        m.qd = [0.0] * len(JOINTS)
        m.tau = [0.0] * len(JOINTS)
        put("DYNFILTER_ROBOT_STATE", m.utime, m)
    for i in range(len(TICK_US)):
        utime = T0 + 20_000 + 100_000 * i
        c = dynfilter.torque_command_t()
        c.utime = utime
        c.base_quaternion = [1.0, 0.0, 0.0, 0.0]
        c.num_joints = len(JOINTS)
        c.joint_names = JOINTS
        c.tau = [-(offset(name) + i + 1) for name in JOINTS]
        c.q = [offset(name) + 0.1 * i for name in JOINTS]
        c.qd = [0.0] * len(JOINTS)
        c.qdd = [0.0] * len(JOINTS)
        put("DYNFILTER_TORQUE_COMMAND", utime, c)

        s = dynfilter.contact_state_t()
        s.utime = utime
        s.contacts = []
        # Two contacts on l_foot (summed), one on r_foot, one inactive on r_hand.
        for body, force, active in (("l_foot", 100.0, True), ("l_foot", 50.0, True),
                                    ("r_foot", 200.0 + i, True), ("r_hand", 999.0, False)):
            ct = dynfilter.contact_t()
            ct.body_name = body
            ct.object = -1
            ct.kind = 6
            ct.active = active
            ct.normal = [0.0, 0.0, 1.0]
            ct.normal_force = force
            s.contacts.append(ct)
        s.num_contacts = len(s.contacts)
        put("DYNFILTER_CONTACT_STATE", utime, s)

        f = dynfilter.filter_status_t()
        f.utime = utime
        f.status = 0 if i == 0 else 128
        f.reason = "ok" if i == 0 else "stale reference"
        f.mode = "paper"
        f.tick_us = TICK_US[i]
        f.solve_us = TICK_US[i] / 4
        f.latency_us = 300.0 + i
        f.frames_received = 10 * (i + 1)
        f.frames_accepted = 10 * (i + 1) - REJECTED[i]
        f.frames_rejected = REJECTED[i]
        f.ticks = 100 * (i + 1)
        f.missed_ticks = MISSED[i]
        put("DYNFILTER_STATUS", utime, f)
    # A channel the tool does not decode.
    log.write_event(T0, "OTHER_CHANNEL", b"\x00\x01\x02")
    log.close()


def check_png(path):
    if not path.is_file():
        fail("no PNG at %s" % path)
    data = path.read_bytes()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        fail("%s is not a PNG (signature %r)" % (path, data[:8]))
    if data[12:16] != b"IHDR":
        fail("%s has no IHDR chunk first" % path)
    width, height = struct.unpack(">II", data[16:24])
    if len(data) < 20_000 or width < 600 or height < 800:
        fail("%s is too small: %d bytes, %dx%d" % (path, len(data), width, height))
    if b"IEND" not in data[-12:]:
        fail("%s is truncated (no IEND)" % path)
    return width, height, len(data)


def expect(summary, pattern, what):
    if not re.search(pattern, summary, re.MULTILINE):
        fail("summary lacks %s (/%s/):\n%s" % (what, pattern, summary))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--types-path", default=str(ROOT / "build" / "lcmtypes" / "python"))
    parser.add_argument("--work-dir", help="where to write the log and the PNG (default: temp)")
    args = parser.parse_args()

    try:
        import matplotlib  # noqa: F401
        import numpy  # noqa: F401
    except ImportError as e:
        print("SKIP: %s in %s (tools/install-deps.sh installs matplotlib and numpy)"
              % (e, sys.executable))
        sys.exit(SKIP)
    import lcm
    sys.path.insert(0, args.types_path)
    import dynfilter

    with tempfile.TemporaryDirectory() as tmp:
        work = Path(args.work_dir) if args.work_dir else Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        log_path = work / "synthetic.lcmlog"
        png_path = work / "synthetic.png"
        png_path.unlink(missing_ok=True)
        write_log(log_path, dynfilter, lcm)

        run = subprocess.run(
            [sys.executable, str(TOOL), str(log_path), "-o", str(png_path),
             "--types-path", args.types_path, "--joints", "l_knee,waist_yaw", "r_knee"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True,
            timeout=120)
        summary = run.stdout
        if run.returncode != 0:
            fail("tool exited %d\nstdout:\n%s\nstderr:\n%s" % (run.returncode, summary,
                                                               run.stderr))
        if run.stderr.strip():
            fail("unexpected warnings:\n%s" % run.stderr)
        width, height, size = check_png(png_path)

        for channel, n in (("DYNFILTER_REFERENCE", N_REFERENCE),
                           ("DYNFILTER_ROBOT_STATE", N_STATE),
                           ("DYNFILTER_TORQUE_COMMAND", len(TICK_US)),
                           ("DYNFILTER_CONTACT_STATE", len(TICK_US)),
                           ("DYNFILTER_STATUS", len(TICK_US)),
                           ("OTHER_CHANNEL", 1)):
            expect(summary, r"^\s*%s\s+%d\s" % (channel, n), "%d messages on %s" % (n, channel))
        # First message at T0 (reference 0), last: robot state 4 at T0 + 450 ms.
        expect(summary, r"^duration: 0\.450 s$", "duration 0.450 s")
        expect(summary, r"^tick_us: max 987\.5,", "max tick_us 987.5")
        expect(summary, r"^missed ticks: 3 of 400 ticks$", "3 missed ticks of 400")
        expect(summary, r"^rejected frames: 4 \(received 40, accepted 36, dropped 0\)$",
               "4 rejected frames")
        expect(summary, r"stale reference \(3\)", "3 statuses 'stale reference'")
        expect(summary, r"^l_knee: reference \[1\.000, 1\.200\], filtered \[1\.000, 1\.300\], "
                        r"measured \[1\.000, 1\.360\], \|tau\| max 5\.0 N m, "
                        r"max \|measured - filtered\| 0\.0500$",
               "l_knee found by name (any order)")
        expect(summary, r"^r_knee: reference \[4\.000, 4\.200\], filtered \[4\.000, 4\.300\], "
                        r"measured \[4\.000, 4\.360\], \|tau\| max 8\.0 N m",
               "r_knee found by name (any order)")
        if "l_hip_pitch" in summary:
            fail("a joint not asked for is summarised:\n" + summary)
        expect(summary, r"^contact l_foot: normal force mean 150\.0 N, max 150\.0 N",
               "l_foot: two contacts summed")
        expect(summary, r"^contact r_foot: normal force mean 201\.5 N, max 203\.0 N",
               "r_foot forces")
        if "r_hand" in summary:
            fail("the inactive r_hand contact counted:\n" + summary)

        # A joint that is not in the log: warned, still a plot.
        png2 = work / "unknown_joint.png"
        run2 = subprocess.run(
            [sys.executable, str(TOOL), str(log_path), "-o", str(png2),
             "--types-path", args.types_path, "--joints", "no_such_joint"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True,
            timeout=120)
        if run2.returncode != 0 or "no_such_joint" not in run2.stderr:
            fail("unknown joint: exit %d, stderr:\n%s" % (run2.returncode, run2.stderr))
        check_png(png2)

    print(summary)
    print("plot_lcm_log ok: %dx%d PNG, %d bytes" % (width, height, size))


if __name__ == "__main__":
    main()
