#include "dynfilter/realtime/realtime_filter.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include <Eigen/Geometry>

#include "dynfilter/core/lie_group.hpp"

namespace dynfilter::realtime {
namespace {

StreamOptions streamOptions(const RealtimeOptions& options, double silence_s) {
  StreamOptions s;
  s.clock_tolerance_s = options.clock_tolerance_s;
  s.new_stream_messages = options.new_stream_messages;
  s.max_clock_offset_s = options.max_clock_offset_s;
  s.silence_s = silence_s;
  return s;
}

// A play time held back (a late sender) catches up at most this fast (× real time).
constexpr double kCatchUpRate = 1.5;

// Throws std::invalid_argument on the options RealtimeFilter refuses; returns them.
const RealtimeOptions& validated(const RealtimeOptions& options) {
  if (!std::isfinite(options.stream_blend_s) || options.stream_blend_s < 0.0 ||
      !std::isfinite(options.reference_delay_s) || options.reference_delay_s < 0.0)
    throw std::invalid_argument("RealtimeOptions: stream_blend_s and reference_delay_s must be finite and >= 0");
  if (options.reference_delay_s > RealtimeOptions::kMaxReferenceDelayS ||
      !(options.stale_timeout_s <= RealtimeOptions::kMaxReferenceDelayS))
  {
    char bound[32];
    std::snprintf(bound, sizeof bound, "%g", RealtimeOptions::kMaxReferenceDelayS);
    throw std::invalid_argument(std::string("RealtimeOptions: reference_delay_s and stale_timeout_s must be <= ") +
                                bound + " s");
  }
  return options;
}

// The frames a sender at up to RealtimeOptions::kMaxSenderRateHz sends over @p span_s,
// and one at either end.
int framesAtMaxRate(double span_s) {
  return static_cast<int>(std::ceil(std::max(0.0, span_s) * RealtimeOptions::kMaxSenderRateHz)) + 2;
}

// The frames the buffer keeps: those of the reference delay and of the longest silence a
// stream survives (the play time then lags the newest frame by both). (A negative stale
// timeout is refused by MessageStream.)
int bufferCapacity(const RealtimeOptions& o) {
  return framesAtMaxRate(o.reference_delay_s + o.stale_timeout_s);
}

// The filter's options with a balance preview that holds every frame between the sampled
// time and the newest (the reference delay): a fuller preview drops its oldest samples,
// the ones the DCM target needs first.
FilterOptions withPreviewOfTheDelay(FilterOptions filter_options, const RealtimeOptions& o) {
  if (o.balance_preview)
    filter_options.balance.preview_capacity =
        std::max(filter_options.balance.preview_capacity, framesAtMaxRate(o.reference_delay_s));
  return filter_options;
}

}  // namespace

RealtimeFilter::RealtimeFilter(IDynamicsModel& model, const FilterOptions& filter_options,
                               const RealtimeOptions& options, const ReferenceFrame& hold_posture,
                               const QpSolverFactory& qp_solver)
    : model_(model),
      options_(validated(options)),
      filter_(model, withPreviewOfTheDelay(filter_options, options_), qp_solver),
      buffer_(model.nq(), model.nv(), model.info().floating_base, bufferCapacity(options)),
      references_(streamOptions(options, options.stale_timeout_s)),
      states_(streamOptions(options, options.measured_state_timeout_s)),
      hold_(hold_posture),
      sample_(model.nq(), model.nv()),
      placed_(model.nq(), model.nv()),
      blend_offset_(Eigen::VectorXd::Zero(model.nv())),
      blend_q0_(model.info().neutralConfiguration()),
      blend_step_(Eigen::VectorXd::Zero(model.nv())),
      command_(Eigen::VectorXd::Zero(model.nj())),
      measured_q_(model.info().neutralConfiguration()),
      measured_v_(Eigen::VectorXd::Zero(model.nv())) {
  filter_.reset(hold_);
}

bool RealtimeFilter::addReference(const ReferenceFrame& frame, double now_s,
                                  std::int64_t sequence) {
  // A malformed frame (sizes, non-finite) never reaches the stream policy.
  if (frame.q.size() != model_.nq() || frame.v.size() != model_.nv() || frame.vdot.size() != model_.nv() ||
      !frame.q.allFinite() || !frame.v.allFinite() || !frame.vdot.allFinite()) {
    ++counters_.frames_rejected;
    return false;
  }
  const StreamVerdict verdict = references_.judge(frame.time_s, now_s, sequence);
  if (!accepted(verdict)) {
    ++counters_.frames_rejected;
    return false;
  }
  const bool floating = model_.info().floating_base;
  const bool starts = stale_ || verdict == StreamVerdict::kNewStream;
  const bool measured =
      options_.use_measured_state && now_s - measured_local_s_ <= options_.measured_state_timeout_s;
  const Eigen::VectorXd& robot = measured ? measured_q_ : filter_.q();
  if (starts) {
    // (Re)start on this stream: its clock against ours, an empty history, its placement.
    buffer_.clear();
    clock_offset_s_ = now_s - frame.time_s;
    stream_start_s_ = frame.time_s;
    play_s_ = frame.time_s;
    X_WS_.setIdentity();
    if (floating && options_.align_to_robot) {
      const double yaw = tiltAndHeading(basePoseFromConfiguration(frame.q).linear(),
                                        basePoseFromConfiguration(robot).linear()).heading_rad;
      X_WS_.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      const Eigen::Vector3d p_S(frame.q[0], frame.q[1], 0.0), p_W(robot[0], robot[1], 0.0);
      X_WS_.translation() = p_W - X_WS_.linear() * p_S;
    }
  }
  // The frame as placed in the robot's world (base position and orientation; the base
  // velocities are in base axes and stay).
  placed_.time_s = frame.time_s;
  placed_.q = frame.q;  // same sizes (checked above): no allocation
  placed_.v = frame.v;
  placed_.vdot = frame.vdot;
  if (floating) moveBase(X_WS_, placed_.q);
  // Soft start (RealtimeOptions::stream_blend_s): q_robot ⊕ s(τ) (q ⊖ q_robot).
  if (starts) {
    if (options_.stream_blend_s > 0.0) differenceConfiguration(floating, placed_.q, robot, blend_offset_);
    else blend_offset_.setZero();
    blend_q0_ = robot;  // same size: no allocation
  }
  const double tau = options_.stream_blend_s > 0.0
                         ? (frame.time_s - stream_start_s_) / options_.stream_blend_s
                         : 1.0;
  if (tau < 1.0) {
    const double T = options_.stream_blend_s, t2 = tau * tau;
    const double s = t2 * tau * (10.0 - 15.0 * tau + 6.0 * t2);
    const double sdot = 30.0 * t2 * (1.0 - tau) * (1.0 - tau) / T;
    const double sddot = 60.0 * tau * (1.0 - tau) * (1.0 - 2.0 * tau) / (T * T);
    differenceConfiguration(floating, blend_q0_, placed_.q, blend_step_);
    integrateConfiguration(floating, blend_q0_, blend_step_, s, placed_.q);
    placed_.vdot = s * placed_.vdot + 2.0 * sdot * placed_.v + sddot * blend_step_;
    placed_.v = s * placed_.v + sdot * blend_step_;
  }
  if (!buffer_.push(placed_)) {
    ++counters_.frames_rejected;
    return false;
  }
  ++counters_.frames_accepted;
  // Look-ahead of the QP mode's balance layer: the frames between the sampled time and the
  // newest.
  if (options_.balance_preview) filter_.previewFrame(placed_);
  last_frame_local_s_ = now_s;
  stale_ = false;
  return true;
}

bool RealtimeFilter::addMeasuredState(const Eigen::Ref<const Eigen::VectorXd>& q,
                                      const Eigen::Ref<const Eigen::VectorXd>& v,
                                      double stamp_s, double now_s) {
  if (!accepted(states_.judge(stamp_s, now_s))) return false;
  measured_q_ = q;
  measured_v_ = v;
  measured_local_s_ = now_s;
  measured_fresh_ = true;
  return true;
}

const FilterOutput& RealtimeFilter::tick(double now_s) {
  ++counters_.ticks;
  if (!stale_ && now_s - last_frame_local_s_ > options_.stale_timeout_s) {
    // Hold where the filter is now, at rest.
    stale_ = true;
    hold_.q = filter_.q();
    hold_.v.setZero();
    hold_.vdot.setZero();
  }
  if (stale_) {
    ++counters_.stale_ticks;
    sample_.q = hold_.q;
    sample_.v = hold_.v;
    sample_.vdot = hold_.vdot;
    sample_.time_s = now_s;
  } else {
    // The play time follows the sender's clock a reference delay behind, but a stream
    // plays from its first frame (for the first reference delay the sample waits there, at
    // rest: sampling before it, at rest, while the balance layer's preview held that frame
    // moving, gave a reference CoM acceleration Δċ/Δt of up to 14 m/s² and the closed-loop
    // robot fell), never runs past the newest frame (a late sender: it waits there, at
    // rest), and after waiting catches up at most kCatchUpRate × real time instead of
    // jumping ahead.
    const double target = now_s - clock_offset_s_ - options_.reference_delay_s;
    const double dt = std::clamp(now_s - last_tick_s_, 0.0, 1.0);
    double play = play_s_ < target ? std::min(target, play_s_ + kCatchUpRate * dt) : play_s_;
    play = std::max(std::min(play, buffer_.newestTime()), stream_start_s_);
    const bool waiting = target < stream_start_s_ || (play >= buffer_.newestTime() && target > play);
    play_s_ = play;
    buffer_.sample(play, sample_);
    if (waiting) {
      sample_.v.setZero();
      sample_.vdot.setZero();
    }
  }
  last_tick_s_ = now_s;
  // A state is used once: without a newer one the filter runs on from its own state (its
  // model's prediction under the commands it sent), not again from a state that ages.
  if (options_.use_measured_state && measured_fresh_ &&
      now_s - measured_local_s_ <= options_.measured_state_timeout_s)
    filter_.setMeasuredState(measured_q_, measured_v_);
  measured_fresh_ = false;

  const FilterOutput& out = filter_.step(sample_);
  std::uint32_t extra = stale_ ? kStatusStaleReference : 0u;
  if (out.status & kStatusReseeded) ++counters_.reseeds;
  // The filter keeps its last good output on a failed tick, so τ_J is always finite.
  const ModelInfo& info = model_.info();
  bool clamped = false;
  for (int j = 0; j < info.nj; ++j) {
    const double tau = out.tau_J[j];
    command_[j] = std::clamp(tau, -info.tau_max[j], info.tau_max[j]);
    // The QP mode meets the limits to its tolerance (~1e-7 N m): only a real excess counts.
    clamped |= std::abs(command_[j] - tau) > 1e-6;
  }
  if (clamped) {
    extra |= kStatusTorqueClamped;
    ++counters_.torque_clamps;
  }
  status_ = out.status | extra;
  return out;
}

}  // namespace dynfilter::realtime
