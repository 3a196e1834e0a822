#!/usr/bin/env python3
"""Probe of docs/balance.md §24, not part of the product and not tested.

Solves a whole-body optimal-control problem over a window of a reference CSV (the output of
dynfilter-bvh2ref) with Crocoddyl's FDDP on the human figure:
- the clean-up's contact schedule, extended by soles within --near-ground-m where it has no
  foot in stance; each contact a rigid 6-D sole contact that holds the sole still where it
  touched down (flat, on the ground, near the reference's place, at rest);
- soft wrench cones on a shrunk sole (--sole-scale, --mu); soles above the ground when not in
  contact; optional vertical landings and lift-offs, unloading ramps before lift-offs, and
  soft joint and torque limits;
- the reference's state as the tracking target.
Writes the optimised motion as a reference CSV with its exact v and v̇ columns, and
(--plan) the contact plan that docs/probes/contact_plan_probe.patch reads (PLAN=file).

Needs a venv of its own, with the pair of wheels that agree on their ABI:
    python3 -m venv /tmp/cv && /tmp/cv/bin/pip install crocoddyl==3.2.1 pin==4.0.0
(crocoddyl 3.2.1 with pin 4.1.0 corrupts memory: random MemoryError / segfaults.)
Run two solves at once only with OMP_NUM_THREADS=1 (two OpenMP pools on 2 cores: 10× slower).

The sole geometry and the foot link names are the human figure's (models/human_figure.urdf).
"""
import argparse
import csv
import time

import crocoddyl
import numpy as np
import pinocchio as pin

FEET = ("l_foot", "r_foot")
SOLE_CENTRE_IN_FOOT = np.array([0.0726415853, 0.0, -0.06825])  # bottom face centre (m)
SOLE_SIZE = np.array([0.259434233, 0.0985850086])  # length, width (m)


def build_model(urdf):
    """Pinocchio model with a sole frame and four sole-corner frames per foot."""
    model = pin.buildModelFromUrdf(urdf, pin.JointModelFreeFlyer())
    for name in FEET:
        fid = model.getFrameId(name)
        foot = model.frames[fid]
        X_FS = foot.placement * pin.SE3(np.eye(3), SOLE_CENTRE_IN_FOOT)
        model.addFrame(pin.Frame(name + "_sole", foot.parentJoint, fid, X_FS, pin.FrameType.OP_FRAME))
        for i, (sx, sy) in enumerate(((1, 1), (1, -1), (-1, 1), (-1, -1))):
            corner = np.array([sx * SOLE_SIZE[0] / 2, sy * SOLE_SIZE[1] / 2, 0.0])
            model.addFrame(pin.Frame("%s_corner%d" % (name, i), foot.parentJoint, fid,
                                     X_FS * pin.SE3(np.eye(3), corner), pin.FrameType.OP_FRAME))
    return model


def read_csv(path):
    with open(path) as fh:
        rows = list(csv.reader(fh))
    return rows[0], np.array([[float(x) for x in r] for r in rows[1:]])


def runs(flags):
    """[(start, end)] of the runs of equal values."""
    out, k = [], 0
    while k < len(flags):
        j = k
        while j < len(flags) and flags[j] == flags[k]:
            j += 1
        out.append((k, j))
        k = j
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("urdf")
    ap.add_argument("reference")
    ap.add_argument("stance", help="the clean-up's .stance.csv")
    ap.add_argument("output")
    ap.add_argument("--plan", help="also write the contact plan: body,t_start_s,t_end_s,x,y,z,qw,qx,qy,qz (the sole's pose)")
    ap.add_argument("--window", nargs=2, type=float, default=(0.0, 3.0), metavar=("T0", "T1"))
    ap.add_argument("--iterations", type=int, default=150)
    ap.add_argument("--near-ground-m", type=float, default=0.01,
                    help="a foot with a sole corner this low is in contact where no foot is in the clean-up's stance")
    ap.add_argument("--sole-scale", type=float, default=0.7, help="the wrench cone's support, times the sole")
    ap.add_argument("--mu", type=float, default=0.5)
    ap.add_argument("--vertical-frames", type=int, default=0,
                    help="this many frames before a landing and after a lift-off, the sole is held above its contact place (rising 1 mm a frame)")
    ap.add_argument("--unload-frames", type=int, default=0,
                    help="over this many frames before a lift-off the sole's normal force ramps down to zero")
    ap.add_argument("--start-from", help="a previous output CSV: the window starts from its state at T0 (q, v)")
    ap.add_argument("--limits", action="store_true", help="soft joint limits (0.03 rad inside) and torque limits (0.9 of the URDF's)")
    ap.add_argument("--velocity-limits", action="store_true", help="with --limits: soft velocity limits (0.9 of the URDF's)")
    args = ap.parse_args()

    model = build_model(args.urdf)
    kin = build_model(args.urdf)  # kinematics on a model Crocoddyl never sees
    kdata = kin.createData()
    hdr, ref = read_csv(args.reference)
    shdr, sched = read_csv(args.stance)
    col = {n: i for i, n in enumerate(hdr)}
    times = ref[:, 0]
    k0 = int(np.searchsorted(times, args.window[0]))
    k1 = min(int(np.searchsorted(times, args.window[1])), len(times) - 1)
    dt = times[1] - times[0]

    def q_of(row):
        q = np.zeros(model.nq)
        q[0:3] = row[1:4]
        q[3:7] = [row[5], row[6], row[7], row[4]]
        for j in range(2, model.njoints):
            q[model.joints[j].idx_q] = row[col[model.names[j]]]
        return q

    qs = [q_of(ref[k]) for k in range(k0, k1 + 1)]
    vs = [pin.difference(kin, qs[k], qs[k + 1]) / dt for k in range(len(qs) - 1)]
    vs.append(vs[-1])
    xs_ref = [np.concatenate([q, v]) for q, v in zip(qs, vs)]
    n = len(qs)

    # Contact schedule: the clean-up's stance; where it has no foot in stance, a foot whose
    # lowest sole corner is within near_ground_m (runs shorter than 3 frames dropped).
    stance = {f: sched[k0:k1 + 1, shdr.index(f)] > 0.5 for f in FEET}
    any_stance = np.zeros(n, bool)
    for f in FEET:
        any_stance |= stance[f]
    for f in FEET:
        low = np.zeros(n, bool)
        for k in range(n):
            pin.framesForwardKinematics(kin, kdata, qs[k])
            low[k] = min(kdata.oMf[kin.getFrameId("%s_corner%d" % (f, i))].translation[2] for i in range(4)) < args.near_ground_m
        for value in (False, True):
            for a, b in runs(low):
                if low[a] == value and b - a < 3 and a > 0 and b < n:
                    low[a:b] = not value
        stance[f] = stance[f] | (low & ~any_stance)
        for a, b in runs(stance[f].copy()):  # gaps of 1-2 frames between contacts: contact
            if not stance[f][a] and b - a < 3 and a > 0 and b < n:
                stance[f][a:b] = True
        print("%s: %d contact frames (the clean-up's stance: %d)" % (f, stance[f].sum(), (sched[k0:k1 + 1, shdr.index(f)] > 0.5).sum()))

    # Each contact run holds the sole where the reference has it at the run's first frame.
    X_WS = {f: [None] * n for f in FEET}
    for f in FEET:
        for a, b in runs(stance[f]):
            if stance[f][a]:
                pin.framesForwardKinematics(kin, kdata, qs[a])
                X = kdata.oMf[kin.getFrameId(f + "_sole")].copy()
                # Flat on the ground (z = 0), keeping the reference's heading and place.
                yaw = np.arctan2(X.rotation[1, 0], X.rotation[0, 0])
                X = pin.SE3(pin.utils.rotate("z", yaw), np.array([X.translation[0], X.translation[1], 0.0]))
                for k in range(a, b):
                    X_WS[f][k] = X

    # Vertical landings and lift-offs: the sole above the place it lands on or leaves.
    hover = {f: [None] * n for f in FEET}
    for f in FEET:
        for a, b in runs(stance[f]):
            if not stance[f][a]:
                continue
            for i in range(1, args.vertical_frames + 1):
                for k in (a - i, b - 1 + i):
                    if 0 <= k < n and not stance[f][k] and hover[f][k] is None:
                        hover[f][k] = X_WS[f][a].translation + np.array([0.0, 0.0, 0.001 * i])

    state = crocoddyl.StateMultibody(model)
    actuation = crocoddyl.ActuationModelFloatingBase(state)
    nu = actuation.nu
    w_x = np.concatenate([[10.0] * 6, [1.0] * (model.nv - 6), [0.1] * model.nv])
    lb = np.full(state.ndx, -1e9)
    ub = np.full(state.ndx, 1e9)
    lb[6:model.nv] = model.lowerPositionLimit[7:] + 0.03
    ub[6:model.nv] = model.upperPositionLimit[7:] - 0.03
    if args.velocity_limits:
        lb[model.nv + 6:] = -0.9 * model.velocityLimit[6:]
        ub[model.nv + 6:] = 0.9 * model.velocityLimit[6:]
    tau_max = 0.9 * model.effortLimit[6:]
    weight_n = pin.computeTotalMass(model) * 9.81
    cones = []

    def node(k, terminal):
        contacts = crocoddyl.ContactModelMultiple(state, nu)
        costs = crocoddyl.CostModelSum(state, nu)
        for f in FEET:
            sole = model.getFrameId(f + "_sole")
            if X_WS[f][k] is not None and terminal:
                contacts.addContact(f, crocoddyl.ContactModel6D(state, sole, X_WS[f][k], pin.LOCAL_WORLD_ALIGNED, nu, np.array([0.0, 30.0])))
            elif X_WS[f][k] is not None:
                if k == 0 or X_WS[f][k - 1] is None:  # touch-down: on the ground, flat, near the reference's place
                    costs.addCost(f + "_touchdown", crocoddyl.CostModelResidual(
                        state, crocoddyl.ActivationModelWeightedQuad(np.array([1.0, 1.0, 100.0, 100.0, 100.0, 1.0])),
                        crocoddyl.ResidualModelFramePlacement(state, sole, X_WS[f][k], nu)), 1e4)
                    costs.addCost(f + "_touchdown_still", crocoddyl.CostModelResidual(
                        state, crocoddyl.ResidualModelFrameVelocity(state, sole, pin.Motion.Zero(), pin.LOCAL_WORLD_ALIGNED, nu)), 1e3)
                contacts.addContact(f, crocoddyl.ContactModel6D(state, sole, X_WS[f][k], pin.LOCAL_WORLD_ALIGNED, nu, np.array([0.0, 30.0])))
                left = next((j for j in range(k, n) if X_WS[f][j] is None), n) - k  # nodes to the lift-off
                if args.unload_frames > 0 and left <= args.unload_frames and left < n - k:
                    ub_f = np.full(6, 1e9)
                    ub_f[2] = weight_n * (left - 1) / args.unload_frames + 1.0
                    costs.addCost(f + "_unload", crocoddyl.CostModelResidual(
                        state, crocoddyl.ActivationModelQuadraticBarrier(crocoddyl.ActivationBounds(-np.full(6, 1e9), ub_f)),
                        crocoddyl.ResidualModelContactForce(state, sole, pin.Force.Zero(), 6, nu)), 1e-1)
                cone = crocoddyl.WrenchCone(np.eye(3), args.mu, args.sole_scale * SOLE_SIZE, 4, True, 5.0)
                cones.append(cone)
                bounds = crocoddyl.ActivationBounds(np.array(cone.lb).copy(), np.array(cone.ub).copy())
                costs.addCost(f + "_cone", crocoddyl.CostModelResidual(
                    state, crocoddyl.ActivationModelQuadraticBarrier(bounds),
                    crocoddyl.ResidualModelContactWrenchCone(state, sole, cone, nu)), 1e3)
            else:
                if hover[f][k] is not None:
                    costs.addCost(f + "_hover", crocoddyl.CostModelResidual(
                        state, crocoddyl.ResidualModelFrameTranslation(state, sole, hover[f][k], nu)), 1e5)
                above = crocoddyl.ActivationBounds(np.array([-1e9, -1e9, 0.0]), np.array([1e9, 1e9, 1e9]))
                for i in range(4):
                    corner = model.getFrameId("%s_corner%d" % (f, i))
                    costs.addCost("%s_corner%d_z" % (f, i), crocoddyl.CostModelResidual(
                        state, crocoddyl.ActivationModelQuadraticBarrier(above),
                        crocoddyl.ResidualModelFrameTranslation(state, corner, np.zeros(3), nu)), 1e5)
        if args.limits:
            costs.addCost("joint_limits", crocoddyl.CostModelResidual(
                state, crocoddyl.ActivationModelQuadraticBarrier(crocoddyl.ActivationBounds(lb, ub)),
                crocoddyl.ResidualModelState(state, state.zero(), nu)), 1e4)
        costs.addCost("track", crocoddyl.CostModelResidual(
            state, crocoddyl.ActivationModelWeightedQuad(w_x ** 2),
            crocoddyl.ResidualModelState(state, xs_ref[k], nu)), 1.0)
        if not terminal:
            if args.limits:
                costs.addCost("torque_limits", crocoddyl.CostModelResidual(
                    state, crocoddyl.ActivationModelQuadraticBarrier(crocoddyl.ActivationBounds(-tau_max, tau_max)),
                    crocoddyl.ResidualModelControl(state, nu)), 1e-1)
            costs.addCost("torque", crocoddyl.CostModelResidual(state, crocoddyl.ResidualModelControl(state, nu)), 1e-5)
        dam = crocoddyl.DifferentialActionModelContactFwdDynamics(state, actuation, contacts, costs, 0.0, True)
        return crocoddyl.IntegratedActionModelEuler(dam, 0.0 if terminal else dt)

    x0 = xs_ref[0]
    if args.start_from:
        prev_hdr, prev = read_csv(args.start_from)
        pc = {c: i for i, c in enumerate(prev_hdr)}
        row = prev[int(np.argmin(abs(prev[:, 0] - times[k0])))]
        q0 = np.zeros(model.nq)
        q0[0:3] = [row[pc["base_x"]], row[pc["base_y"]], row[pc["base_z"]]]
        q0[3:7] = [row[pc["base_qx"]], row[pc["base_qy"]], row[pc["base_qz"]], row[pc["base_qw"]]]
        v0 = np.zeros(model.nv)
        v0[0:6] = [row[pc[c]] for c in ("base_vx", "base_vy", "base_vz", "base_wx", "base_wy", "base_wz")]
        for j in range(2, model.njoints):
            q0[model.joints[j].idx_q] = row[pc[model.names[j]]]
            v0[model.joints[j].idx_v] = row[pc[model.names[j] + ".v"]]
        x0 = np.concatenate([q0, v0])
    problem = crocoddyl.ShootingProblem(x0, [node(k, False) for k in range(n - 1)], node(n - 1, True))
    solver = crocoddyl.SolverFDDP(problem)
    start = time.time()
    xs_init = [x0] + list(xs_ref[1:])
    solver.solve(xs_init, problem.quasiStatic(xs_init[:-1]), args.iterations, False)
    # The solution's contact wrenches against the full sole and the filter's friction (0.8).
    bad = {"pull": 0, "cop": 0, "friction": 0, "nodes": 0}
    for k, d in enumerate(problem.runningDatas):
        for f_name, c in d.differential.multibody.contacts.contacts.todict().items():
            w = c.f.vector  # in the contact frame: force then moment
            bad["nodes"] += 1
            if w[2] < 1.0:
                bad["pull"] += 1
                continue
            if abs(-w[4] / w[2]) > SOLE_SIZE[0] / 2 or abs(w[3] / w[2]) > SOLE_SIZE[1] / 2:
                bad["cop"] += 1
            if np.hypot(w[0], w[1]) > 0.8 * w[2]:
                bad["friction"] += 1
    print("contact wrenches outside the full sole / friction 0.8: %s" % bad)
    q_out = [x[:model.nq] for x in solver.xs]
    err_j = np.array([q_out[k][7:] - qs[k][7:] for k in range(n)])
    err_b = np.array([q_out[k][:3] - qs[k][:3] for k in range(n)])
    print("solve %.1f s, %d iterations, cost %.4g, stop %.3g, dynamics gap %.3g; joints %.4f rad RMS (max %.3f), base %.4f m RMS"
          % (time.time() - start, solver.iter, solver.cost, solver.stop, solver.ffeas, np.sqrt((err_j ** 2).mean()),
             abs(err_j).max(), np.sqrt((err_b ** 2).sum(1).mean())))
    if args.plan:
        # Where the optimised soles are (the contacts hold the sole still, Kp = 0: not
        # necessarily at the reference's placement).
        X_out = {f: [None] * n for f in FEET}
        for f in FEET:
            for a, b in runs(stance[f]):
                if stance[f][a]:
                    pin.framesForwardKinematics(kin, kdata, q_out[a])
                    X_out[f][a] = kdata.oMf[kin.getFrameId(f + "_sole")].copy()
        write_plan(args.plan, times[k0:k1 + 1], stance, X_out)
    # q, v and v̇ of every node: v̇ from the solver's own integration, v_{k+1} = v_k + v̇_k dt.
    v_out = [x[model.nq:] for x in solver.xs]
    a_out = [(v_out[k + 1] - v_out[k]) / dt for k in range(n - 1)] + [np.zeros(model.nv)]
    joint_cols = [model.names[j] for j in range(2, model.njoints)]
    header = (hdr + ["base_vx", "base_vy", "base_vz", "base_wx", "base_wy", "base_wz"] + [j + ".v" for j in joint_cols]
              + ["base_ax", "base_ay", "base_az", "base_alphax", "base_alphay", "base_alphaz"] + [j + ".a" for j in joint_cols])
    with open(args.output, "w") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        for k in range(n):
            q = q_out[k]
            row = [times[k0 + k]] + list(q[0:3]) + [q[6], q[3], q[4], q[5]] + [0.0] * (len(hdr) - 8)
            for j in range(2, model.njoints):
                row[col[model.names[j]]] = q[model.joints[j].idx_q]
            vj = [v_out[k][model.joints[j].idx_v] for j in range(2, model.njoints)]
            aj = [a_out[k][model.joints[j].idx_v] for j in range(2, model.njoints)]
            row += list(v_out[k][:6]) + vj + list(a_out[k][:6]) + aj
            w.writerow(["%.17g" % x for x in row])


def write_plan(path, times, stance, X_WS):
    with open(path, "w") as fh:
        w = csv.writer(fh)
        w.writerow(["body", "t_start_s", "t_end_s", "x", "y", "z", "qw", "qx", "qy", "qz"])
        for f in FEET:
            for a, b in runs(stance[f]):
                if stance[f][a]:
                    X = X_WS[f][a]
                    qx, qy, qz, qw = pin.Quaternion(X.rotation).coeffs()
                    end = times[b] if b < len(times) else times[-1] + (times[1] - times[0])
                    w.writerow([f] + ["%.9g" % v for v in (times[a], end, *X.translation, qw, qx, qy, qz)])


if __name__ == "__main__":
    main()
