#pragma once
/// @file
/// Clean-up of a retargeted reference motion before it is filtered: a contact schedule
/// from the reference (a foot near the ground and slow = stance), stance feet held still
/// and on the ground (no skating, no sinking) by adjusting the legs with PoseIk, and every
/// joint inside the model's limits; the change is reported.
///
/// Method:
///  - First, the input's configurations are low-passed (lowpass_hz): the schedule, the foot
///    targets and the posture all come from the smoothed motion.
///  - Feet: the links named in ReferenceCleanupOptions::feet, or else the bodies that touch
///    the ground when the model stands at its neutral configuration (standingBaseHeight).
///    Sole points: the contact points of that stance, in the foot's frame.
///  - Size: L = the standing base height at the neutral configuration (m), the leg length
///    every threshold is relative to.
///  - Schedule: frame k is stance for foot f when the lowest sole point is at most
///    contact_height · L above the ground and the sole's centre moves horizontally slower
///    than contact_speed · L per second (central differences); runs of stance or swing
///    shorter than min_phase_s are merged into their neighbours. Support completion:
///    where the CoM (ground projection) lies more than 2 cm outside the stance soles, a foot
///    still over min_phase_s (slower than contact_speed · L / 2 in every direction) up to
///    3 · contact_height · L above the ground is in stance too (lowest first) —
///    a figure retargeted with a wide stance stands with one foot hovering a few
///    centimetres (the CMU walk's last 1.1 s: the left foot 5 cm up, the CoM 35 cm outside
///    the right sole; before, the filter had to stand on the right foot alone).
///  - Stance pose of a run: the foot flat (its neutral-stance orientation turned by the
///    run's mean heading about the ground normal), its sole centre at the run's mean
///    horizontal position, the sole on the ground. Heel-off: where the run ends with the
///    reference's sole pitching away from the run's own level (its median pitch) — the heel
///    rising over the toes, or the toes over the heel — the flat pose rolls over that edge
///    from the run's last frame within 0.05 rad of that level on, by the pitch beyond those
///    0.05 rad; the edge stays where it is. (Flattened, the CMU jumps lost their push-off:
///    the pelvis left the ground at 0.64 m/s instead of 1.6.) In a swing the target is the
///    reference's foot corrected (sole centre moved, orientation turned) by the correction
///    that ended the last stance, blended (smoothstep) over the whole swing into the one
///    that starts the next, so that the target is continuous and accelerates as little as
///    the swing allows; before the first and after the last stance, that stance's
///    correction. (Ramps of 80 ms at each end of a stance, used before, put 30–450 m/s²
///    into the base where a leg could not absorb them.)
///  - Per frame, PoseIk solves for the whole configuration: the feet at their targets
///    (the stance pose, or the corrected reference foot in a swing), every other coordinate
///    held at the reference (base weight base_weight, joints posture_weight, a lower weight
///    for the joints between the base and a foot so that the legs take up the change), all
///    within the joint limits; a continuity term (continuity_weight) holds each frame's
///    change near the reference's own change, so the answer follows one branch over the
///    clip. The answer is low-passed again (lowpass_hz) and solved once more with it as the
///    posture, so that the feet are exact. Velocities and accelerations are estimated again.
///  - Balance (ReferenceCleanupOptions::balance, on by default): where the clip's zero-moment
///    point leaves the support of its stance soles (shrunk by zmp_margin_m), the nearest CoM
///    path a pendulum can follow on that support is found (feasibleComPath, over the clip's
///    past and future: reference_balance.hpp), the base is moved along the ground towards it
///    (at most max_com_shift_m per axis) and the IK solved again with the same foot targets,
///    until the CoM is on the path or balance_iterations rounds are done. The base and its
///    upper body carry the shift; the legs bend to keep the feet.
///  - Report: per joint max and RMS change, overall RMS; per foot the stance skate (largest
///    horizontal slide of a sole point while it touches the ground, within 5 mm, during a
///    stance run) and the largest penetration of a sole point, before and after; limit
///    excess before and after; the ZMP against the stance soles, before and after.

#include <string>
#include <vector>

#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/io/reference_balance.hpp"
#include "dynfilter/io/reference_motion.hpp"

namespace dynfilter::io {

struct ReferenceCleanupOptions {
  /// Zero-phase low-pass of the input's configurations before anything else
  /// (lowPassConfigurations, Hz); 0: off. Above ~10 Hz retargeted mocap is marker noise and
  /// IK jitter, which become accelerations of 10–100 m/s² in the reference.
  double lowpass_hz = 8.0;
  std::vector<std::string> feet;  ///< foot links; empty: found from the neutral stance
  double contact_height = 0.04;   ///< sole height threshold, fraction of the leg length L
  double contact_speed = 0.4;     ///< horizontal sole speed threshold, L per second
  double min_phase_s = 0.08;      ///< shorter stance or swing runs are merged (s)
  double base_weight = 1.0;       ///< IK weight holding the base at the reference
  double posture_weight = 1.0;    ///< IK weight holding joints (not on a leg) at the reference
  double leg_weight = 0.05;       ///< IK weight holding the leg joints at the reference
  /// IK weight holding each frame's change at the reference's change (PoseIk's continuity
  /// term, about the previous frame's answer moved by the reference's own change); 0: off
  double continuity_weight = 1.0;
  int smoothing_window = 7;       ///< estimateDerivatives window (odd, ≥ 3)
  /// Balance stage: the zero-moment point brought into the stance soles' support by moving
  /// the base along the ground onto the nearest CoM path a pendulum can follow, the feet
  /// kept (reference_balance.hpp; docs/balance.md §9). Needs the QP solver of
  /// cleanupReference.
  bool balance = true;
  double zmp_margin_m = 0.02;     ///< the support shrunk by this towards each sole's centre (m)
  int balance_iterations = 4;     ///< at most this many shift-and-solve rounds
  double max_com_shift_m = 0.25;  ///< the CoM moved by at most this per axis (m)

  /// @throws std::invalid_argument naming the option on a bad value.
  void validate() const;
};

/// Which foot is in stance, frame by frame.
struct ContactSchedule {
  std::vector<std::string> links;     ///< foot links
  std::vector<int> bodies;            ///< their body indices
  std::vector<double> time_s;         ///< per frame
  std::vector<std::vector<char>> stance;  ///< [frame][foot]: 1 stance, 0 swing
};

struct JointChangeReport {
  std::string joint;
  double max_change_rad = 0.0, rms_change_rad = 0.0;
};

struct FootReport {
  std::string link;
  int stance_runs = 0;
  double stance_fraction = 0.0;
  double skate_before_m = 0.0, skate_after_m = 0.0;  ///< worst over stance runs
  double penetration_before_m = 0.0, penetration_after_m = 0.0;  ///< worst sole point, ≥ 0
  /// Stance runs held at the tilt the leg reaches instead of flat: a leg of fewer than six
  /// joints cannot orient its sole freely, and a flat sole it cannot reach with the body as
  /// the reference holds it would be bought by moving the body (turning the pelvis, bending
  /// the other leg). The largest tilt from flat of those runs' poses (rad).
  int tilted_runs = 0;
  double tilt_max_rad = 0.0;
};

struct CleanupReport {
  std::vector<JointChangeReport> joints;  ///< model order
  double rms_change_rad = 0.0;            ///< over all joints and frames
  double base_position_change_max_m = 0.0;
  std::vector<FootReport> feet;
  int joints_outside_before = 0, joints_outside_after = 0;  ///< joints leaving a limit
  double limit_excess_rms_before_rad = 0.0, limit_excess_rms_after_rad = 0.0;  ///< all joints
  double leg_length_m = 0.0;
  /// ZMP against the stance soles' support (shrunk by zmp_margin_m), before and after the
  /// balance stage: frames outside, largest and RMS (over all frames) distance (m)
  int zmp_frames_outside_before = 0, zmp_frames_outside_after = 0;
  double zmp_outside_max_before_m = 0.0, zmp_outside_max_after_m = 0.0;
  double zmp_outside_rms_before_m = 0.0, zmp_outside_rms_after_m = 0.0;
  double com_shift_max_m = 0.0, com_shift_rms_m = 0.0;  ///< the base moved along the ground
  FeasibleComReport com_path;      ///< the balance stage's CoM path (reference_balance.hpp)
  double com_path_error_m = 0.0;   ///< largest distance of the IK's CoM from that path
};

struct CleanupResult {
  ReferenceMotion motion;
  ContactSchedule schedule;
  CleanupReport report;
};

/// Finds the schedule of @p motion on @p model (see file comment) without changing it.
/// Changes the model's state. @throws std::invalid_argument on a bad option, a foot link
/// that is not in the model, or a model that touches the ground with no body at its
/// neutral stance.
ContactSchedule findContactSchedule(const ReferenceMotion& motion, IDynamicsModel& model,
                                    const ReferenceCleanupOptions& options);

/// Cleans @p motion up (see file comment). Changes the model's state.
/// @throws as findContactSchedule.
CleanupResult cleanupReference(const ReferenceMotion& motion, IDynamicsModel& model,
                               const ReferenceCleanupOptions& options, const QpSolverFactory& qp_solver);

/// Stance-foot skate of a motion against a schedule: per foot the worst horizontal slide
/// of a sole point while it touches the ground (within 5 mm) in a stance run (m), and the deepest sole
/// point below the ground (m, ≥ 0). Changes the model's state.
std::vector<FootReport> measureFeet(const ReferenceMotion& motion, IDynamicsModel& model,
                                    const ContactSchedule& schedule);

/// Writes the schedule as CSV (README "Reference motion file", contact schedule):
/// header `time,<foot link>,...`, one row per frame, 1 = stance, 0 = swing.
/// @throws InputError when the file cannot be written.
void writeContactScheduleCsv(const std::string& path, const ContactSchedule& schedule);

/// Human-readable report: per joint changed, per foot skate and penetration, limits.
std::string formatCleanupReport(const CleanupReport& report);

}  // namespace dynfilter::io
