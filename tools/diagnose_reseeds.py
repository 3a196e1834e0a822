#!/usr/bin/env python3
"""Why does the filter re-seed? One line of evidence per re-seed, from the tools' outputs.

    build/venv/bin/python tools/diagnose_reseeds.py [--out build/diagnosis] [--only walk,kick]
        [--mode qp] [--config tools/config/default.yaml] [--markdown docs/reseeds.md]

For each clip (the results of tools/paper_results.py: walk, slope, jump, kick, and g1_walk on
the robot paper_results.ROBOTS names) it retargets the CMU capture (dynfilter-bvh2ref),
filters it (dynfilter-offline --events-csv) and, for every re-seed (status bit 16; re-seeds
less than 0.1 s apart form one episode), looks at the 0.5 s before it and reports what the
outputs show:
  reason      the divergence guard's reason (events CSV)
  balance     the filtered figure's centre of mass / capture point (CoM + CoM velocity / ω,
              ω = √(g / CoM height)) outside the support (convex hull of the collision-box
              corners of the bodies the filter holds in contact), first time and by how much;
              and whether the *reference's* own capture point leaves the reference's support
  ref-contact a body other than a foot that the reference puts on the ground (knee, hand,
              head within 2 cm), i.e. a contact the reference has and the filter does not
  ref-foot    a stance foot of the reference sliding (> 0.15 m/s while within 5 mm of the
              ground) or sinking (> 5 mm below it)
  held-turn   a sole the filter holds in contact while the reference turns it about the
              vertical by more than 20° (the filter's by less than half that)
  limits      joints beyond their URDF range in the reference at the re-seed; torques at
              their limit (≥ 99 %) in ≥ 10 % of the window
  qp          ticks answered by a relaxation or a fallback in the window
Prints a table and writes <out>/diagnosis.md and diagnosis.json (and --markdown).
"""
import argparse
import csv
import json
import math
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import paper_results as pr  # noqa: E402  (the clips, the CSV readers, the URDF tree)

G = 9.81
WINDOW_S = 0.5


# ----------------------------------------------------------------------------- model
class Body:
    """The URDF's masses and collision shapes, with forward kinematics giving rotations."""

    def __init__(self, urdf):
        self.tree = pr.Model(urdf)
        root = ET.parse(urdf).getroot()
        self.mass, self.com, self.shapes = {}, {}, {}
        self.lower, self.upper = {}, {}
        for link in root.findall("link"):
            name = link.get("name")
            inertial = link.find("inertial")
            if inertial is not None:
                self.mass[name] = float(inertial.find("mass").get("value"))
                o = inertial.find("origin")
                self.com[name] = np.array([float(v) for v in (o.get("xyz") if o is not None else "0 0 0").split()])
            for c in link.findall("collision"):
                o = c.find("origin")
                xyz = np.array([float(v) for v in (o.get("xyz") if o is not None else "0 0 0").split()])
                g = c.find("geometry")[0]
                if g.tag == "box":
                    size = np.array([float(v) for v in g.get("size").split()])
                    corners = np.array([[sx, sy, sz] for sx in (-.5, .5) for sy in (-.5, .5) for sz in (-.5, .5)]) * size + xyz
                    self.shapes.setdefault(name, []).append(("box", corners, 0.0))
                elif g.tag == "sphere":
                    self.shapes.setdefault(name, []).append(("sphere", xyz[None, :], float(g.get("radius"))))
        for j in root.findall("joint"):
            lim = j.find("limit")
            if lim is not None and j.get("type") == "revolute":
                self.lower[j.get("name")] = float(lim.get("lower"))
                self.upper[j.get("name")] = float(lim.get("upper"))
        self.total = sum(self.mass.values())

    def fk(self, base_p, base_q, joint_q):
        m = self.tree
        R = {m.root: pr.quat_to_R(base_q)}
        P = {m.root: np.asarray(base_p, float)}
        for child in m.topological():
            if child == m.root:
                continue
            name, jtype, xyz, rpy, axis = m.joints[child]
            par = m.parent[child]
            Ro = pr.rpy_to_R(rpy)
            Rj = pr.axis_angle(axis, joint_q.get(name, 0.0)) if jtype in ("revolute", "continuous") else np.eye(3)
            P[child] = P[par] + R[par] @ xyz
            R[child] = R[par] @ Ro @ Rj
        return R, P

    def com_of(self, R, P):
        return sum(self.mass[l] * (P[l] + R[l] @ self.com[l]) for l in self.mass) / self.total

    def lowest(self, R, P, link):
        """Lowest world points of the link's collision shapes (n x 3)."""
        out = []
        for kind, pts, radius in self.shapes.get(link, []):
            W = (R[link] @ pts.T).T + P[link]
            if kind == "sphere":
                W = W - np.array([0, 0, radius])
            out.append(W)
        return np.vstack(out) if out else np.zeros((0, 3))


def states(table, body):
    """Per row: (R, P) of every link."""
    joints = body.tree.moving
    out = []
    for i in range(len(table["time"])):
        out.append(body.fk(*pr.q_of(table, i, joints)))
    return out


# ----------------------------------------------------------------------------- geometry
def hull(points):
    """Convex hull (counter-clockwise) of 2-D points; monotone chain."""
    pts = sorted(set(map(tuple, np.round(points, 6))))
    if len(pts) <= 2:
        return np.array(pts)

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower, upper = [], []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1])


def outside(poly, p):
    """Distance of p outside the convex polygon (0 inside; inf without a polygon)."""
    if len(poly) == 0:
        return math.inf
    if len(poly) < 3:
        return float(min(np.linalg.norm(poly - p, axis=1)))
    d_out = 0.0
    n = len(poly)
    inside = True
    for k in range(n):
        a, b = poly[k], poly[(k + 1) % n]
        e = b - a
        if e[0] * (p[1] - a[1]) - e[1] * (p[0] - a[0]) < 0:
            inside = False
    if inside:
        return 0.0
    best = math.inf
    for k in range(n):
        a, b = poly[k], poly[(k + 1) % n]
        e = b - a
        s = np.clip(np.dot(p - a, e) / max(np.dot(e, e), 1e-12), 0, 1)
        best = min(best, float(np.linalg.norm(a + s * e - p)))
    return best if not inside else d_out


def capture_point(com, com_vel, ground_z):
    """Capture point (x, y): CoM + CoM velocity / ω, ω = √(g / h), h the CoM's height above
    the ground (at least 0.2 m)."""
    h = max(com[2] - ground_z, 0.2)
    return com[:2] + com_vel[:2] / math.sqrt(G / h)


def capture_exit(rows, times, com, com_vel, support_of, ground):
    """The capture point against the support over rows: ((time, distance) of the first row
    more than 1 cm outside, or None; the largest finite distance outside)."""
    first, worst = None, 0.0
    for k in rows:
        d = outside(support_of(k), capture_point(com[k], com_vel[k], ground(com[k, :2])))
        worst = max(worst, d if math.isfinite(d) else 0.0)
        if first is None and d > 0.01:
            first = (times[k], d)
    return first, worst


def window_rows(t_f, t_r, previous, dt):
    """(rows of the filtered output looked at for the re-seed at t_r, index of the first row
    at or after t_r). The rows: WINDOW_S before t_r, from 2 rows after the previous episode's
    last re-seed, to 2 rows before the re-seed's row: that row holds the teleported state, and
    the velocities are central differences."""
    k_end = int(np.searchsorted(t_f, t_r))
    start = max(t_r - WINDOW_S, previous + 2.0 * dt)
    return range(max(0, int(np.searchsorted(t_f, start))), min(k_end - 1, len(t_f))), k_end


def touching(body, states, links, ground):
    """The links whose collision shapes come within 2 cm of the ground in any of the states."""
    out = set()
    for s in states:
        for l in links:
            W = body.lowest(*s, l)
            if len(W) and min(W[:, 2] - np.array([ground(p[:2]) for p in W])) < 0.02:
                out.add(l)
    return out


def foot_track(body, states, times, link, ground):
    """Per state: (time, centre of the link's collision points, height of its lowest point
    above the ground)."""
    track = []
    for t, s in zip(times, states):
        W = body.lowest(*s, link)
        z = W[:, 2] - np.array([ground(p[:2]) for p in W])
        # The centre of all its collision points: a fixed set, so it does not jump when
        # a different corner becomes the lowest (the four lowest did, by 10+ m/s).
        track.append((t, W.mean(axis=0), float(z.min())))
    return track


def foot_findings(link, track):
    """Sinking (lowest point > 5 mm below the ground) and sliding (> 0.15 m/s between two
    rows both within 5 mm of the ground) of a foot_track."""
    if not track:
        return []
    sink = min(z for _, _, z in track)
    slide = 0.0
    for (ta, pa, za), (tb, pb, zb) in zip(track, track[1:]):
        if za < 0.005 and zb < 0.005 and tb > ta:
            slide = max(slide, float(np.linalg.norm(pb[:2] - pa[:2]) / (tb - ta)))
    out = []
    if sink < -0.005:
        out.append(f"reference {link} sinks {1000 * -sink:.0f} mm")
    if slide > 0.15:
        out.append(f"reference {link} slides at up to {slide:.2f} m/s in stance")
    return out


def yaw_of(R):
    """Heading of a rotation about world z (rad)."""
    return math.atan2(R[1, 0], R[0, 0])


def held_while_turned(link, times, held, ref_states, fil_states, min_turn_rad=0.35):
    """A sole the filter holds in contact while the reference turns it about the vertical:
    per run of consecutive rows with `held` true, the reference's and the filter's change of
    the link's heading over the run (unwrapped). Named when the reference turns it by more
    than min_turn_rad and the filter by less than half of that: a held contact fixes the
    sole's yaw, and the leg's turn goes into the body instead."""
    out, k = [], 0
    while k < len(times):
        if not held[k]:
            k += 1
            continue
        e = k
        while e + 1 < len(times) and held[e + 1]:
            e += 1

        def turn(states):
            yaw = np.unwrap([yaw_of(s[0][link]) for s in states[k:e + 1]])
            return float(yaw.max() - yaw.min()) if len(yaw) else 0.0

        ref_turn, fil_turn = turn(ref_states), turn(fil_states)
        if ref_turn > min_turn_rad and fil_turn < 0.5 * ref_turn:
            out.append(f"{link} held in contact {times[k]:.2f}–{times[e]:.2f} s while the reference turns it by "
                       f"{math.degrees(ref_turn):.0f}° (the filter's by {math.degrees(fil_turn):.0f}°)")
        k = e + 1
    return out


def joints_beyond(lower, upper, q):
    """(excess, joint) of the joints of q more than 0.05 rad outside [lower, upper], largest first."""
    beyond = []
    for j, lo in lower.items():
        if j in q:
            ex = max(lo - q[j], q[j] - upper[j])
            if ex > 0.05:
                beyond.append((ex, j))
    return sorted(beyond, reverse=True)


def saturated_torques(table, effort, rows):
    """(fraction, joint) of the joints whose |torque| is at ≥ 99 % of its limit in ≥ 10 % of
    the rows, largest first."""
    sat = []
    for j, lim in effort.items():
        col = f"{j}.tau"
        if col in table and rows:
            frac = float(np.mean(np.abs(table[col][rows]) >= 0.99 * lim))
            if frac >= 0.1:
                sat.append((frac, j))
    return sorted(sat, reverse=True)


# ----------------------------------------------------------------------------- analysis
def episodes(events_csv):
    rows = []
    with open(events_csv) as f:
        for r in csv.DictReader(f):
            rows.append(r)
    reseeds = [r for r in rows if int(r["status"]) & 16]
    eps = []
    for r in reseeds:
        t = float(r["time"])
        if eps and t - eps[-1]["times"][-1] < 0.1:
            eps[-1]["times"].append(t)
            eps[-1]["reasons"].add(r["reseed_reason"])
        else:
            eps.append({"times": [t], "reasons": {r["reseed_reason"]}, "row": r})
    relaxed = [(float(r["time"]), int(r["status"]), r["qp_violated"]) for r in rows if int(r["status"]) & (256 | 512)]
    return eps, relaxed


def soles_of(ref_csv, body):
    """The model's soles: the bodies of the contact schedule dynfilter-bvh2ref writes beside
    the reference (<stem>.stance.csv); without one, the links named like a foot."""
    stance = Path(ref_csv).with_suffix(".stance.csv")
    if stance.exists():
        with open(stance) as f:
            return [l for l in next(csv.reader(f))[1:] if l in body.shapes]
    return [l for l in body.shapes if "foot" in l]


def analyse(name, ref_csv, fil_csv, contacts_csv, events_csv, body, ground):
    ref, fil = pr.read_table(ref_csv), pr.read_table(fil_csv)
    eps, relaxed = episodes(events_csv)
    t_f = fil["time"]
    idx_ref = np.clip(np.searchsorted(ref["time"], t_f - 1e-9), 0, len(ref["time"]) - 1)
    S_ref = states(ref, body)
    S_fil = states(fil, body)
    dt = float(np.median(np.diff(t_f)))
    # CoM, its velocity and the capture point of both motions.
    c_ref = np.array([body.com_of(*s) for s in S_ref])
    c_fil = np.array([body.com_of(*s) for s in S_fil])
    cd_ref = np.gradient(c_ref, ref["time"], axis=0)
    cd_fil = np.gradient(c_fil, t_f, axis=0)

    contacts = pr.read_contact_rows(contacts_csv)
    feet = soles_of(ref_csv, body)
    others = [l for l in body.shapes if l not in feet]

    def held_bodies(k):
        """The bodies the filter holds in contact at output row k."""
        if not contacts:
            return set()
        return set(contacts["body"][np.abs(contacts["time"] - t_f[k]) < 0.5 * dt])

    def support_fil(k):
        bodies = held_bodies(k)
        if not bodies:
            return np.zeros((0, 2))
        pts = []
        for l in bodies:
            W = body.lowest(*S_fil[k], l)
            pts += [p[:2] for p in W if p[2] - ground(p[:2]) < 0.01]
        return hull(np.array(pts)) if pts else np.zeros((0, 2))

    def support_ref(i):
        pts = []
        for l in feet + others:
            W = body.lowest(*S_ref[i], l)
            pts += [p[:2] for p in W if p[2] - ground(p[:2]) < 0.02]
        return hull(np.array(pts)) if pts else np.zeros((0, 2))

    out = []
    previous = -math.inf  # the last re-seed before this episode: its teleport is no motion
    for ep in eps:
        t_r = ep["times"][0]
        ks, k_end = window_rows(t_f, t_r, previous, dt)
        previous = ep["times"][-1]
        ref_rows = [idx_ref[k] for k in ks]
        findings = []
        reason = ", ".join(sorted(ep["reasons"]))
        # The base's lean against its turn (events CSV of dynfilter-offline since §30).
        row = ep["row"]
        if row.get("base_tilt_rad") not in (None, ""):
            tilt, heading = float(row["base_tilt_rad"]), float(row["base_heading_rad"])
            lean = f"base leaned {math.degrees(tilt):.0f}° from the reference's, heading {math.degrees(heading):+.0f}°"
            upright = row["reseed_reason"] in pr.FALL_REASONS and not pr.is_fall(row)
            findings.append(lean + (" (upright: a turn or a drift not followed, not a fall)" if upright else ""))
        # Balance of the filtered figure and of the reference.
        first_cp, worst_cp = capture_exit(ks, t_f, c_fil, cd_fil, support_fil, ground)
        if first_cp:
            findings.append(f"filtered capture point left its support at {first_cp[0]:.2f} s "
                            f"(up to {100 * worst_cp:.0f} cm outside)")
        _, ref_out = capture_exit(ref_rows, ref["time"], c_ref, cd_ref, support_ref, ground)
        if ref_out > 0.02:
            findings.append(f"the reference's own capture point is up to {100 * ref_out:.0f} cm outside the reference's support")
        # Contacts the reference has and the filter does not.
        touched = touching(body, [S_ref[i] for i in ref_rows], others, ground)
        if touched:
            findings.append("reference puts on the ground: " + ", ".join(sorted(touched)))
        # Stance feet of the reference sliding or sinking.
        for l in feet:
            findings += foot_findings(l, foot_track(body, [S_ref[i] for i in ref_rows],
                                                    [ref["time"][i] for i in ref_rows], l, ground))
        # Soles the filter holds while the reference turns them.
        held = [held_bodies(k) for k in ks]
        for l in feet:
            findings += held_while_turned(l, [t_f[k] for k in ks], [l in h for h in held],
                                          [S_ref[i] for i in ref_rows], [S_fil[k] for k in ks])
        # Limits.
        i = idx_ref[min(k_end, len(t_f) - 1)]
        beyond = joints_beyond(body.lower, body.upper, {j: ref[j][i] for j in body.lower if j in ref})
        if beyond:
            findings.append("reference beyond joint limits: " + ", ".join(
                f"{j} {math.degrees(e):.0f}°" for e, j in beyond[:3]))
        sat = saturated_torques(fil, body.tree.effort, list(ks))
        if sat:
            findings.append("torque at its limit: " + ", ".join(f"{j} {100 * f:.0f} %" for f, j in sat[:3]))
        nrel = [r for r in relaxed if t_r - WINDOW_S <= r[0] <= t_r]
        if nrel:
            fams = sorted({r[2] for r in nrel if r[2]})
            findings.append(f"{len(nrel)} QP ticks relaxed/fell back ({'; '.join(fams) or 'no family'})")
        out.append({"clip": name, "time_s": round(t_r, 3), "count": len(ep["times"]),
                    "reason": reason, "findings": findings})
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(pr.ROOT / "build" / "diagnosis"))
    ap.add_argument("--only", default=",".join(pr.RESULTS))
    ap.add_argument("--build-dir", default=str(pr.ROOT / "build"))
    ap.add_argument("--mode", default="qp", choices=["qp", "paper"])
    ap.add_argument("--config", help="YAML configuration for dynfilter-offline")
    ap.add_argument("--backend", default="dart", choices=["dart", "ode"])
    ap.add_argument("--markdown", help="also write the table here")
    args = ap.parse_args()
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    build = Path(args.build_dir).resolve()
    offline = build / "tools" / "offline" / "dynfilter-offline"
    bvh2ref = build / "tools" / "bvh2ref" / "dynfilter-bvh2ref"
    human = Body(pr.URDF)
    report = []
    for name in [n.strip() for n in args.only.split(",") if n.strip()]:
        bvh, mapping, stem, extra = pr.RESULTS[name]
        body, robot = human, []
        if name in pr.ROBOTS:  # another robot than the human figure (paper_results.ROBOTS)
            found = subprocess.run(pr.ROBOTS[name], capture_output=True, text=True)
            if found.returncode != 0:
                print(f"{name}: skipped, {found.stderr.strip()}")
                continue
            body, robot = Body(found.stdout.strip()), ["--model", found.stdout.strip()]
        ref_csv = out / f"{stem}_reference.csv"
        subprocess.run([str(bvh2ref), str(pr.CMU / bvh), "--mapping", str(pr.CMU / "mappings" / mapping),
                        "-o", str(ref_csv)] + robot, check=True, capture_output=True)
        extra = list(extra) + robot
        ground = lambda p: 0.0  # noqa: E731
        if "--slope-deg" in extra:
            heading, _ = pr.heading_of(ref_csv)
            extra += ["--slope-heading-deg", f"{heading:.1f}"]
            r0 = pr.read_table(ref_csv)
            p0 = np.array([r0["base_x"][0], r0["base_y"][0]])
            h = np.array([math.cos(math.radians(heading)), math.sin(math.radians(heading))])
            tan = math.tan(math.radians(pr.SLOPE_DEG))
            ground = lambda p, p0=p0, h=h, tan=tan: -tan * float(h @ (np.asarray(p) - p0))  # noqa: E731
        fil_csv = out / f"{name}_{args.mode}.csv"
        events = out / f"{name}_{args.mode}.events.csv"
        cmd = [str(offline), str(ref_csv), "-o", str(fil_csv), "--no-progress", "-q", "--mode", args.mode,
               "--backend", args.backend, "--events-csv", str(events)] + extra
        if args.config:
            cmd += ["--config", args.config]
        subprocess.run(cmd, check=True)
        rows = analyse(name, ref_csv, fil_csv, out / f"{name}_{args.mode}.contacts.csv", events, body, ground)
        report += rows
        print(f"{name}: {len(rows)} re-seed episodes")
        for r in rows:
            print(f"  {r['time_s']:6.2f} s  ({r['count']} ticks) {r['reason']}: " + "; ".join(r["findings"]))
    L = ["| clip | time (s) | re-seeding ticks | guard's reason | what the outputs show |", "|---|---:|---:|---|---|"]
    for r in report:
        L.append(f"| {r['clip']} | {r['time_s']:.2f} | {r['count']} | {r['reason']} | {'; '.join(r['findings']) or '–'} |")
    text = "\n".join(L) + "\n"
    (out / "diagnosis.md").write_text(text)
    (out / "diagnosis.json").write_text(json.dumps(report, indent=1))
    if args.markdown:
        Path(args.markdown).write_text(text)
    print(f"wrote {out / 'diagnosis.md'}")


if __name__ == "__main__":
    main()
