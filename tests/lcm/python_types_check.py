"""The generated Python message types with the lcm wheel's binding: a reference frame and
a filter status through memq:// (in-process), decoded and compared field by field."""
import sys

import lcm

import dynfilter


def main():
    lc = lcm.LCM("memq://")
    received = []
    lc.subscribe("DYNFILTER_REFERENCE",
                 lambda channel, data: received.append(dynfilter.reference_frame_t.decode(data)))
    lc.subscribe("DYNFILTER_STATUS",
                 lambda channel, data: received.append(dynfilter.filter_status_t.decode(data)))

    frame = dynfilter.reference_frame_t()
    frame.utime = 1234567
    frame.sequence = 8
    frame.base_position = [0.1, 0.2, 0.95]
    frame.base_quaternion = [1.0, 0.0, 0.0, 0.0]
    frame.num_joints = 2
    frame.joint_names = ["l_knee", "r_knee"]
    frame.q = [0.5, -0.25]
    frame.qd = [1.0, 2.0]
    frame.qdd = [3.0, 4.0]
    frame.num_contact_hints = 1
    frame.contact_hint_bodies = ["l_foot"]
    frame.contact_hint_active = [True]
    lc.publish("DYNFILTER_REFERENCE", frame.encode())

    status = dynfilter.filter_status_t()
    status.utime = 5
    status.status = 8
    status.reason = "reference invalid: unknown joint name"
    status.mode = "paper"
    status.frames_rejected = 1
    lc.publish("DYNFILTER_STATUS", status.encode())

    while len(received) < 2:
        if lc.handle_timeout(1000) <= 0:
            print("timed out waiting for messages")
            return 1
    got_frame, got_status = received
    failures = []
    for field in ("utime", "sequence", "base_position", "base_quaternion", "num_joints",
                  "joint_names", "q", "qd", "qdd", "num_contact_hints", "contact_hint_bodies",
                  "contact_hint_active"):
        a, b = getattr(frame, field), getattr(got_frame, field)
        # Arrays must come back as lists or tuples (lcm-gen 1.3.1 gave a map iterator).
        if isinstance(a, list) and not isinstance(b, (list, tuple)):
            failures.append(f"reference_frame_t.{field}: not a sequence: {b!r}")
        elif (list(a) if isinstance(a, list) else a) != (list(b) if isinstance(b, (list, tuple)) else b):
            failures.append(f"reference_frame_t.{field}: sent {a!r}, got {b!r}")
    for field in ("utime", "status", "reason", "mode", "frames_rejected"):
        if getattr(status, field) != getattr(got_status, field):
            failures.append(f"filter_status_t.{field}")
    for failure in failures:
        print(failure)
    print("python types ok" if not failures else f"{len(failures)} fields differ")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
