#pragma once
/// @file
/// Clean-up of a retargeted reference motion before it is filtered: a contact schedule
/// from the reference (a foot near the ground and slow = stance), stance feet held still
/// and on the ground (no skating, no sinking) by adjusting the legs with PoseIk, and every
/// joint inside the model's limits; the change is reported.
///
/// Method:
///  - Feet: the links named in ReferenceCleanupOptions::feet, or else the bodies that touch
///    the ground when the model stands at its neutral configuration (standingBaseHeight).
///    Sole points: the contact points of that stance, in the foot's frame.
///  - Size: L = the standing base height at the neutral configuration (m), the leg length
///    every threshold is relative to.
///  - Schedule: frame k is stance for foot f when the lowest sole point is at most
///    contact_height · L above the ground and the sole's centre moves horizontally slower
///    than contact_speed · L per second (central differences); runs of stance or swing
///    shorter than min_phase_s are merged into their neighbours.
///  - Stance pose of a run: the foot flat (its neutral-stance orientation turned by the
///    run's mean heading about the ground normal), its sole centre at the run's mean
///    horizontal position, the sole on the ground. Over blend_s before and after the run,
///    the foot's target moves smoothly between the reference pose and the stance pose
///    (over at most half the swing between two runs, so the target stays continuous).
///  - Per frame, PoseIk solves for the whole configuration: the feet at their targets
///    (stance pose or blend; swing feet at the reference pose), every other coordinate
///    held at the reference (base weight base_weight, joints posture_weight, a lower weight
///    for the joints between the base and a foot so that the legs take up the change), all
///    within the joint limits; a continuity term (continuity_weight) holds each frame's
///    change near the reference's own change, so the answer follows one branch over the
///    clip. Velocities and accelerations are estimated again.
///  - Report: per joint max and RMS change, overall RMS; per foot the stance skate (largest
///    horizontal distance of the sole centre from its position at the start of the stance
///    run) and the largest penetration of a sole point, before and after; limit excess
///    before and after.

#include <string>
#include <vector>

#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/io/reference_motion.hpp"

namespace dynfilter::io {

struct ReferenceCleanupOptions {
  std::vector<std::string> feet;  ///< foot links; empty: found from the neutral stance
  double contact_height = 0.04;   ///< sole height threshold, fraction of the leg length L
  double contact_speed = 0.4;     ///< horizontal sole speed threshold, L per second
  double min_phase_s = 0.08;      ///< shorter stance or swing runs are merged (s)
  double blend_s = 0.08;          ///< foot target transition before / after a stance (s)
  double base_weight = 1.0;       ///< IK weight holding the base at the reference
  double posture_weight = 1.0;    ///< IK weight holding joints (not on a leg) at the reference
  double leg_weight = 0.05;       ///< IK weight holding the leg joints at the reference
  /// IK weight holding each frame's change at the reference's change (PoseIk's continuity
  /// term, about the previous frame's answer moved by the reference's own change); 0: off
  double continuity_weight = 1.0;
  int smoothing_window = 7;       ///< estimateDerivatives window (odd, ≥ 3)

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
};

struct CleanupReport {
  std::vector<JointChangeReport> joints;  ///< model order
  double rms_change_rad = 0.0;            ///< over all joints and frames
  double base_position_change_max_m = 0.0;
  std::vector<FootReport> feet;
  int joints_outside_before = 0, joints_outside_after = 0;  ///< joints leaving a limit
  double limit_excess_rms_before_rad = 0.0, limit_excess_rms_after_rad = 0.0;  ///< all joints
  double leg_length_m = 0.0;
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
                               const ReferenceCleanupOptions& options);

/// Stance-foot skate of a motion against a schedule: per foot the worst horizontal
/// distance of the sole centre from where its stance run began (m), and the deepest sole
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
