#include "dynfilter/realtime/realtime_filter.hpp"

#include <algorithm>
#include <cmath>

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

}  // namespace

RealtimeFilter::RealtimeFilter(IDynamicsModel& model, const FilterOptions& filter_options,
                               const RealtimeOptions& options, const ReferenceFrame& hold_posture,
                               const QpSolverFactory& qp_solver)
    : model_(model),
      options_(options),
      filter_(model, filter_options, qp_solver),
      buffer_(model.nq(), model.nv(), model.info().floating_base),
      references_(streamOptions(options, options.stale_timeout_s)),
      states_(streamOptions(options, options.measured_state_timeout_s)),
      hold_(hold_posture),
      sample_(model.nq(), model.nv()),
      command_(Eigen::VectorXd::Zero(model.nj())),
      measured_q_(model.info().neutralConfiguration()),
      measured_v_(Eigen::VectorXd::Zero(model.nv())) {
  filter_.reset(hold_);
}

bool RealtimeFilter::addReference(const ReferenceFrame& frame, double now_s,
                                  std::int64_t sequence) {
  const StreamVerdict verdict = references_.judge(frame.time_s, now_s, sequence);
  if (!accepted(verdict)) {
    ++counters_.frames_rejected;
    return false;
  }
  if (stale_ || verdict == StreamVerdict::kNewStream) {
    // (Re)start on this stream: its clock against ours, an empty history.
    buffer_.clear();
    clock_offset_s_ = now_s - frame.time_s;
    stream_start_s_ = frame.time_s;
  }
  if (!buffer_.push(frame)) {
    ++counters_.frames_rejected;
    return false;
  }
  ++counters_.frames_accepted;
  // Look-ahead of the QP mode's balance layer (the frames between the sampled time and
  // the newest), only when asked for: with it, the ODE robot in the LCM closed loop fell
  // in 2 of 3 runs on a loaded machine (0 of 3 without; cause not found yet).
  if (options_.balance_preview) filter_.previewFrame(frame);
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
    // A stream plays from its first frame: for the first reference delay after the
    // hand-over the sample waits at that frame (its pose and velocity) instead of a pose
    // at rest before it, so that the tick's reference and the balance layer's preview (the
    // same frames) agree. Before it, the sample had v = 0 while the preview's first frame
    // moved: the layer's reference CoM acceleration (Δċ over the ever shorter time to
    // that frame) reached 14 m/s² and the closed-loop robot fell.
    const double t = now_s - clock_offset_s_ - options_.reference_delay_s;
    buffer_.sample(std::max(t, stream_start_s_), sample_);
    if (t < stream_start_s_) {
      sample_.v.setZero();
      sample_.vdot.setZero();
    }
  }
  if (options_.use_measured_state && now_s - measured_local_s_ <= options_.measured_state_timeout_s)
    filter_.setMeasuredState(measured_q_, measured_v_);

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
