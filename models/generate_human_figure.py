#!/usr/bin/env python3
"""Generate the dynfilter human figure URDF (and optional JSON metadata).

The figure has 15 rigid body segments whose masses, centre-of-mass locations and
radii of gyration come from the male table of

    de Leva, P. (1996). Adjustments to Zatsiorsky-Seluyanov's segment inertia
    parameters. Journal of Biomechanics 29(9):1223-1230.

scaled from de Leva's male reference subject (stature 1.741 m, mass 73.0 kg) to the
requested stature and body mass. Multi-DoF joints are chains of revolute joints with
light intermediate links. See models/README.md for the conventions and the sources of
every number.

Usage:
    generate_human_figure.py [--height M] [--mass KG] [-o OUT.urdf] [--metadata OUT.json]

Standard library only. The output is deterministic: the same arguments produce a
byte-identical file.
"""

import argparse
import json
import math
import sys
import xml.etree.ElementTree as ET

# ----------------------------------------------------------------------------------
# Reference data
# ----------------------------------------------------------------------------------

SOURCE = ("de Leva, P. (1996). Adjustments to Zatsiorsky-Seluyanov's segment inertia "
          "parameters. Journal of Biomechanics 29(9):1223-1230. Male values of Table 4, "
          "scaled from the reference subject (stature 1.741 m, body mass 73.0 kg).")

REF_STATURE_M = 1.741
REF_MASS_KG = 73.0

# de Leva (1996) Table 4, male column. For each segment:
#   length    longitudinal segment length (m) of the reference subject,
#   mass      fraction of total body mass,
#   com       CoM distance from the ORIGIN endpoint, as a fraction of the length,
#   r_sag     radius of gyration about the sagittal (antero-posterior) axis,
#   r_trans   radius of gyration about the transverse (medio-lateral) axis,
#   r_long    radius of gyration about the longitudinal axis,
# radii as fractions of the segment length. Endpoints: origin -> other.
DE_LEVA_MALE = {
    # VERT (vertex) -> CERV (C7): head and neck (alternative head definition).
    "head": dict(length=0.2429, mass=0.0694, com=0.5002,
                 r_sag=0.303, r_trans=0.315, r_long=0.261),
    # CERV (C7) -> XYPH (xiphoid): upper trunk (alternative definition using CERV).
    "upper_trunk": dict(length=0.2421, mass=0.1596, com=0.5066,
                        r_sag=0.505, r_trans=0.320, r_long=0.465),
    # XYPH -> OMPH (omphalion): middle trunk.
    "middle_trunk": dict(length=0.2155, mass=0.1633, com=0.4502,
                         r_sag=0.482, r_trans=0.383, r_long=0.468),
    # OMPH -> MIDH (mid-point of the hip joint centres): lower trunk.
    "lower_trunk": dict(length=0.1457, mass=0.1117, com=0.6115,
                        r_sag=0.615, r_trans=0.551, r_long=0.587),
    # SJC -> EJC.
    "upper_arm": dict(length=0.2817, mass=0.0271, com=0.5772,
                      r_sag=0.285, r_trans=0.269, r_long=0.158),
    # EJC -> WJC.
    "forearm": dict(length=0.2689, mass=0.0162, com=0.4574,
                    r_sag=0.276, r_trans=0.265, r_long=0.121),
    # WJC -> MET3 (head of the 3rd metacarpal).
    "hand": dict(length=0.0862, mass=0.0061, com=0.7900,
                 r_sag=0.628, r_trans=0.513, r_long=0.401),
    # HJC -> KJC.
    "thigh": dict(length=0.4222, mass=0.1416, com=0.4095,
                  r_sag=0.329, r_trans=0.329, r_long=0.149),
    # KJC -> LMAL (lateral malleolus).
    "shank": dict(length=0.4340, mass=0.0433, com=0.4459,
                  r_sag=0.255, r_trans=0.249, r_long=0.103),
    # HEEL -> TTIP (tip of the longest toe).
    "foot": dict(length=0.2581, mass=0.0137, com=0.4415,
                 r_sag=0.257, r_trans=0.245, r_long=0.124),
}

# Distance of the shoulder joint centres below CERV, from de Leva's two alternative
# trunk lengths CERV->MIDH (603.3 mm) and MIDS->MIDH (515.5 mm, MIDS = mid-point of
# the shoulder joint centres), reference subject (m).
DE_LEVA_CERV_TO_MIDS_M = 0.6033 - 0.5155

# Geometric estimates that de Leva does not provide (fractions of stature unless noted).
ANKLE_HEIGHT_PER_STATURE = 0.039          # ankle joint above the sole (anthropometric rule of thumb)
HIP_HALF_WIDTH_PER_STATURE = 0.09 / 1.75  # half the distance between the hip joint centres
SHOULDER_HALF_WIDTH_PER_STATURE = 0.10    # half the distance between the shoulder joint centres
HEEL_BEHIND_ANKLE_PER_FOOT = 0.22         # heel behind the ankle joint, fraction of foot length
SOLE_WIDTH_PER_FOOT = 0.38                # sole box width, fraction of foot length
SOLE_THICKNESS_M = 0.03                   # sole box height (not scaled)
FOOT_COM_HEIGHT_PER_ANKLE = 0.5           # foot CoM height above the sole, fraction of ankle height
HEAD_SPHERE_RADIUS_PER_HEAD = 0.41        # head collision sphere radius, fraction of head length
KNEE_SPHERE_RADIUS_PER_STATURE = 0.03     # knee collision sphere (on the shank, at the knee joint)
ELBOW_SPHERE_RADIUS_PER_STATURE = 0.022   # elbow collision sphere (on the forearm, at the elbow)
PALM_BREADTH_PER_STATURE = 0.05           # hand box extent along x (palm faces the thigh)
PALM_THICKNESS_PER_STATURE = 0.017        # hand box extent along y
PALM_LENGTH_PER_HAND = 1.2                # hand box extent along z, fraction of WJC->MET3
DE_LEVA_HAND_TO_FINGERTIP_M = 0.1879      # WJC -> DAC3 (alternative hand length), visual only

# Intermediate links of the revolute chains.
INTERMEDIATE_MASS_KG = 0.05
INTERMEDIATE_INERTIA = 1e-4

DEG = math.pi / 180.0

# Joint table. Angles in degrees, efforts (N m) for the 73 kg reference subject,
# velocities in rad/s. Roll and yaw limits are given for the LEFT side; the right side
# mirrors them (lower, upper) -> (-upper, -lower). Pitch limits are the same on both
# sides. "axis" is the joint axis in the joint frame.
#            name              axis        lower  upper  effort  velocity
JOINTS_TRUNK = [
    ("waist_yaw",     (0, 0, 1),  -45.0,  45.0, 120.0, 10.0),
    ("waist_roll",    (1, 0, 0),  -35.0,  35.0, 200.0, 10.0),
    ("waist_pitch",   (0, 1, 0),  -25.0,  80.0, 250.0, 10.0),
    ("neck_yaw",      (0, 0, 1),  -60.0,  60.0,  25.0, 15.0),
    ("neck_roll",     (1, 0, 0),  -45.0,  45.0,  40.0, 15.0),
    ("neck_pitch",    (0, 1, 0),  -45.0,  45.0,  50.0, 15.0),
]
JOINTS_LEG = [  # without the side prefix
    ("hip_yaw",       (0, 0, 1),  -45.0,  45.0, 100.0, 15.0),
    ("hip_roll",      (1, 0, 0),  -30.0,  45.0, 200.0, 15.0),
    ("hip_pitch",     (0, 1, 0), -120.0,  30.0, 250.0, 15.0),
    ("knee",          (0, 1, 0),    0.0, 150.0, 250.0, 20.0),
    ("ankle_pitch",   (0, 1, 0),  -40.0,  50.0, 200.0, 20.0),
    ("ankle_roll",    (1, 0, 0),  -35.0,  15.0,  60.0, 20.0),
]
JOINTS_ARM = [  # without the side prefix
    ("shoulder_pitch", (0, 1, 0), -180.0,  60.0, 100.0, 20.0),
    ("shoulder_roll",  (1, 0, 0),  -40.0, 180.0,  90.0, 20.0),
    ("shoulder_yaw",   (0, 0, 1),  -70.0,  90.0,  60.0, 20.0),
    ("elbow",          (0, -1, 0),   0.0, 150.0,  80.0, 20.0),
    ("forearm_yaw",    (0, 0, 1),  -80.0,  80.0,  10.0, 25.0),
    ("wrist_pitch",    (0, 1, 0),  -20.0,  30.0,  15.0, 25.0),
    ("wrist_roll",     (1, 0, 0),  -80.0,  70.0,  18.0, 25.0),
]
SIDES = (("l", 1.0), ("r", -1.0))


# ----------------------------------------------------------------------------------
# Formatting
# ----------------------------------------------------------------------------------

def fmt(x):
    """Fixed formatting for lengths, angles and inertias (no '-0')."""
    s = "%.9g" % (float(x) + 0.0)
    return "0" if s == "-0" else s


def fmt_mass(x):
    """Masses get more digits so that the total reads back exactly to 1e-9."""
    s = "%.12g" % (float(x) + 0.0)
    return "0" if s == "-0" else s


def fmt_vec(v):
    return " ".join(fmt(c) for c in v)


# ----------------------------------------------------------------------------------
# Model construction
# ----------------------------------------------------------------------------------

class Link:
    def __init__(self, name, mass, com, inertia):
        self.name = name
        self.mass = mass
        self.com = com
        self.inertia = inertia  # (ixx, iyy, izz)
        self.visuals = []       # (xyz, geometry-string)
        self.collisions = []    # (xyz, geometry-string)


class Joint:
    def __init__(self, name, parent, child, xyz, axis, lower, upper, effort, velocity):
        self.name = name
        self.parent = parent
        self.child = child
        self.xyz = xyz
        self.axis = axis
        self.lower = lower
        self.upper = upper
        self.effort = effort
        self.velocity = velocity


def box(size):
    return '<box size="%s"/>' % fmt_vec(size)


def sphere(radius):
    return '<sphere radius="%s"/>' % fmt(radius)


def cylinder(radius, length):
    return '<cylinder radius="%s" length="%s"/>' % (fmt(radius), fmt(length))


def segment_inertia(mass, length, rx, ry, rz):
    """Principal moments m (r L)^2 for radii (fractions of length) about link x, y, z."""
    return tuple(mass * (r * length) ** 2 for r in (rx, ry, rz))


def build_model(height, mass):
    """Returns (links, joints, info). Links are in file order, joints in model order."""
    s = height / REF_STATURE_M           # length scale
    L = {k: v["length"] * s for k, v in DE_LEVA_MALE.items()}
    M = {k: v["mass"] * mass for k, v in DE_LEVA_MALE.items()}
    P = DE_LEVA_MALE

    ankle_h = ANKLE_HEIGHT_PER_STATURE * height
    hip_dy = HIP_HALF_WIDTH_PER_STATURE * height
    shoulder_dy = SHOULDER_HALF_WIDTH_PER_STATURE * height
    torso_len = L["middle_trunk"] + L["upper_trunk"]
    shoulder_z = torso_len - DE_LEVA_CERV_TO_MIDS_M * s
    foot_len = L["foot"]
    heel_x = -HEEL_BEHIND_ANKLE_PER_FOOT * foot_len

    # Number of intermediate links whose mass is taken from each real segment.
    n_inter = {"torso": 2, "head": 2, "thigh": 2, "shank": 0, "foot": 1,
               "upper_arm": 2, "forearm": 1, "hand": 1}

    def reduced(seg_mass, key):
        m = seg_mass - n_inter[key] * INTERMEDIATE_MASS_KG
        if not m > 0.0:
            raise ValueError("body mass too small: segment '%s' would have mass %g kg"
                             % (key, m))
        return m

    def rescale(inertia, m_new, m_old):
        return tuple(i * m_new / m_old for i in inertia)

    links = []
    joints = []

    # --- pelvis (lower trunk, OMPH -> MIDH); origin at MIDH, segment points up. ----
    lpt = P["lower_trunk"]
    pelvis_com = (0.0, 0.0, (1.0 - lpt["com"]) * L["lower_trunk"])
    pelvis_I = segment_inertia(M["lower_trunk"], L["lower_trunk"],
                               lpt["r_sag"], lpt["r_trans"], lpt["r_long"])
    pelvis = Link("pelvis", None, pelvis_com, pelvis_I)  # mass set at the end
    pelvis.visuals.append((pelvis_com, box((0.18 * s, 0.30 * s, 0.20 * s))))
    links.append(pelvis)

    # --- torso (middle + upper trunk); origin at OMPH (waist joint). -----------------
    mpt, upt = P["middle_trunk"], P["upper_trunk"]
    m1, m2 = M["middle_trunk"], M["upper_trunk"]
    z1 = (1.0 - mpt["com"]) * L["middle_trunk"]
    z2 = L["middle_trunk"] + (1.0 - upt["com"]) * L["upper_trunk"]
    I1 = segment_inertia(m1, L["middle_trunk"], mpt["r_sag"], mpt["r_trans"], mpt["r_long"])
    I2 = segment_inertia(m2, L["upper_trunk"], upt["r_sag"], upt["r_trans"], upt["r_long"])
    mt = m1 + m2
    zc = (m1 * z1 + m2 * z2) / mt
    d = m1 * (z1 - zc) ** 2 + m2 * (z2 - zc) ** 2   # parallel-axis term (shift along z)
    torso_I_full = (I1[0] + I2[0] + d, I1[1] + I2[1] + d, I1[2] + I2[2])
    torso_m = reduced(mt, "torso")
    torso = Link("torso", torso_m, (0.0, 0.0, zc), rescale(torso_I_full, torso_m, mt))
    torso.visuals.append(((0.0, 0.0, 0.5 * torso_len),
                          box((0.20 * s, 0.26 * s, torso_len))))

    # --- head (VERT -> CERV); origin at CERV (neck joint), segment points up. --------
    hd = P["head"]
    head_m = reduced(M["head"], "head")
    head_com = (0.0, 0.0, (1.0 - hd["com"]) * L["head"])
    head = Link("head", head_m, head_com,
                segment_inertia(head_m, L["head"], hd["r_sag"], hd["r_trans"], hd["r_long"]))
    head_r = HEAD_SPHERE_RADIUS_PER_HEAD * L["head"]
    head.visuals.append((head_com, sphere(head_r)))
    head.visuals.append(((0.0, 0.0, 0.25 * L["head"]), cylinder(0.055 * s, 0.5 * L["head"])))
    head.collisions.append((head_com, sphere(head_r)))

    def add_chain(parent, child_link, xyz, side_sign, spec):
        """Adds the revolute joints in spec, (name, axis, lo, up, effort, vel), from
        parent to child_link, with an intermediate link between consecutive joints."""
        prev = parent
        for i, (jname, axis, lo, up, effort, vel) in enumerate(spec):
            last = i == len(spec) - 1
            if last:
                child = child_link
            else:
                child = Link(jname + "_link", INTERMEDIATE_MASS_KG, (0.0, 0.0, 0.0),
                             (INTERMEDIATE_INERTIA,) * 3)
            lo_r, up_r = lo * DEG, up * DEG
            if side_sign < 0 and axis[1] == 0:  # roll / yaw joints mirror on the right
                lo_r, up_r = -up_r, -lo_r
            joints.append(Joint(jname, prev.name, child.name,
                                xyz if i == 0 else (0.0, 0.0, 0.0), axis, lo_r, up_r,
                                effort * mass / REF_MASS_KG, vel))
            links.append(child)
            prev = child

    # Waist and neck.
    add_chain(pelvis, torso, (0.0, 0.0, L["lower_trunk"]), 1.0, JOINTS_TRUNK[0:3])
    add_chain(torso, head, (0.0, 0.0, torso_len), 1.0, JOINTS_TRUNK[3:6])

    # Legs.
    th, sh, ft = P["thigh"], P["shank"], P["foot"]
    sole_center = (heel_x + 0.5 * foot_len, 0.0, -ankle_h + 0.5 * SOLE_THICKNESS_M)
    sole_size = (foot_len, SOLE_WIDTH_PER_FOOT * foot_len, SOLE_THICKNESS_M)
    for side, sign in SIDES:
        spec = [(side + "_" + n, a, lo, up, e, v) for (n, a, lo, up, e, v) in JOINTS_LEG]

        thigh_m = reduced(M["thigh"], "thigh")
        thigh = Link(side + "_thigh", thigh_m, (0.0, 0.0, -th["com"] * L["thigh"]),
                     segment_inertia(thigh_m, L["thigh"], th["r_sag"], th["r_trans"], th["r_long"]))
        thigh.visuals.append(((0.0, 0.0, -0.5 * L["thigh"]), cylinder(0.065 * s, L["thigh"])))

        shank_m = reduced(M["shank"], "shank")
        shank = Link(side + "_shank", shank_m, (0.0, 0.0, -sh["com"] * L["shank"]),
                     segment_inertia(shank_m, L["shank"], sh["r_sag"], sh["r_trans"], sh["r_long"]))
        shank.visuals.append(((0.0, 0.0, -0.5 * L["shank"]), cylinder(0.045 * s, L["shank"])))
        # Knee: a kneeling or falling figure must not pass through the floor.
        shank.collisions.append(((0.0, 0.0, 0.0), sphere(KNEE_SPHERE_RADIUS_PER_STATURE * height)))

        # Foot: longitudinal axis along x; sagittal radius about z, transverse about y.
        foot_m = reduced(M["foot"], "foot")
        foot_com = (heel_x + ft["com"] * foot_len, 0.0,
                    -ankle_h + FOOT_COM_HEIGHT_PER_ANKLE * ankle_h)
        foot = Link(side + "_foot", foot_m, foot_com,
                    segment_inertia(foot_m, foot_len, ft["r_long"], ft["r_trans"], ft["r_sag"]))
        foot.visuals.append(((sole_center[0], 0.0, -0.5 * ankle_h),
                             box((foot_len, sole_size[1], ankle_h))))
        foot.collisions.append((sole_center, box(sole_size)))

        add_chain(pelvis, thigh, (0.0, sign * hip_dy, 0.0), sign, spec[0:3])
        add_chain(thigh, shank, (0.0, 0.0, -L["thigh"]), sign, spec[3:4])
        add_chain(shank, foot, (0.0, 0.0, -L["shank"]), sign, spec[4:6])

    # Arms.
    ua, fa, hn = P["upper_arm"], P["forearm"], P["hand"]
    palm_len = PALM_LENGTH_PER_HAND * L["hand"]
    palm_size = (PALM_BREADTH_PER_STATURE * height, PALM_THICKNESS_PER_STATURE * height, palm_len)
    for side, sign in SIDES:
        spec = [(side + "_" + n, a, lo, up, e, v) for (n, a, lo, up, e, v) in JOINTS_ARM]

        ua_m = reduced(M["upper_arm"], "upper_arm")
        upper_arm = Link(side + "_upper_arm", ua_m, (0.0, 0.0, -ua["com"] * L["upper_arm"]),
                         segment_inertia(ua_m, L["upper_arm"], ua["r_sag"], ua["r_trans"], ua["r_long"]))
        upper_arm.visuals.append(((0.0, 0.0, -0.5 * L["upper_arm"]),
                                  cylinder(0.045 * s, L["upper_arm"])))

        # Forearm and hand: at q = 0 the forearm is in neutral rotation (palm facing the
        # thigh), i.e. turned 90 deg from de Leva's anatomical position (palm forward),
        # so the sagittal radius applies about y and the transverse one about x.
        fa_m = reduced(M["forearm"], "forearm")
        forearm = Link(side + "_forearm", fa_m, (0.0, 0.0, -fa["com"] * L["forearm"]),
                       segment_inertia(fa_m, L["forearm"], fa["r_trans"], fa["r_sag"], fa["r_long"]))
        forearm.visuals.append(((0.0, 0.0, -0.5 * L["forearm"]),
                                cylinder(0.035 * s, L["forearm"])))
        forearm.collisions.append(((0.0, 0.0, 0.0), sphere(ELBOW_SPHERE_RADIUS_PER_STATURE * height)))

        hand_m = reduced(M["hand"], "hand")
        hand = Link(side + "_hand", hand_m, (0.0, 0.0, -hn["com"] * L["hand"]),
                    segment_inertia(hand_m, L["hand"], hn["r_trans"], hn["r_sag"], hn["r_long"]))
        finger_len = DE_LEVA_HAND_TO_FINGERTIP_M * s
        hand.visuals.append(((0.0, 0.0, -0.5 * finger_len),
                             box((palm_size[0], palm_size[1], finger_len))))
        hand.collisions.append(((0.0, 0.0, -0.5 * palm_len), box(palm_size)))

        add_chain(torso, upper_arm, (0.0, sign * shoulder_dy, shoulder_z), sign, spec[0:3])
        add_chain(upper_arm, forearm, (0.0, 0.0, -L["upper_arm"]), sign, spec[3:5])
        add_chain(forearm, hand, (0.0, 0.0, -L["forearm"]), sign, spec[5:7])

    # Pelvis mass closes the mass budget so that the written masses sum to `mass`.
    others = sum(float(fmt_mass(lk.mass)) for lk in links if lk is not pelvis)
    pelvis.mass = mass - others
    pelvis.inertia = rescale(pelvis_I, pelvis.mass, M["lower_trunk"])

    info = {
        "standing_pelvis_height_m": ankle_h + L["shank"] + L["thigh"],
        "sole_size": sole_size,
        "sole_center": sole_center,
    }
    return links, joints, info


# ----------------------------------------------------------------------------------
# Output
# ----------------------------------------------------------------------------------

def write_urdf(links, joints, height, mass):
    out = []
    w = out.append
    w('<?xml version="1.0"?>')
    w("<!-- Human figure for dynfilter, generated by models/generate_human_figure.py")
    w("     (height %s m, mass %s kg). Do not edit by hand; regenerate instead."
      % (fmt(height), fmt(mass)))
    w("     Segment inertial parameters: de Leva (1996), J. Biomech. 29(9):1223-1230,")
    w("     male table, scaled from 1.741 m / 73.0 kg. Z up, X forward, Y left.")
    w("     Joint order = document order. See models/README.md. -->")
    w('<robot name="human_figure">')

    by_name = {lk.name: lk for lk in links}
    emitted = set()

    def emit_link(lk):
        w('  <link name="%s">' % lk.name)
        w("    <inertial>")
        w('      <origin xyz="%s" rpy="0 0 0"/>' % fmt_vec(lk.com))
        w('      <mass value="%s"/>' % fmt_mass(lk.mass))
        w('      <inertia ixx="%s" ixy="0" ixz="0" iyy="%s" iyz="0" izz="%s"/>'
          % tuple(fmt(i) for i in lk.inertia))
        w("    </inertial>")
        for xyz, geom in lk.visuals:
            w("    <visual>")
            w('      <origin xyz="%s" rpy="0 0 0"/>' % fmt_vec(xyz))
            w("      <geometry>%s</geometry>" % geom)
            w("    </visual>")
        for xyz, geom in lk.collisions:
            w("    <collision>")
            w('      <origin xyz="%s" rpy="0 0 0"/>' % fmt_vec(xyz))
            w("      <geometry>%s</geometry>" % geom)
            w("    </collision>")
        w("  </link>")
        emitted.add(lk.name)

    emit_link(links[0])
    for j in joints:
        w('  <joint name="%s" type="revolute">' % j.name)
        w('    <parent link="%s"/>' % j.parent)
        w('    <child link="%s"/>' % j.child)
        w('    <origin xyz="%s" rpy="0 0 0"/>' % fmt_vec(j.xyz))
        w('    <axis xyz="%s"/>' % fmt_vec(j.axis))
        w('    <limit lower="%s" upper="%s" effort="%s" velocity="%s"/>'
          % (fmt(j.lower), fmt(j.upper), fmt(j.effort), fmt(j.velocity)))
        w("  </joint>")
        emit_link(by_name[j.child])
    assert emitted == set(by_name), "links not reached by any joint"
    w("</robot>")
    return "\n".join(out) + "\n"


def read_back(urdf_text):
    """Parses the written URDF and returns (masses, coms, inertias, joint names, joints)."""
    root = ET.fromstring(urdf_text)
    links = {}
    for lk in root.findall("link"):
        inertial = lk.find("inertial")
        m = float(inertial.find("mass").get("value"))
        com = [float(c) for c in inertial.find("origin").get("xyz").split()]
        I = inertial.find("inertia")
        diag = [float(I.get(k)) for k in ("ixx", "iyy", "izz")]
        links[lk.get("name")] = (m, com, diag)
    joints = [(j.get("name"), j.find("parent").get("link"), j.find("child").get("link"),
               [float(c) for c in j.find("origin").get("xyz").split()])
              for j in root.findall("joint")]
    return links, joints


def check_and_metadata(urdf_text, height, mass, info):
    links, joints = read_back(urdf_text)
    total = math.fsum(v[0] for v in links.values())
    if abs(total - mass) > 1e-9:
        raise AssertionError("total mass %.15g != %.15g" % (total, mass))
    for name, (m, _, (a, b, c)) in links.items():
        if not (m > 0 and a > 0 and b > 0 and c > 0
                and a + b >= c and b + c >= a and a + c >= b):
            raise AssertionError("invalid inertial on link " + name)
    # Forward kinematics at q = 0 (all joint rotations are identity).
    pos = {"pelvis": [0.0, 0.0, float(fmt(info["standing_pelvis_height_m"]))]}
    for _, parent, child, xyz in joints:
        pos[child] = [p + x for p, x in zip(pos[parent], xyz)]
    sole_c = [float(fmt(c)) for c in info["sole_center"]]
    for side in ("l", "r"):
        bottom = pos[side + "_foot"][2] + sole_c[2] - 0.5 * SOLE_THICKNESS_M
        if abs(bottom) > 1e-8:
            raise AssertionError("sole bottom of %s foot at z = %g" % (side, bottom))

    segments = ["pelvis", "torso", "head", "l_thigh", "r_thigh", "l_shank", "r_shank",
                "l_foot", "r_foot", "l_upper_arm", "r_upper_arm", "l_forearm",
                "r_forearm", "l_hand", "r_hand"]
    meta = {
        "height_m": height,
        "mass_kg": mass,
        "total_mass_kg": total,
        "standing_pelvis_height_m": float(fmt(info["standing_pelvis_height_m"])),
        "foot_sole": {
            "length_m": float(fmt(info["sole_size"][0])),
            "width_m": float(fmt(info["sole_size"][1])),
            "height_m": float(fmt(info["sole_size"][2])),
            "center_in_foot_frame_m": sole_c,
        },
        "joint_names": [j[0] for j in joints],
        "segments": {n: {"mass_kg": links[n][0], "com_m": links[n][1],
                         "inertia_diag_kg_m2": links[n][2]} for n in segments},
        "source": SOURCE,
    }
    return meta


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--height", type=float, default=1.75, help="stature in m (default 1.75)")
    ap.add_argument("--mass", type=float, default=70.0, help="body mass in kg (default 70.0)")
    ap.add_argument("-o", "--output", default=None, help="URDF output path (default stdout)")
    ap.add_argument("--metadata", default=None, help="write JSON metadata to this path")
    args = ap.parse_args(argv)
    if not (math.isfinite(args.height) and 0.5 <= args.height <= 3.0):
        ap.error("--height must be within [0.5, 3.0] m")
    if not (math.isfinite(args.mass) and 0.0 < args.mass <= 500.0):
        ap.error("--mass must be within (0, 500] kg")
    try:
        links, joints, info = build_model(args.height, args.mass)
    except ValueError as e:
        ap.error(str(e))
    urdf = write_urdf(links, joints, args.height, args.mass)
    meta = check_and_metadata(urdf, args.height, args.mass, info)

    if args.output:
        with open(args.output, "w", encoding="utf-8", newline="\n") as f:
            f.write(urdf)
    else:
        sys.stdout.write(urdf)
    if args.metadata:
        with open(args.metadata, "w", encoding="utf-8", newline="\n") as f:
            f.write(json.dumps(meta, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
