#!/usr/bin/env python3
"""Reproduce the paper's four results (Yamane & Nakamura, dynamics filter) in one command.

    build/venv/bin/python tools/paper_results.py [--out build/results]
        [--only walk,slope,jump,kick,g1_walk] [--check]

For each result it retargets a CMU clip (dynfilter-bvh2ref), filters it (dynfilter-offline)
and writes into --out:
  <name>_filtered.csv (+ .contacts.csv), <name>_bodies.csv   the tools' outputs
  <name>_filmstrip.png   reference (grey) and filtered (blue) stick figures, side view
  <name>_plots.png       knee/hip/ankle torques, contact normal force per body, tracking error
  <name>_animation.gif   reference vs filtered over time
  metrics.json, report.md  every metric computed from the CSVs; the exact commands; the date
Results: walk (131_01 start-walk-stop), slope (the same walk on a 5° downhill slope along
the walking direction), jump (01_01 forward jumps), kick (10_01 soccer kick).
--check then verifies the outputs (report, images, finite metrics) and prints
"paper results ok". Exits 77 (skipped) when numpy or matplotlib is missing.
"""
import argparse
import csv
import datetime
import io
import json
import math
import os
import re
import shlex
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

SKIP = 77
try:
    import numpy as np
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib import animation
except ImportError as e:  # pragma: no cover
    print(f"paper_results: skipped, {e} (tools/install-deps.sh makes the venv)")
    sys.exit(SKIP)

ROOT = Path(__file__).resolve().parents[1]
URDF = ROOT / "models" / "human_figure.urdf"
CMU = ROOT / "data" / "mocap" / "cmu"
BODY_WEIGHT_N = 70.0 * 9.81
SLOPE_DEG = 5.0

RESULTS = {
    # name: (bvh, mapping, reference stem, extra filter options)
    "walk": ("131_01_start_walk_stop.bvh", "131_01.yaml", "walk", []),
    "slope": ("131_01_start_walk_stop.bvh", "131_01.yaml", "walk", ["--slope-deg", f"{SLOPE_DEG:g}"]),
    "jump": ("01_01_forward_jumps.bvh", "01_01.yaml", "jump", []),
    "kick": ("10_01_soccer_kick.bvh", "10_01.yaml", "kick", []),
    "g1_walk": ("131_01_start_walk_stop.bvh", "131_01_g1.yaml", "g1_walk", []),
}
# Results on another robot than the human figure: the URDF comes from this command
# (the Unitree G1 of the example-robot-data wheel, tools/install-deps.sh).
ROBOTS = {"g1_walk": [str(ROOT / "tools" / "g1-urdf.sh")]}
TITLES = {
    "walk": "Walk (CMU 131_01, start–walk–stop), flat ground",
    "slope": f"Walk on a {SLOPE_DEG:g}° downhill slope (same reference as walk)",
    "jump": "Forward jumps (CMU 01_01)",
    "kick": "Soccer kick (CMU 10_01)",
    "g1_walk": "Walk (CMU 131_01) retargeted to the Unitree G1 (IK mode), flat ground",
}
GROUPS = ("legs", "arms", "spine")  # and "other": by structure, `dynfilter-model-info --joint-groups`
# The tool that groups a model's joints; main() points it into --build-dir.
MODEL_INFO = ROOT / "build" / "tools" / "model_info" / "dynfilter-model-info"
PLOT_JOINTS = ["l_hip_pitch", "r_hip_pitch", "l_knee", "r_knee", "l_ankle_pitch", "r_ankle_pitch"]


def rel(p):
    """A path as written in the commands: relative to the repository when inside it."""
    p = Path(p).resolve()
    try:
        return str(p.relative_to(ROOT))
    except ValueError:
        return str(p)


def joint_groups(urdf):
    """joint name -> "spine" | "legs" | "arms" | "other", from the model's kinematic tree
    (`dynfilter-model-info --joint-groups`; no joint names in this script)."""
    r = subprocess.run([str(MODEL_INFO), str(urdf), "--joint-groups"], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"paper_results: {MODEL_INFO} --joint-groups failed on {urdf}: {r.stderr.strip()}")
    rows = list(csv.reader(io.StringIO(r.stdout)))
    return {j: g for j, g in rows[1:]}


# ----------------------------------------------------------------------------- model
class Model:
    """The URDF's tree: links in file order, each link's parent and its joint."""

    def __init__(self, urdf):
        self.path = str(urdf)
        self._groups = None
        root = ET.parse(urdf).getroot()
        self.links = [l.get("name") for l in root.findall("link")]
        self.parent = {}
        self.joints = {}  # child link -> (name, type, xyz, rpy, axis)
        for j in root.findall("joint"):
            child = j.find("child").get("link")
            self.parent[child] = j.find("parent").get("link")
            o = j.find("origin")
            xyz = [float(v) for v in (o.get("xyz", "0 0 0") if o is not None else "0 0 0").split()]
            rpy = [float(v) for v in (o.get("rpy", "0 0 0") if o is not None else "0 0 0").split()]
            a = j.find("axis")
            axis = [float(v) for v in (a.get("xyz") if a is not None else "1 0 0").split()]
            self.joints[child] = (j.get("name"), j.get("type"), np.array(xyz), np.array(rpy),
                                  np.array(axis))
        self.root = [l for l in self.links if l not in self.parent][0]
        self.index = {l: i for i, l in enumerate(self.links)}
        self.edges = [(self.index[self.parent[c]], self.index[c]) for c in self.links
                      if c in self.parent]
        self.moving = [self.joints[c][0] for c in self.links
                       if c in self.joints and self.joints[c][1] != "fixed"]
        self.mass = sum(float(m.get("value")) for m in root.iter("mass"))
        self.effort = {}  # joint -> |tau| limit (N m), from <limit effort>
        for j in root.findall("joint"):
            lim = j.find("limit")
            if lim is not None and lim.get("effort") is not None:
                self.effort[j.get("name")] = float(lim.get("effort"))

    def group_of(self, joint):
        """The joint's group by structure (joint_groups), read once per model."""
        if self._groups is None:
            self._groups = joint_groups(self.path)
        return self._groups.get(joint, "other")

    def fk(self, base_p, base_q, joint_q):
        """World positions of every link origin (n_links x 3). base_q = (w, x, y, z)."""
        R = {self.root: quat_to_R(base_q)}
        P = {self.root: np.asarray(base_p, float)}
        order = self.topological()
        for child in order:
            if child == self.root:
                continue
            name, jtype, xyz, rpy, axis = self.joints[child]
            par = self.parent[child]
            Ro = rpy_to_R(rpy)
            q = joint_q.get(name, 0.0)
            if jtype in ("revolute", "continuous"):
                Rj, tj = axis_angle(axis, q), np.zeros(3)
            elif jtype == "prismatic":
                Rj, tj = np.eye(3), axis * q
            else:
                Rj, tj = np.eye(3), np.zeros(3)
            P[child] = P[par] + R[par] @ (xyz + Ro @ tj)
            R[child] = R[par] @ Ro @ Rj
        return np.array([P[l] for l in self.links])

    def topological(self):
        out, seen = [], set()

        def visit(l):
            if l in seen:
                return
            if l in self.parent:
                visit(self.parent[l])
            seen.add(l)
            out.append(l)

        for l in self.links:
            visit(l)
        return out


def quat_to_R(q):
    w, x, y, z = np.asarray(q, float) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def rpy_to_R(rpy):
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def axis_angle(axis, a):
    k = axis / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(a) * K + (1 - math.cos(a)) * (K @ K)


# ----------------------------------------------------------------------------- files
def read_table(path):
    """A numeric CSV as {column: array}."""
    with open(path, newline="") as f:
        header = next(csv.reader(f))
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {h: data[:, i] for i, h in enumerate(header)}


def read_contacts(path):
    """The contacts CSV: times, bodies and normal forces (rows may be absent)."""
    times, bodies, normal = [], [], []
    if Path(path).exists():
        with open(path, newline="") as f:
            for row in csv.DictReader(f):
                times.append(float(row["time"]))
                bodies.append(row["body"])
                normal.append(float(row["normal_force_n"]))
    return np.array(times), np.array(bodies, dtype=object), np.array(normal)


def read_bodies(path, links):
    """The bodies CSV: (times, reference [n x links x 3], filtered [n x links x 3])."""
    rows = {"reference": [], "filtered": []}
    times = {"reference": [], "filtered": []}
    with open(path, newline="") as f:
        r = csv.reader(f)
        header = next(r)
        cols = [[header.index(f"{l}.{c}") for c in "xyz"] for l in links]
        for row in r:
            src = row[1].strip()
            times[src].append(float(row[0]))
            rows[src].append([[float(row[i]) for i in c] for c in cols])
    return (np.array(times["filtered"]), np.array(rows["reference"]), np.array(rows["filtered"]))


def q_of(table, i, joints):
    return ([table[f"base_{c}"][i] for c in "xyz"],
            [table[f"base_q{c}"][i] for c in "wxyz"],
            {j: table[j][i] for j in joints if j in table})


def write_bodies_fk(model, reference_csv, filtered_csv, out):
    """The bodies CSV computed here by forward kinematics (same format as dynfilter-offline's
    --bodies-csv); used when the offline tool does not have that option."""
    ref, fil = read_table(reference_csv), read_table(filtered_csv)
    idx = np.clip(np.searchsorted(ref["time"], fil["time"] - 1e-9), 0, len(ref["time"]) - 1)
    with open(out, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["time", "source"] + [f"{l}.{c}" for l in model.links for c in "xyz"])
        for k, t in enumerate(fil["time"]):
            for src, tab, i in (("reference", ref, idx[k]), ("filtered", fil, k)):
                P = model.fk(*q_of(tab, i, model.moving))
                w.writerow([repr(float(t)), src] + [f"{v:.6g}" for v in P.ravel()])


# ----------------------------------------------------------------------------- running
def run(cmd, log, commands):
    commands.append(" ".join(shlex.quote(c) for c in [rel(cmd[0])] + [
        rel(c) if os.path.isabs(c) else c for c in cmd[1:]]))
    t0 = time.monotonic()
    p = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    Path(log).write_text(p.stdout + p.stderr)
    if p.returncode != 0:
        sys.exit(f"paper_results: failed ({p.returncode}): {' '.join(cmd)}\n{p.stdout}{p.stderr}")
    return time.monotonic() - t0, p.stdout + p.stderr


def has_bodies_option(offline):
    p = subprocess.run([offline, "--help"], capture_output=True, text=True)
    return "--bodies-csv" in p.stdout + p.stderr


def heading_of(reference_csv):
    """Direction of travel (deg from +x about +z): base displacement first → last frame."""
    ref = read_table(reference_csv)
    dx = ref["base_x"][-1] - ref["base_x"][0]
    dy = ref["base_y"][-1] - ref["base_y"][0]
    return math.degrees(math.atan2(dy, dx)), math.hypot(dx, dy)


# ----------------------------------------------------------------------------- metrics
def rms(a):
    a = np.asarray(a, float)
    return float(math.sqrt(np.mean(a * a))) if a.size else float("nan")


def read_contact_rows(path):
    """Every column of the contacts CSV (numbers as floats; body and kind as text)."""
    cols = {}
    if Path(path).exists():
        with open(path, newline="") as f:
            for row in csv.DictReader(f):
                for k, v in row.items():
                    cols.setdefault(k, []).append(v if k in ("body", "kind") else float(v))
    return {k: np.array(v, dtype=object if k in ("body", "kind") else float) for k, v in cols.items()}


def limit_metrics(t, contacts_csv, model, mu):
    """Frames (of the filtered CSV) violating a physical limit: friction cone, centre of
    pressure outside the contact's support rectangle, joint torque beyond its URDF effort
    limit; and the frames where the QP mode relaxed or fell back (status bits 512, 256)."""
    tol = 1e-6
    m = {}
    c = read_contact_rows(contacts_csv)
    if c:
        f = np.column_stack([c["fx"], c["fy"], c["fz"]])
        n = np.column_stack([c["nx"], c["ny"], c["nz"]])
        fn = np.sum(f * n, axis=1)
        ft = np.linalg.norm(f - fn[:, None] * n, axis=1)
        m["frames_friction_violation"] = int(len(np.unique(c["time"][ft > mu * np.maximum(fn, 0) + tol])))
        # Soles pivoting at friction's twist (QP mode, qp.yaw_slip): physical, counted.
        m["frames_pivoting"] = int(len(np.unique(c["time"][c["pivot"] != 0]))) if "pivot" in c else 0
        # Contacts sliding with kinetic friction (QP mode, qp.tangential_slip): physical, counted.
        m["frames_sliding"] = (int(len(np.unique(c["time"][(c["slide_x"] != 0) | (c["slide_y"] != 0) | (c["slide_z"] != 0)])))
                               if "slide_x" in c else 0)
        if "support_x_min" in c:
            flat = c["kind"] != "point"
            loaded = c["normal_force_n"] > 1e-9
            out_x = (c["cop_x"] < c["support_x_min"] - tol) | (c["cop_x"] > c["support_x_max"] + tol)
            out_y = (c["cop_y"] < c["support_y_min"] - tol) | (c["cop_y"] > c["support_y_max"] + tol)
            bad = flat & loaded & (out_x | ((c["kind"] == "face") & out_y))
            m["frames_cop_outside"] = int(len(np.unique(c["time"][bad])))
            # Torsion of edges and faces: Coulomb friction at the support's farthest point
            # bounds the moment about the normal by μ r f_n (a necessary condition).
            mom = np.column_stack([c["mx"], c["my"], c["mz"]])
            twist = np.abs(np.sum(mom * n, axis=1))
            r = np.hypot(np.maximum(np.abs(c["support_x_min"]), np.abs(c["support_x_max"])),
                         np.maximum(np.abs(c["support_y_min"]), np.abs(c["support_y_max"])))
            twisted = (c["kind"] != "point") & (twist > mu * r * np.maximum(fn, 0) + tol)
            m["frames_torsion_violation"] = int(len(np.unique(c["time"][twisted])))
        m.setdefault("frames_cop_outside", 0)
        m.setdefault("frames_torsion_violation", 0)
    else:
        m["frames_friction_violation"] = m["frames_cop_outside"] = m["frames_torsion_violation"] = m["frames_pivoting"] = 0
        m["frames_sliding"] = 0
    over = np.zeros(len(t["time"]), dtype=bool)
    for j, limit in model.effort.items():
        if f"{j}.tau" in t:
            over |= np.abs(t[f"{j}.tau"]) > limit + tol
    m["frames_torque_over_limit"] = int(np.count_nonzero(over))
    status = t["status"].astype(np.int64)
    m["frames_qp_relaxed"] = int(np.count_nonzero(status & 512))
    m["frames_qp_fallback"] = int(np.count_nonzero(status & 256))
    m["frames_reseeded"] = int(np.count_nonzero(status & 16))
    return m


def metrics_of(filtered_csv, contacts_csv, model=None, mu=0.8):
    t = read_table(filtered_csv)
    groups_of = model if model is not None else Model(URDF)
    n = len(t["time"])
    joints = [c[4:] for c in t if c.startswith("err.")]
    m = {"frames": n, "duration_s": float(t["time"][-1] - t["time"][0])}
    E = np.column_stack([t[f"err.{j}"] for j in joints])
    m["joint_rms_rad"] = rms(E)
    for g in GROUPS:
        cols = [i for i, j in enumerate(joints) if groups_of.group_of(j) == g]
        if cols:  # else the model has no joint in this group
            m[f"joint_rms_{g}_rad"] = rms(E[:, cols])
    pos = np.column_stack([t[f"task_err.{c}"] for c in ("x", "y", "z")])
    rot = np.column_stack([t[f"task_err.{c}"] for c in ("rx", "ry", "rz")])
    m["task_pos_rms_m"] = float(math.sqrt(np.mean(np.sum(pos ** 2, axis=1))))
    m["task_rot_rms_rad"] = float(math.sqrt(np.mean(np.sum(rot ** 2, axis=1))))
    m["max_eq12_residual"] = float(np.max(np.abs(t["eq12_residual"])))
    m["max_base_residual_n"] = float(np.max(np.abs(t["base_residual_n"])))
    weight = BODY_WEIGHT_N if model is None else model.mass * 9.81
    m["max_base_residual_rel_bw"] = m["max_base_residual_n"] / weight
    m["max_penetration_mm"] = 1000.0 * float(np.max(t["max_penetration_m"]))
    ct, cb, cn = read_contacts(contacts_csv)
    m["frames_with_contact"] = int(len(np.unique(ct)))
    m["frames_pulling_contact"] = int(len(np.unique(ct[cn < 0]))) if len(ct) else 0
    m["max_normal_force_n"] = float(cn.max()) if len(cn) else 0.0
    m["min_normal_force_n"] = float(cn.min()) if len(cn) else 0.0
    for g in GROUPS:
        cols = [j for j in joints if groups_of.group_of(j) == g and f"{j}.tau" in t]
        peaks = {j: float(np.max(np.abs(t[f"{j}.tau"]))) for j in cols}
        if not peaks:  # a model without joints in this group
            continue
        worst = max(peaks, key=peaks.get)
        m[f"peak_tau_{g}_nm"] = peaks[worst]
        m[f"peak_tau_{g}_joint"] = worst
    m["mean_tick_us"] = 1e6 * float(np.mean(t["tick_time_s"]))
    m["mean_solve_us"] = 1e6 * float(np.mean(t["solve_time_s"]))
    flags = 0
    for s in t["status"]:
        flags |= int(s)
    m["status_flags"] = f"0x{flags:x}"
    if model is not None:
        m.update(limit_metrics(t, contacts_csv, model, mu))
    return m


FALL_REASONS = ("base position error", "base rotation error")
# A base re-seed is a fall when the base leaned this far from the reference's (rad): the
# guard's orientation error also counts a turn about the vertical, and an upright figure
# whose heading lags 50° is not falling (docs/balance.md §30).
FALL_TILT_RAD = 0.5


def is_fall(row):
    """Whether an events-CSV row re-seeded a fall: the guard's reason is the base's position or
    orientation and the base leaned more than FALL_TILT_RAD from the reference's (files
    without the base_tilt_rad column: the reason alone)."""
    tilt = row.get("base_tilt_rad")
    return row["reseed_reason"] in FALL_REASONS and (tilt in (None, "") or float(tilt) > FALL_TILT_RAD)


def reseed_counts(rows):
    """(re-seeding ticks, falls) of the rows of a `dynfilter-offline --events-csv` file
    (csv.DictReader): every tick with the re-seed bit, and those whose guard's reason is the
    base's falling (is_fall). A joint-error re-seed also resets the base, so it can pre-empt
    a fall: compare falls, not only ticks."""
    ticks = falls = 0
    for r in rows:
        if int(r["status"]) & 16:
            ticks += 1
            falls += is_fall(r)
    return ticks, falls


def count_reseeds(events_csv):
    """reseed_counts of an events file; (0, 0) when the file does not exist."""
    if not Path(events_csv).exists():
        return 0, 0
    with open(events_csv, newline="") as f:
        return reseed_counts(csv.DictReader(f))


def motion_metrics(filtered_csv, reference_csv, bodies_csv, contacts_csv, events_csv, model):
    """Issue 13's per-mode numbers: re-seeds and falls (every tick, from --events-csv), base
    and CoM error, stance-foot skate in the output, the largest per-frame base jump."""
    import diagnose_reseeds as dr  # the URDF's masses and forward kinematics with rotations
    m = {}
    m["reseed_ticks"], m["reseed_falls"] = count_reseeds(events_csv)
    fil, ref = read_table(filtered_csv), read_table(reference_csv)
    base = np.column_stack([fil[f"base_{c}"] for c in "xyz"])
    m["base_rms_m"] = float(math.sqrt(np.mean(np.sum(np.column_stack(
        [fil[f"err.base_{c}"] for c in "xyz"]) ** 2, axis=1))))
    m["max_base_jump_mm"] = 1000.0 * float(np.max(np.linalg.norm(np.diff(base, axis=0), axis=1))) \
        if len(base) > 1 else 0.0
    body = dr.Body(model.path)  # this model's masses (the G1's for g1_walk, not the figure's)
    idx = np.clip(np.searchsorted(ref["time"], fil["time"] - 1e-9), 0, len(ref["time"]) - 1)
    c_f = np.array([body.com_of(*body.fk(*q_of(fil, k, model.moving))) for k in range(len(fil["time"]))])
    c_r = np.array([body.com_of(*body.fk(*q_of(ref, i, model.moving))) for i in idx])
    m["com_rms_m"] = float(math.sqrt(np.mean(np.sum((c_f - c_r) ** 2, axis=1))))
    # Skate: per stance (consecutive written frames with a contact on the foot), how far the
    # foot's origin moves horizontally from where the stance began; the worst stance.
    times, _, fil_b = read_bodies(bodies_csv, model.links)
    c = read_contact_rows(contacts_csv)
    worst = 0.0
    # Every body the filter held in contact (soles, or a knee): no link names assumed.
    for foot in sorted(set(c["body"])) if c else []:
        li = model.links.index(foot)
        on = set(np.round(c["time"][c["body"] == foot], 6)) if c else set()
        start = None
        for k, t in enumerate(times):
            if round(float(t), 6) in on:
                if start is None:
                    start = k
                worst = max(worst, float(np.linalg.norm(fil_b[k, li, :2] - fil_b[start, li, :2])))
            else:
                start = None
    m["max_stance_skate_mm"] = 1000.0 * worst
    return m


# ----------------------------------------------------------------------------- pictures
def view_axes(reference_csv, model):
    """Horizontal axis of the side view: the direction of travel when the figure travels
    (> 0.5 m), otherwise the mean facing direction (the pelvis' x axis)."""
    ref = read_table(reference_csv)
    d = np.array([ref["base_x"][-1] - ref["base_x"][0], ref["base_y"][-1] - ref["base_y"][0]])
    if np.linalg.norm(d) > 0.5:
        u = d / np.linalg.norm(d)
    else:
        fx = np.zeros(2)
        for i in range(0, len(ref["time"]), 10):
            R = quat_to_R([ref[f"base_q{c}"][i] for c in "wxyz"])
            fx += R[:2, 0]
        u = fx / np.linalg.norm(fx) if np.linalg.norm(fx) > 1e-9 else np.array([1.0, 0.0])
    return np.array([u[0], u[1], 0.0])


def project(P, u):
    """World points (... x 3) → side-view coordinates (along u, z)."""
    return np.stack([P[..., :2] @ u[:2], P[..., 2]], axis=-1)


def ground_z(s, u, w_mean, slope_deg, heading_deg, p0=(0.0, 0.0)):
    """Ground height under side-view coordinate s (perpendicular coordinate w_mean); a
    slope passes through z = 0 under p0 (dynfilter-offline puts it under the first base)."""
    if not slope_deg:
        return np.zeros_like(s)
    h = np.array([math.cos(math.radians(heading_deg)), math.sin(math.radians(heading_deg))])
    perp = np.array([-u[1], u[0]])
    xy = np.outer(s, u[:2]) + w_mean * perp - np.asarray(p0, float)
    return -math.tan(math.radians(slope_deg)) * (xy @ h)


def draw_figure(ax, Q, edges, color, lw=2.0, alpha=1.0, zorder=2):
    lines = []
    for a, b in edges:
        (ln,) = ax.plot([Q[a, 0], Q[b, 0]], [Q[a, 1], Q[b, 1]], color=color, lw=lw,
                        alpha=alpha, solid_capstyle="round", zorder=zorder)
        lines.append(ln)
    return lines


def filmstrip(name, times, ref, fil, model, u, ground, out):
    n = len(times)
    step = max(1, int(math.ceil((n - 1) / 8.0))) if n > 1 else 1
    frames = list(range(0, n, step))[:10]
    R, F = project(ref, u), project(fil, u)
    zmax = max(R[..., 1].max(), F[..., 1].max()) + 0.1
    zmin = min(R[..., 1].min(), F[..., 1].min(), 0.0) - 0.1
    half = 0.75
    panel_h = 1.9 * (zmax - zmin) / (2 * half)
    fig, axes = plt.subplots(2, len(frames), figsize=(1.9 * len(frames), 2 * panel_h + 0.9),
                             squeeze=False, sharey=True)
    for c, i in enumerate(frames):
        centre = 0.5 * (R[i, 0, 0] + F[i, 0, 0])
        for r, (Q, col, label) in enumerate(((R, "0.45", "reference"), (F, "tab:blue", "filtered"))):
            ax = axes[r, c]
            s = np.linspace(centre - half, centre + half, 2)
            ax.fill_between(s, ground(s), zmin - 1, color="0.85", zorder=0)
            ax.plot(s, ground(s), color="k", lw=1, zorder=1)
            if r == 1:
                draw_figure(ax, R[i], model.edges, "0.75", lw=1.2, alpha=0.8, zorder=1)
            draw_figure(ax, Q[i], model.edges, col)
            ax.set_xlim(centre - half, centre + half)
            ax.set_ylim(zmin, zmax)
            ax.set_aspect("equal")
            ax.set_xticks([])
            if c == 0:
                ax.set_ylabel(f"{label}\nz (m)")
            if r == 0:
                ax.set_title(f"t = {times[i]:.2f} s", fontsize=9)
    fig.suptitle(f"{TITLES[name]}: reference (grey, top) and filtered (blue, bottom; "
                 f"reference ghosted), every {step} frames; side view", fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)
    return step


def plots(name, filtered_csv, contacts_csv, out):
    t = read_table(filtered_csv)
    time_s = t["time"]
    fig, axes = plt.subplots(3, 1, figsize=(10, 9), sharex=True)
    ax = axes[0]
    # The human figure's leg joints, or on another robot its hip pitch, knee, ankle pitch.
    joints = [j for j in PLOT_JOINTS if f"{j}.tau" in t] or [
        c[:-4] for c in t if c.endswith(".tau") and re.search("hip_pitch|knee|ankle_pitch", c)][:6]
    for j in joints:
        if f"{j}.tau" in t:
            ax.plot(time_s, t[f"{j}.tau"], lw=1, label=j, ls="-" if j.startswith("l_") else "--")
    ax.set_ylabel("joint torque (N·m)")
    ax.legend(ncol=3, fontsize=8)
    ax.grid(alpha=0.3)
    ax = axes[1]
    ct, cb, cn = read_contacts(contacts_csv)
    total = np.zeros_like(time_s)
    for body in sorted(set(cb)):
        sel = cb == body
        tb, inv = np.unique(ct[sel], return_inverse=True)
        fsum = np.bincount(inv, weights=cn[sel])
        per = np.zeros_like(time_s)
        per[np.clip(np.searchsorted(time_s, tb - 1e-9), 0, len(time_s) - 1)] = fsum
        total += per
        ax.plot(time_s, per, lw=1, label=body)
    ax.plot(time_s, total, color="k", lw=0.8, alpha=0.6, label="total")
    ax.axhline(BODY_WEIGHT_N, color="r", lw=0.8, ls=":", label="body weight")
    ax.axhline(0, color="k", lw=0.5)
    ax.set_ylabel("contact normal force (N)")
    ax.legend(ncol=4, fontsize=8)
    ax.grid(alpha=0.3)
    ax = axes[2]
    E = np.column_stack([t[c] for c in t if c.startswith("err.")])
    ax.plot(time_s, np.linalg.norm(E, axis=1), lw=1, color="tab:purple")
    ax.set_ylabel("‖joint tracking error‖ (rad)")
    ax.set_xlabel("time (s)")
    ax.grid(alpha=0.3)
    fig.suptitle(TITLES[name], fontsize=11)
    fig.tight_layout()
    fig.savefig(out, dpi=80)
    plt.close(fig)


def animate(name, times, ref, fil, model, u, ground, out, fps=12, max_bytes=5_000_000):
    R, F = project(ref, u), project(fil, u)
    dt = float(np.median(np.diff(times))) if len(times) > 1 else 1.0 / fps
    step = max(1, int(round(1.0 / (fps * dt))))
    for attempt in range(4):
        idx = list(range(0, len(times), step))
        smin = min(R[..., 0].min(), F[..., 0].min()) - 0.3
        smax = max(R[..., 0].max(), F[..., 0].max()) + 0.3
        zmin = min(R[..., 1].min(), F[..., 1].min(), 0.0) - 0.1
        zmax = max(R[..., 1].max(), F[..., 1].max()) + 0.1
        width = min(9.0, max(4.0, 2.2 * (smax - smin)))
        fig, ax = plt.subplots(figsize=(width, 3.6))
        s = np.linspace(smin, smax, 2)
        ax.fill_between(s, ground(s), zmin - 1, color="0.85", zorder=0)
        ax.plot(s, ground(s), color="k", lw=1)
        ax.set_xlim(smin, smax)
        ax.set_ylim(zmin, zmax)
        ax.set_aspect("equal")
        ax.set_xlabel("along the plane of motion (m)")
        ax.set_ylabel("z (m)")
        ref_lines = draw_figure(ax, R[0], model.edges, "0.55", lw=2)
        fil_lines = draw_figure(ax, F[0], model.edges, "tab:blue", lw=2)
        title = ax.set_title("")
        ax.plot([], [], color="0.55", label="reference")
        ax.plot([], [], color="tab:blue", label="filtered")
        ax.legend(loc="upper right", fontsize=8)
        fig.tight_layout()

        def update(k):
            i = idx[k]
            for lines, Q in ((ref_lines, R[i]), (fil_lines, F[i])):
                for ln, (a, b) in zip(lines, model.edges):
                    ln.set_data([Q[a, 0], Q[b, 0]], [Q[a, 1], Q[b, 1]])
            title.set_text(f"{TITLES[name]}   t = {times[i]:.2f} s")
            return ref_lines + fil_lines + [title]

        anim = animation.FuncAnimation(fig, update, frames=len(idx), blit=False)
        anim.save(out, writer=animation.PillowWriter(fps=fps), dpi=70)
        plt.close(fig)
        if Path(out).stat().st_size < max_bytes:
            break
        step *= 2
    return fps, step, len(idx)


# ----------------------------------------------------------------------------- report
ROWS = [
    ("frames", "frames", "{:d}"),
    ("duration_s", "duration (s)", "{:.2f}"),
    ("joint_rms_rad", "joint tracking RMS, all (rad)", "{:.4f}"),
    ("joint_rms_legs_rad", "… legs (rad)", "{:.4f}"),
    ("joint_rms_arms_rad", "… arms (rad)", "{:.4f}"),
    ("joint_rms_spine_rad", "… spine, neck (rad)", "{:.4f}"),
    ("task_pos_rms_m", "task point P position RMS (m)", "{:.4f}"),
    ("task_rot_rms_rad", "task point P orientation RMS (rad)", "{:.4f}"),
    ("max_eq12_residual", "max abs(Eq. 12 residual)", "{:.2e}"),
    ("max_base_residual_n", "max base residual (N)", "{:.2e}"),
    ("max_base_residual_rel_bw", "… relative to body weight", "{:.2e}"),
    ("max_penetration_mm", "max penetration (mm)", "{:.2f}"),
    ("frames_with_contact", "frames with contact", "{:d}"),
    ("frames_pulling_contact", "frames with a pulling contact", "{:d}"),
    ("min_normal_force_n", "min contact normal force (N)", "{:.1f}"),
    ("max_normal_force_n", "max contact normal force (N)", "{:.1f}"),
    ("peak_tau_legs_nm", "peak abs(torque), legs (N·m)", "{:.1f}"),
    ("peak_tau_arms_nm", "peak abs(torque), arms (N·m)", "{:.1f}"),
    ("peak_tau_spine_nm", "peak abs(torque), spine/neck (N·m)", "{:.1f}"),
    ("mean_tick_us", "mean time per tick (µs)", "{:.1f}"),
    ("mean_solve_us", "mean solve time per tick (µs)", "{:.1f}"),
    ("status_flags", "status flags seen", "{}"),
]

# Paper mode next to the QP mode on the same input.
MODE_ROWS = [
    ("joint_rms_rad", "joint tracking RMS, all (rad)", "{:.4f}"),
    ("task_pos_rms_m", "task point P position RMS (m)", "{:.4f}"),
    ("frames_pulling_contact", "frames with a pulling contact", "{:d}"),
    ("frames_friction_violation", "frames with a force outside its friction cone", "{:d}"),
    ("frames_cop_outside", "frames with a CoP outside its support", "{:d}"),
    ("frames_torsion_violation", "frames with a contact's twist beyond its friction", "{:d}"),
    ("frames_torque_over_limit", "frames with a torque beyond its limit", "{:d}"),
    ("min_normal_force_n", "min contact normal force (N)", "{:.1f}"),
    ("max_normal_force_n", "max contact normal force (N)", "{:.1f}"),
    ("peak_tau_legs_nm", "peak abs(torque), legs (N·m)", "{:.1f}"),
    ("max_base_residual_rel_bw", "max base residual / body weight", "{:.2e}"),
    ("max_penetration_mm", "max penetration (mm)", "{:.2f}"),
    ("frames_reseeded", "frames re-seeded from the reference (divergence guard)", "{:d}"),
    ("reseed_ticks", "re-seeding ticks (every tick, --events-csv)", "{:d}"),
    ("reseed_falls", "of which falls (base position or orientation error)", "{:d}"),
    ("base_rms_m", "base position RMS (m)", "{:.4f}"),
    ("com_rms_m", "centre of mass error RMS (m)", "{:.4f}"),
    ("max_stance_skate_mm", "largest stance-foot skate in the output (mm)", "{:.1f}"),
    ("max_base_jump_mm", "largest per-frame base jump (mm)", "{:.1f}"),
    ("frames_qp_relaxed", "frames answered by a QP relaxation", "{:d}"),
    ("frames_pivoting", "frames with a sole pivoting at friction's twist", "{:d}"),
    ("frames_sliding", "frames with a contact sliding (kinetic friction)", "{:d}"),
    ("frames_qp_fallback", "frames that fell back to the paper solve", "{:d}"),
    ("mean_tick_us", "mean time per tick (µs)", "{:.1f}"),
    ("mean_solve_us", "mean solve time per tick (µs)", "{:.1f}"),
]


def fmt(m, key, f):
    v = m.get(key)
    if v is None:
        return "–"
    s = f.format(v)
    j = key.replace("_nm", "_joint")
    if key.startswith("peak_tau_") and j in m:
        s += f" ({m[j]})"
    return s


def write_report(out, entries, total_s, bodies_note):
    names = [n for n in RESULTS if n in entries]
    now = datetime.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M:%S %Z")
    L = ["# The paper's results, reproduced", "",
         f"Generated by `tools/paper_results.py` on {now} "
         f"(this run: {total_s:.1f} s for {', '.join(e for e in names if entries[e]['run_now'])}).",
         "Every number below is computed from the CSV files in this directory.", "",
         "## Metrics", "",
         "| metric | " + " | ".join(names) + " |",
         "|---|" + "---:|" * len(names)]
    for key, label, f in ROWS:
        L.append(f"| {label} | " + " | ".join(fmt(entries[n]["metrics"], key, f) for n in names) + " |")
    L += ["", f"Body weight = 70 kg × 9.81 m/s² = {BODY_WEIGHT_N:.1f} N. Joint RMS is over every "
          "frame and joint (`err.<joint>`); P's RMS is the RMS of the norm of "
          "`task_err.x..z` (position) and `task_err.rx..rz` (orientation). A pulling contact "
          "is a frame with any contact whose `normal_force_n < 0` in `<stem>.contacts.csv`.",
          "", "All metrics are over the frames written to `<name>_filtered.csv` (the reference's "
          "frames). The summary `dynfilter-offline` prints (kept in `<name>_offline.log`) is over "
          "every filter tick (4 per frame here), so its maxima and pulling-contact count can "
          "differ; with `--every-tick` the two agree.", ""]
    with_qp = [n for n in names if "metrics_qp" in entries[n]]
    if with_qp:
        L += ["## Paper mode vs QP mode", "",
              "The same references filtered with `--mode qp` (unilateral contacts with a minimum "
              "normal force of 1 N, friction pyramid with μ = 0.8, CoP in the support rectangle, "
              "URDF torque limits, joint limits as acceleration bounds; tools/config/default.yaml). "
              "Friction is checked against the true cone ‖f_t‖ ≤ μ f_n, torques against the URDF "
              "effort limits, the CoP against the support rectangle written with each contact.", "",
              "| metric | " + " | ".join(f"{n} paper | {n} QP" for n in with_qp) + " |",
              "|---|" + "---:|" * (2 * len(with_qp))]
        for key, label, f in MODE_ROWS:
            L.append(f"| {label} | " + " | ".join(
                f"{fmt(entries[n]['metrics'], key, f)} | {fmt(entries[n]['metrics_qp'], key, f)}"
                for n in with_qp) + " |")
        L += ["", "A QP relaxation drops, for that tick only and in this order, the joint-limit "
              "acceleration bounds, the normal forces' rate bounds (release ramps, unloading rate), "
              "then the contacts (they "
              "break); contacts, friction, CoP and torque limits hold in every relaxation.", ""]
    for n in names:
        e = entries[n]
        L += [f"## {n}: {TITLES[n]}", ""]
        if e.get("note"):
            L += [e["note"], ""]
        L += [f"Generated {e['date']}; {e['seconds']:.1f} s.", "",
              f"![{n} filmstrip]({n}_filmstrip.png)", "",
              f"QP mode: ![{n} QP filmstrip]({n}_qp_filmstrip.png)", "",
              f"QP-mode animation: [{n}_qp_animation.gif]({n}_qp_animation.gif)", "",
              f"![{n} plots]({n}_plots.png)", "",
              f"Animation: [{n}_animation.gif]({n}_animation.gif)", "",
              "Commands (from the repository root):", "", "```"] + e["commands"] + ["```", ""]
    L += ["## Notes", "", bodies_note, ""]
    (out / "report.md").write_text("\n".join(L))


# ----------------------------------------------------------------------------- check
def check(out, names):
    report = out / "report.md"
    assert report.exists() and report.stat().st_size > 0, "report.md missing"
    text = report.read_text()
    entries = json.loads((out / "metrics.json").read_text())
    for n in names:
        assert n in entries, f"{n}: no metrics"
        for k, v in entries[n]["metrics"].items():
            if isinstance(v, (int, float)):
                assert math.isfinite(v), f"{n}: metric {k} = {v}"
        for suffix, magic in (("_filmstrip.png", b"\x89PNG\r\n\x1a\n"), ("_plots.png", b"\x89PNG\r\n\x1a\n"),
                              ("_animation.gif", b"GIF8"), ("_qp_filmstrip.png", b"\x89PNG\r\n\x1a\n"),
                              ("_qp_animation.gif", b"GIF8")):
            p = out / f"{n}{suffix}"
            assert p.exists() and p.stat().st_size > 0, f"{p} missing or empty"
            assert p.read_bytes()[:len(magic)] == magic, f"{p}: bad signature"
            from PIL import Image
            with Image.open(p) as im:
                im.verify()
            with Image.open(p) as im:
                assert im.size[0] > 100 and im.size[1] > 100, f"{p}: size {im.size}"
                if suffix.endswith(".gif"):
                    assert getattr(im, "n_frames", 1) > 1, f"{p}: not animated"
            assert p.stat().st_size < 5_000_000 or suffix != "_animation.gif", f"{p} ≥ 5 MB"
            assert f"{n}{suffix}" in text, f"report does not link {n}{suffix}"
    print("paper results ok")


# ----------------------------------------------------------------------------- main
def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(ROOT / "build" / "results"))
    ap.add_argument("--only", default=",".join(RESULTS), help="comma-separated subset of "
                    + ",".join(RESULTS))
    ap.add_argument("--build-dir", default=str(ROOT / "build"))
    ap.add_argument("--offline", help="dynfilter-offline (default: in --build-dir)")
    ap.add_argument("--bvh2ref", help="dynfilter-bvh2ref (default: in --build-dir)")
    ap.add_argument("--check", action="store_true", help="verify the outputs afterwards")
    args = ap.parse_args()
    names = [n.strip() for n in args.only.split(",") if n.strip()]
    bad = [n for n in names if n not in RESULTS]
    if bad:
        ap.error(f"unknown result(s) {bad}; choose from {list(RESULTS)}")
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    build = Path(args.build_dir).resolve()
    global MODEL_INFO
    MODEL_INFO = build / "tools" / "model_info" / "dynfilter-model-info"
    offline = str(Path(args.offline or build / "tools" / "offline" / "dynfilter-offline").resolve())
    bvh2ref = str(Path(args.bvh2ref or build / "tools" / "bvh2ref" / "dynfilter-bvh2ref").resolve())
    for b in (offline, bvh2ref):
        if not os.access(b, os.X_OK):
            sys.exit(f"paper_results: {b} not found; build first (cmake --build build)")
    human = Model(URDF)
    native_bodies = has_bodies_option(offline)
    bodies_note = ("Link positions (`<name>_bodies.csv`) come from `dynfilter-offline "
                   "--bodies-csv` (forward kinematics of the reference and filtered frames)."
                   if native_bodies else
                   "`dynfilter-offline` has no `--bodies-csv` option in this build: the link "
                   "positions (`<name>_bodies.csv`, same format) were computed by this script's "
                   "own forward kinematics of models/human_figure.urdf.")

    metrics_path = out / "metrics.json"
    entries = json.loads(metrics_path.read_text()) if metrics_path.exists() else {}
    for e in entries.values():
        e["run_now"] = False
    t_all = time.monotonic()
    made_refs = {}
    for name in names:
        t_start = time.monotonic()
        bvh, mapping, stem, extra = RESULTS[name]
        model, robot = human, []
        if name in ROBOTS:
            found = subprocess.run(ROBOTS[name], capture_output=True, text=True)
            if found.returncode != 0:
                print(f"{name}: skipped, {found.stderr.strip()}")
                continue
            urdf = found.stdout.strip()
            model, robot = Model(urdf), ["--model", urdf]
        commands = []
        reference = out / f"{stem}_reference.csv"
        if stem not in made_refs:
            run([bvh2ref, str(CMU / bvh), "--mapping", str(CMU / "mappings" / mapping),
                 "-o", str(reference)] + robot, out / f"{stem}_bvh2ref.log", commands)
            made_refs[stem] = commands[-1]
        else:
            commands.append(made_refs[stem])
        note = ""
        p0 = (0.0, 0.0)
        extra = list(extra)
        heading, dist = heading_of(reference)
        if "--slope-deg" in extra:
            extra += ["--slope-heading-deg", f"{heading:.1f}"]
            ref = read_table(reference)
            h = np.array([math.cos(math.radians(heading)), math.sin(math.radians(heading))])
            tan = math.tan(math.radians(SLOPE_DEG))
            p0 = (float(ref["base_x"][0]), float(ref["base_y"][0]))
            z1 = -tan * float(h @ [ref["base_x"][-1] - p0[0], ref["base_y"][-1] - p0[1]])
            note = (f"The reference travels {dist:.2f} m with heading {heading:.1f}° "
                    f"(base displacement, first → last frame), so the ground descends "
                    f"{SLOPE_DEG:g}° along that heading. `--slope-deg` puts the plane under "
                    f"the first frame's base (z = 0 there); under the last frame's base it is "
                    f"at z = {z1:+.3f} m; the reference (made on level ground) follows the plane: "
                    f"`dynfilter-offline` moves each frame's base with the plane under it.")
        filtered = out / f"{name}_filtered.csv"
        contacts = out / f"{name}_filtered.contacts.csv"
        bodies = out / f"{name}_bodies.csv"
        cmd = [offline, str(reference), "-o", str(filtered), "--no-progress",
               "--events-csv", str(out / f"{name}_events.csv")] + extra + robot
        if native_bodies:
            cmd += ["--bodies-csv", str(bodies)]
        run(cmd, out / f"{name}_offline.log", commands)
        if not native_bodies:
            write_bodies_fk(model, reference, filtered, bodies)
        m = metrics_of(filtered, contacts, model)
        m.update(motion_metrics(filtered, reference, bodies, contacts, out / f"{name}_events.csv", model))
        # The same input in the QP mode (issue 7): unilateral, friction, CoP, limits.
        filtered_qp = out / f"{name}_qp_filtered.csv"
        bodies_qp = out / f"{name}_qp_bodies.csv"
        run([offline, str(reference), "-o", str(filtered_qp), "--no-progress", "--mode", "qp",
             "--events-csv", str(out / f"{name}_qp_events.csv"), "--bodies-csv", str(bodies_qp)] + extra + robot,
            out / f"{name}_qp_offline.log", commands)
        m_qp = metrics_of(filtered_qp, out / f"{name}_qp_filtered.contacts.csv", model)
        m_qp.update(motion_metrics(filtered_qp, reference, bodies_qp, out / f"{name}_qp_filtered.contacts.csv",
                                   out / f"{name}_qp_events.csv", model))
        times, ref_b, fil_b = read_bodies(bodies, model.links)
        u = view_axes(reference, model)
        slope = SLOPE_DEG if "--slope-deg" in extra else 0.0
        w_mean = float(np.mean(ref_b[:, 0, :2] @ np.array([-u[1], u[0]])))
        ground = lambda s: ground_z(np.asarray(s, float), u, w_mean, slope, heading, p0)  # noqa: E731
        step = filmstrip(name, times, ref_b, fil_b, model, u, ground, out / f"{name}_filmstrip.png")
        plots(name, filtered, contacts, out / f"{name}_plots.png")
        fps, astep, nframes = animate(name, times, ref_b, fil_b, model, u, ground,
                                      out / f"{name}_animation.gif")
        # The QP mode's motion, drawn the same way.
        TITLES[f"{name}_qp"] = TITLES[name] + ", QP mode"
        times_q, ref_q, fil_q = read_bodies(bodies_qp, model.links)
        filmstrip(f"{name}_qp", times_q, ref_q, fil_q, model, u, ground, out / f"{name}_qp_filmstrip.png")
        animate(f"{name}_qp", times_q, ref_q, fil_q, model, u, ground, out / f"{name}_qp_animation.gif")
        note += (" " if note else "") + (
            f"Side view along ({u[0]:.2f}, {u[1]:.2f}) in the horizontal plane; filmstrip every "
            f"{step} frames; animation {nframes} frames at {fps} fps (every {astep} frames).")
        secs = time.monotonic() - t_start
        entries[name] = {"metrics": m, "metrics_qp": m_qp, "commands": commands, "note": note, "run_now": True,
                         "date": datetime.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M:%S %Z"),
                         "seconds": secs}
        print(f"{name}: {m['frames']} frames, joint RMS {m['joint_rms_rad']:.4f} rad, "
              f"{m['frames_pulling_contact']} pulling frames (QP mode: "
              f"{m_qp['frames_pulling_contact']}), {secs:.1f} s")
    total = time.monotonic() - t_all
    metrics_path.write_text(json.dumps(entries, indent=1))
    write_report(out, entries, total, bodies_note)
    print(f"wrote {out / 'report.md'} ({total:.1f} s)")
    if args.check:
        check(out, names)


if __name__ == "__main__":
    main()
