#pragma once
/// @file
/// The filter as a control loop: reference frames arrive at their own rate on the
/// sender's clock; the loop ticks at a fixed rate, samples the reference (interpolated,
/// a fixed delay behind the newest frame so that there is always a frame on each side;
/// a stream plays from its first frame, never before it, never past its newest frame,
/// and after waiting for a late sender catches up at most 1.5× real time), places a floating-base stream
/// under the robot and blends the robot's posture into it (RealtimeOptions),
/// optionally closes the loop on the measured robot state, and produces torque commands
/// that are finite and within the URDF limits. Transport-free: the LCM processes and the
/// tests drive it the same way. tick() does not allocate.

#include <cstdint>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dynfilter/core/dynamics_filter.hpp"
#include "dynfilter/core/reference_buffer.hpp"
#include "dynfilter/realtime/message_stream.hpp"

namespace dynfilter::realtime {

struct RealtimeOptions {
  /// Feed accepted frames (as placed and blended) to the balance layer's look-ahead
  /// (DynamicsFilter::previewFrame): the reference delay is its preview window. The
  /// filter's `balance.preview_capacity` is raised to the frames of the delay at
  /// kMaxSenderRateHz when it holds fewer.
  bool balance_preview = true;
  /// No reference frame for this long (s) → hold the current posture (damped by the
  /// filter's feedback) and report kStatusStaleReference.
  double stale_timeout_s = 0.25;
  /// Floating base: place each reference stream where the robot stands. When a stream
  /// starts (or follows a stale hold), the horizontal rigid motion (x, y and yaw about
  /// world z) that puts the stream's first base pose over the filter's base (the measured
  /// one when fresh) is applied to every frame of that stream: a motion captured anywhere
  /// in a capture volume starts under the robot instead of metres away (which trips the
  /// filter's base-error guard every tick). Heights, tilt, joints and the base-frame
  /// velocities are unchanged. false: the frames are in the robot's world frame already.
  bool align_to_robot = true;
  /// Soft start of a stream (s): over this time T the reference goes from the robot's
  /// posture when the stream starts (or follows a stale hold), at rest, into the stream:
  /// q = q_robot ⊕ s(τ) (q_stream ⊖ q_robot), τ = t / T, s the quintic 0 → 1, with the
  /// velocity s v_stream + ṡ (q_stream ⊖ q_robot) and the acceleration that go with it. The
  /// reference so starts at the robot's posture (a captured walk starts with an elbow
  /// 0.6–1.7 rad from the standing pose) and at rest, and the stream's motion comes in with
  /// s: a standing robot is not asked at once for the motion of a clip that starts moving.
  /// (Adding the posture offset to the stream and fading it out, as before 2026-11-30, asked
  /// for it: the closed-loop G1 fell 0.9 s into the CMU walk, before its first step; now
  /// about 2.0 s, docs/balance.md §33.) While s < 1 the reference moves faster than the
  /// stream by ṡ (q_stream ⊖ q_robot): with T = 1 s that tipped the squat on DART after
  /// sender gaps, hence 2 s. 0: no fade.
  double stream_blend_s = 2.0;
  /// The reference is played this far (s) behind the newest received frame's time, at most
  /// kMaxReferenceDelayS. The frames of that span and of stale_timeout_s are kept for a
  /// sender of up to kMaxSenderRateHz (about 1 KB a frame for a 40-joint model: 0.3 MB with
  /// the defaults); a faster sender keeps that many frames.
  double reference_delay_s = 0.05;
  static constexpr double kMaxReferenceDelayS = 10.0;
  static constexpr double kMaxSenderRateHz = 1000.0;
  /// Start a tick from the measured robot state when a new one has arrived (each state is
  /// used once); between states the filter runs on from its own state.
  bool use_measured_state = false;
  /// A measured state received longer ago than this (s) is not used.
  double measured_state_timeout_s = 0.05;
  /// Stream policy (message_stream.hpp) of both the reference and the robot state: the
  /// clock tolerance, the messages in a row that make a new stream, and the optional
  /// bound on |stamp − receive time| for senders on this clock (0: off). A stream silent
  /// for stale_timeout_s (references) or measured_state_timeout_s (states) is followed
  /// anew by its next message.
  double clock_tolerance_s = 0.5;
  int new_stream_messages = 3;
  double max_clock_offset_s = 0.0;
};

struct Counters {
  std::uint64_t frames_accepted = 0;
  std::uint64_t frames_rejected = 0;  ///< off the reference stream (referenceStream())
  std::uint64_t ticks = 0;
  std::uint64_t stale_ticks = 0;
  std::uint64_t reseeds = 0;
  std::uint64_t torque_clamps = 0;
};

class RealtimeFilter {
 public:
  /// Holds @p hold_posture (a reference frame of the model) until the first frame arrives.
  /// Throws std::invalid_argument on a negative or non-finite stream_blend_s or
  /// reference_delay_s, on a reference_delay_s or stale_timeout_s above
  /// kMaxReferenceDelayS (and as MessageStream on bad stream options).
  RealtimeFilter(IDynamicsModel& model, const FilterOptions& filter_options,
                 const RealtimeOptions& options, const ReferenceFrame& hold_posture,
                 const QpSolverFactory& qp_solver = {});

  /// A validated reference frame; frame.time_s is on the sender's clock (s), @p now_s
  /// the local clock at reception, @p sequence the sender's frame number (-1: none).
  /// Returns false (counted as rejected; referenceStream().lastRejection() says why) when
  /// the frame is off the followed stream, and (counted, before the stream policy) when its
  /// sizes are not the model's or it is not finite. A frame that starts a new stream (a restarted
  /// sender, a jumped clock, after silence) resets the reference history and the clock
  /// offset, and (RealtimeOptions::align_to_robot) places the stream under the robot. With
  /// RealtimeOptions::balance_preview an accepted frame also enters the filter's preview
  /// (DynamicsFilter::previewFrame): the reference delay is the balance layer's look-ahead.
  /// No allocation.
  bool addReference(const ReferenceFrame& frame, double now_s, std::int64_t sequence = -1);

  /// A validated measured state (q: nq, v: nv) stamped @p stamp_s on the robot's clock,
  /// received at @p now_s. Returns false when it is off the state stream (not used). With
  /// use_measured_state the next tick starts from the newest accepted state, once.
  bool addMeasuredState(const Eigen::Ref<const Eigen::VectorXd>& q,
                        const Eigen::Ref<const Eigen::VectorXd>& v, double stamp_s,
                        double now_s);

  /// One control tick at local time @p now_s. Never throws.
  const FilterOutput& tick(double now_s);

  /// Status bits of the last tick: the filter's, plus kStatusStaleReference and
  /// kStatusTorqueClamped from this layer.
  std::uint32_t status() const { return status_; }
  /// Torques to publish after tick(): the filter's τ_J clamped to ±tau_max (dim nj).
  const Eigen::VectorXd& command() const { return command_; }
  /// The horizontal placement of the followed stream (RealtimeOptions::align_to_robot):
  /// world-from-stream, a rotation about z and a translation in x, y (identity without).
  const Eigen::Isometry3d& streamPlacement() const { return X_WS_; }
  /// The followed stream's offset from the robot when it started, q_robot ⊖ q_first (nv,
  /// zero without a blend), which the soft start (RealtimeOptions::stream_blend_s) closes.
  const Eigen::VectorXd& streamOffset() const { return blend_offset_; }
  /// The reference sample the last tick used (its time on the sender's clock).
  const ReferenceFrame& lastReference() const { return sample_; }
  const Counters& counters() const { return counters_; }
  /// The reference and robot-state streams: verdicts, counters, clock offsets.
  const MessageStream& referenceStream() const { return references_; }
  const MessageStream& stateStream() const { return states_; }
  bool stale() const { return stale_; }
  const DynamicsFilter& filter() const { return filter_; }

 private:
  IDynamicsModel& model_;
  RealtimeOptions options_;
  DynamicsFilter filter_;
  ReferenceBuffer buffer_;
  MessageStream references_, states_;
  ReferenceFrame hold_, sample_, placed_;
  Eigen::Isometry3d X_WS_ = Eigen::Isometry3d::Identity();
  Eigen::VectorXd blend_offset_;  // q_robot ⊖ q_first of the stream (nv)
  Eigen::VectorXd blend_q0_;      // q_robot when the stream started (nq)
  Eigen::VectorXd blend_step_;    // q_stream ⊖ q_robot of the frame being placed (nv)
  Eigen::VectorXd command_, measured_q_, measured_v_;
  double clock_offset_s_ = 0.0;  // local − sender
  double stream_start_s_ = 0.0;  // the followed stream's first frame (sender's clock)
  double play_s_ = 0.0;          // the sampled time (sender's clock)
  double last_tick_s_ = 0.0;     // local time of the previous tick
  double last_frame_local_s_ = -1e300;
  double measured_local_s_ = -1e300;
  bool measured_fresh_ = false;  // a state arrived since the last tick
  bool stale_ = true;
  std::uint32_t status_ = 0;
  Counters counters_;
};

}  // namespace dynfilter::realtime
