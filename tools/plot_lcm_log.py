#!/usr/bin/env python3
"""Plots an LCM log of the real-time stack (lcm-logger) to one PNG and prints a summary.

The PNG has four stacked plots over time (seconds from the first message, from each
message's utime):
  1. tracking: the filter's filtered joint positions q (torque_command_t) against the
     reference q (reference_frame_t) and, when the log has robot_state_t, the measured q;
  2. the commanded joint torques tau of the same joints (torque_command_t);
  3. contact normal forces (contact_state_t), summed per body over its active contacts,
     and their total;
  4. timing (filter_status_t): tick_us, solve_us, latency_us, and the cumulative
     missed_ticks on a second axis.

    lcm-logger -f run.lcmlog                  # while the stack runs (liblcm-bin)
    build/venv/bin/python tools/plot_lcm_log.py run.lcmlog -o run.png [--joints l_knee,r_knee]

Needs the venv of tools/install-deps.sh (the lcm wheel, matplotlib, numpy) and the
generated Python message types: build/lcmtypes/python (found from this file's place in
the repository, or $DYNFILTER_BUILD_DIR/lcmtypes/python; --types-path overrides).
"""
import argparse
import collections
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_JOINTS = ["l_hip_pitch", "l_knee", "l_ankle_pitch", "waist_yaw"]
# role -> (default channel, message type name)
CHANNELS = collections.OrderedDict([
    ("reference", ("DYNFILTER_REFERENCE", "reference_frame_t")),
    ("state", ("DYNFILTER_ROBOT_STATE", "robot_state_t")),
    ("command", ("DYNFILTER_TORQUE_COMMAND", "torque_command_t")),
    ("contact", ("DYNFILTER_CONTACT_STATE", "contact_state_t")),
    ("status", ("DYNFILTER_STATUS", "filter_status_t")),
])


def parse_args(argv):
    parser = argparse.ArgumentParser(
        description=__doc__.splitlines()[0],
        epilog="example: build/venv/bin/python tools/plot_lcm_log.py run.lcmlog -o run.png")
    parser.add_argument("log", help="LCM log file (lcm-logger)")
    parser.add_argument("-o", "--output",
                        help="PNG to write (default: the log's name with .png)")
    parser.add_argument("--joints", nargs="+", metavar="NAME",
                        help="joints for the tracking and torque plots, space or comma "
                             "separated (default: %s)" % ",".join(DEFAULT_JOINTS))
    default_build = Path(os.environ.get("DYNFILTER_BUILD_DIR", ROOT / "build"))
    parser.add_argument("--types-path", default=str(default_build / "lcmtypes" / "python"),
                        help="directory holding the generated Python package `dynfilter` "
                             "(default: %(default)s)")
    for role, (channel, type_name) in CHANNELS.items():
        parser.add_argument("--%s-channel" % role, default=channel, metavar="CHANNEL",
                            help="%s channel (default: %s)" % (type_name, channel))
    parser.add_argument("--log-time", action="store_true",
                        help="time axis from the logger's receive timestamps instead of the "
                             "messages' utime (when the senders' clocks differ)")
    parser.add_argument("--title", help="figure title (default: the log's file name)")
    args = parser.parse_args(argv)
    if args.joints:
        args.joints = [j for item in args.joints for j in item.split(",") if j]
    else:
        args.joints = list(DEFAULT_JOINTS)
    if not args.output:
        args.output = str(Path(args.log).with_suffix(".png"))
    return args


def import_modules(types_path):
    """lcm, the dynfilter message package, numpy and matplotlib (Agg), or exit with a hint."""
    if types_path and Path(types_path).is_dir():
        sys.path.insert(0, str(Path(types_path).resolve()))
    hint = ("run with the venv of tools/install-deps.sh: build/venv/bin/python "
            "tools/plot_lcm_log.py ...")
    try:
        import lcm  # noqa: F401
    except ImportError as e:
        sys.exit("plot_lcm_log: cannot import lcm (%s); %s" % (e, hint))
    try:
        import dynfilter  # noqa: F401
    except ImportError as e:
        sys.exit("plot_lcm_log: cannot import the message package dynfilter (%s) from %s: "
                 "build first (cmake --build build) or pass --types-path" % (e, types_path))
    try:
        import numpy  # noqa: F401
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot  # noqa: F401
    except ImportError as e:
        sys.exit("plot_lcm_log: cannot import numpy/matplotlib (%s); %s" % (e, hint))
    return lcm, dynfilter


class JointIndex:
    """Positions of the wanted joints in a message's joint_names, cached per name list."""

    def __init__(self, joints):
        self.joints = joints
        self.cache = {}
        self.seen = set()

    def __call__(self, names):
        key = tuple(names)
        index = self.cache.get(key)
        if index is None:
            self.seen.update(key)
            where = {name: i for i, name in enumerate(key)}
            index = [where.get(j) for j in self.joints]
            self.cache[key] = index
        return index


def pick(values, index):
    nan = float("nan")
    return [values[i] if i is not None else nan for i in index]


def read_log(lcm, dynfilter, args):
    """Decodes the five channels. Returns (data, counts, undecodable, first_event_time)."""
    channel_role = {getattr(args, role + "_channel"): role for role in CHANNELS}
    types = {role: getattr(dynfilter, type_name) for role, (_, type_name) in CHANNELS.items()}
    joint_index = JointIndex(args.joints)
    data = {role: collections.defaultdict(list) for role in CHANNELS}
    counts = collections.Counter()
    undecodable = collections.Counter()

    try:
        log = lcm.EventLog(args.log, "r")
    except (IOError, OSError, ValueError) as e:
        sys.exit("plot_lcm_log: cannot read %s: %s" % (args.log, e))
    for event in log:
        counts[event.channel] += 1
        role = channel_role.get(event.channel)
        if role is None:
            continue
        try:
            msg = types[role].decode(event.data)
        except Exception:  # wrong fingerprint or truncated: another type on that channel
            undecodable[event.channel] += 1
            continue
        d = data[role]
        d["t"].append(event.timestamp if args.log_time else msg.utime)
        if role in ("reference", "state", "command"):
            index = joint_index(msg.joint_names)
            d["q"].append(pick(msg.q, index))
            if role == "command":
                d["tau"].append(pick(msg.tau, index))
                d["status"].append(msg.status)
        elif role == "contact":
            forces = collections.OrderedDict()
            for c in msg.contacts[:msg.num_contacts]:
                if c.active:
                    forces[c.body_name] = forces.get(c.body_name, 0.0) + c.normal_force
            d["forces"].append(forces)
        else:
            for field in ("tick_us", "solve_us", "latency_us", "missed_ticks", "ticks",
                          "frames_received", "frames_accepted", "frames_rejected",
                          "frames_dropped", "reseeds", "status"):
                d[field].append(getattr(msg, field))
            d["reason"].append(msg.reason)
    return data, counts, undecodable, joint_index.seen


def to_arrays(data, t0):
    import numpy as np
    out = {}
    for role, d in data.items():
        a = {}
        for key, values in d.items():
            if key == "t":
                a["t"] = (np.asarray(values, dtype=np.float64) - t0) * 1e-6
            elif key in ("forces", "reason"):
                a[key] = values
            else:
                a[key] = np.asarray(values, dtype=np.float64)
        # Time-order each channel (a log may interleave senders slightly out of order).
        if "t" in a and len(a["t"]) > 1 and np.any(np.diff(a["t"]) < 0):
            order = np.argsort(a["t"], kind="stable")
            for key in a:
                if isinstance(a[key], list):
                    a[key] = [a[key][i] for i in order]
                else:
                    a[key] = a[key][order]
        out[role] = a
    return out


def contact_series(forces_per_msg):
    """{body: array of summed normal force per message (0 when the body has no contact)}."""
    import numpy as np
    bodies = []
    for forces in forces_per_msg:
        for body in forces:
            if body not in bodies:
                bodies.append(body)
    return collections.OrderedDict(
        (body, np.array([f.get(body, 0.0) for f in forces_per_msg])) for body in bodies)


# Legends outside the plots, on the right, so that they hide no data.
LEGEND = dict(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, borderaxespad=0.0)


def no_data(ax, text):
    ax.text(0.5, 0.5, text, transform=ax.transAxes, ha="center", va="center", color="0.4")


def plot(arrays, args, title):
    import numpy as np
    import matplotlib.pyplot as plt

    ref, state, cmd = arrays["reference"], arrays["state"], arrays["command"]
    contact, status = arrays["contact"], arrays["status"]
    fig, axes = plt.subplots(4, 1, figsize=(14, 13), sharex=True)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]

    # 1. Tracking: one colour per joint, one line style per source.
    from matplotlib.lines import Line2D
    ax = axes[0]
    handles = []
    sources = [(ref, "--", "reference"), (cmd, "-", "filtered"), (state, ":", "measured")]
    used_sources = set()
    for j, joint in enumerate(args.joints):
        color = colors[j % len(colors)]
        drawn = False
        for a, style, label in sources:
            if "q" in a and len(a["t"]) and np.isfinite(a["q"][:, j]).any():
                ax.plot(a["t"], a["q"][:, j], style, color=color, lw=1.2)
                used_sources.add(label)
                drawn = True
        if drawn:
            handles.append(Line2D([], [], color=color, lw=2, label=joint))
    if handles:
        handles += [Line2D([], [], color="0.2", ls=style, lw=1.2, label=label)
                    for _, style, label in sources if label in used_sources]
        ax.legend(handles=handles, **LEGEND)
    else:
        no_data(ax, "no joint positions of %s on %s / %s / %s" % (
            ", ".join(args.joints), args.reference_channel, args.command_channel,
            args.state_channel))
    ax.set_ylabel("q (rad)")
    ax.set_title("tracking: joint positions", fontsize=10)

    # 2. Torques.
    ax = axes[1]
    drawn = False
    for j, joint in enumerate(args.joints):
        if "tau" in cmd and len(cmd["t"]) and np.isfinite(cmd["tau"][:, j]).any():
            ax.plot(cmd["t"], cmd["tau"][:, j], color=colors[j % len(colors)], lw=1.0,
                    label=joint)
            drawn = True
    if drawn:
        ax.legend(**LEGEND)
    else:
        no_data(ax, "no torque_command_t on %s" % args.command_channel)
    ax.set_ylabel("tau (N m)")
    ax.set_title("commanded joint torques", fontsize=10)

    # 3. Contact normal forces.
    ax = axes[2]
    series = contact_series(contact.get("forces", []))
    if series:
        total = np.zeros(len(contact["t"]))
        for body, f in series.items():
            ax.plot(contact["t"], f, lw=1.0, label=body)
            total += f
        if len(series) > 1:
            ax.plot(contact["t"], total, "k--", lw=1.0, label="total")
        ax.legend(**LEGEND)
    elif len(contact.get("t", [])):
        no_data(ax, "%d contact_state_t messages, none with an active contact"
                % len(contact["t"]))
    else:
        no_data(ax, "no contact_state_t on %s" % args.contact_channel)
    ax.set_ylabel("normal force (N)")
    ax.set_title("contact normal forces (per body, active contacts)", fontsize=10)

    # 4. Timing: log scale, as latency and late ticks can be 100x a normal tick.
    ax = axes[3]
    if len(status.get("t", [])):
        for key, color in (("tick_us", colors[0]), ("solve_us", colors[1]),
                           ("latency_us", colors[2])):
            values = status[key]
            ax.plot(status["t"], np.where(values > 0, values, np.nan), lw=0.8, color=color,
                    label="%s (max %.0f)" % (key, values.max()))
        if (status["tick_us"] > 0).any() or (status["solve_us"] > 0).any():
            ax.set_yscale("log")
        ax.set_ylabel("µs (log)")
        ax2 = ax.twinx()
        ax2.step(status["t"], status["missed_ticks"], where="post", color="tab:red", lw=1.4,
                 label="missed_ticks (cumulative, %d)" % status["missed_ticks"][-1])
        ax2.set_ylabel("missed ticks", color="tab:red")
        ax2.tick_params(axis="y", colors="tab:red")
        ax2.set_ylim(bottom=0, top=max(1.0, float(status["missed_ticks"].max()) * 1.1))
        lines = ax.get_legend_handles_labels()
        lines2 = ax2.get_legend_handles_labels()
        legend = dict(LEGEND, bbox_to_anchor=(1.07, 1.0))
        ax.legend(lines[0] + lines2[0], lines[1] + lines2[1], **legend)
    else:
        no_data(ax, "no filter_status_t on %s" % args.status_channel)
        ax.set_ylabel("µs")
    ax.set_title("filter timing", fontsize=10)
    ax.set_xlabel("time (s) from the first message (%s)" %
                  ("logger receive time" if args.log_time else "message utime"))

    for ax in axes:
        ax.grid(True, alpha=0.3)
    fig.suptitle(title)
    fig.tight_layout()
    out = Path(args.output)
    if out.parent and not out.parent.exists():
        out.parent.mkdir(parents=True)
    fig.savefig(str(out), dpi=100, bbox_inches="tight")
    plt.close(fig)


def summarize(arrays, counts, undecodable, seen_joints, args, duration):
    import numpy as np

    def stat(values):
        return "max %.1f, p99 %.1f, mean %.1f" % (
            values.max(), np.percentile(values, 99), values.mean())

    roles = {getattr(args, role + "_channel"): CHANNELS[role][1] for role in CHANNELS}
    lines = ["log: %s" % args.log, "messages per channel:"]
    for channel in list(roles) + sorted(c for c in counts if c not in roles):
        note = roles.get(channel, "not decoded")
        if undecodable.get(channel):
            note += ", %d undecodable" % undecodable[channel]
        lines.append("  %-28s %8d  (%s)" % (channel, counts.get(channel, 0), note))
    lines.append("duration: %.3f s" % duration)

    status = arrays["status"]
    if len(status.get("t", [])):
        lines.append("tick_us: %s" % stat(status["tick_us"]))
        lines.append("solve_us: %s" % stat(status["solve_us"]))
        lines.append("latency_us: %s" % stat(status["latency_us"]))
        # The counters count since the filter started; a restart within the log resets them.
        lines.append("missed ticks: %d of %d ticks" % (status["missed_ticks"][-1],
                                                       status["ticks"][-1]))
        lines.append("rejected frames: %d (received %d, accepted %d, dropped %d)" % (
            status["frames_rejected"][-1], status["frames_received"][-1],
            status["frames_accepted"][-1], status["frames_dropped"][-1]))
        bad = status["status"] != 0
        if bad.any():
            reasons = collections.Counter(r for r, b in zip(status["reason"], bad) if b)
            lines.append("status not ok in %d of %d status messages: %s" % (
                bad.sum(), len(bad), ", ".join("%s (%d)" % rc for rc in reasons.most_common(4))))
    else:
        lines.append("no filter_status_t: no timing, missed ticks or rejected frames")

    cmd, state, contact = arrays["command"], arrays["state"], arrays["contact"]
    for j, joint in enumerate(args.joints):
        if joint not in seen_joints:
            continue
        parts = []
        for a, name in ((arrays["reference"], "reference"), (cmd, "filtered"), (state, "measured")):
            if "q" in a and len(a["t"]):
                parts.append("%s [%.3f, %.3f]" % (name, np.nanmin(a["q"][:, j]),
                                                  np.nanmax(a["q"][:, j])))
        if "tau" in cmd and len(cmd["t"]):
            parts.append("|tau| max %.1f N m" % np.nanmax(np.abs(cmd["tau"][:, j])))
        if "q" in cmd and "q" in state and len(cmd["t"]) > 1 and len(state["t"]):
            # measured vs filtered at the measurement times (filtered interpolated)
            err = state["q"][:, j] - np.interp(state["t"], cmd["t"], cmd["q"][:, j])
            inside = (state["t"] >= cmd["t"][0]) & (state["t"] <= cmd["t"][-1])
            if inside.any():
                parts.append("max |measured - filtered| %.4f" % np.nanmax(np.abs(err[inside])))
        lines.append("%s: %s" % (joint, ", ".join(parts)))
    series = contact_series(contact.get("forces", []))
    for body, f in series.items():
        lines.append("contact %s: normal force mean %.1f N, max %.1f N, in contact %d of %d" % (
            body, f.mean(), f.max(), (f != 0).sum(), len(f)))
    lines.append("wrote %s" % args.output)
    return "\n".join(lines)


def main(argv=None):
    args = parse_args(sys.argv[1:] if argv is None else argv)
    lcm, dynfilter = import_modules(args.types_path)
    if not Path(args.log).is_file():
        sys.exit("plot_lcm_log: %s: no such file" % args.log)
    data, counts, undecodable, seen_joints = read_log(lcm, dynfilter, args)

    missing = [j for j in args.joints if j not in seen_joints]
    if missing and seen_joints:
        print("plot_lcm_log: warning: joint(s) %s not in the log; it has: %s" % (
            ", ".join(missing), " ".join(sorted(seen_joints))), file=sys.stderr)
    for channel, n in undecodable.items():
        print("plot_lcm_log: warning: %d message(s) on %s do not decode as the expected type"
              % (n, channel), file=sys.stderr)

    if not any(d["t"] for d in data.values()):
        sys.exit("plot_lcm_log: %s has no dynfilter messages on %s" % (
            args.log, ", ".join(getattr(args, r + "_channel") for r in CHANNELS)))
    t0 = min(min(d["t"]) for d in data.values() if d["t"])
    t1 = max(max(d["t"]) for d in data.values() if d["t"])
    arrays = to_arrays(data, t0)
    plot(arrays, args, args.title or Path(args.log).name)
    print(summarize(arrays, counts, undecodable, seen_joints, args, (t1 - t0) * 1e-6))
    return 0


if __name__ == "__main__":
    sys.exit(main())
