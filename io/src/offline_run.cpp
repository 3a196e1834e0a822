#include "dynfilter/io/offline_run.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>


namespace dynfilter::io {

void OfflineRunOptions::validate() const {
  if (!std::isfinite(tick_hz) || tick_hz <= 0.0)
    throw std::invalid_argument("tick_hz must be finite and > 0, got " + std::to_string(tick_hz));
  if (preview_s < 0.0 || std::isinf(preview_s))
    throw std::invalid_argument("preview_s must be >= 0 (or NaN: the whole clip), got " +
                                std::to_string(preview_s));
}

OfflineSchedule planOfflineRun(const ReferenceMotion& motion, const OfflineRunOptions& options) {
  options.validate();
  const auto& frames = motion.frames;
  if (frames.size() < 2)
    throw std::invalid_argument("a reference motion needs at least 2 frames, got " +
                                std::to_string(frames.size()));
  const double t0 = frames.front().time_s, t_end = frames.back().time_s;
  const double period = (t_end - t0) / static_cast<double>(frames.size() - 1);
  OfflineSchedule s;
  s.uniform = true;
  for (std::size_t i = 1; i < frames.size(); ++i)
    s.uniform &= std::abs(frames[i].time_s - frames[i - 1].time_s - period) <= 1e-6 * period;
  s.substeps = s.uniform ? std::max(1L, std::lround(period * options.tick_hz)) : 0;
  s.dt_s = s.uniform ? period / static_cast<double>(s.substeps) : 1.0 / options.tick_hz;
  s.ticks = s.uniform ? static_cast<long>(frames.size() - 1) * s.substeps + 1
                      : std::lround(std::floor((t_end - t0) / s.dt_s + 1e-9)) + 1;
  return s;
}

OfflineSchedule runOffline(IDynamicsModel& model, FilterOptions filter_options,
                           const ReferenceMotion& motion, const OfflineRunOptions& options,
                           const QpSolverFactory& qp_solver,
                           const std::function<void(const OfflineTick&)>& on_tick) {
  const OfflineSchedule s = planOfflineRun(motion, options);
  const auto& frames = motion.frames;
  const double t0 = frames.front().time_s, dt = s.dt_s;
  filter_options.dt_s = s.dt_s;
  filter_options.balance.preview_s =
      std::isnan(options.preview_s) ? frames.back().time_s - t0 : options.preview_s;
  filter_options.balance.preview_capacity =
      std::max(filter_options.balance.preview_capacity, static_cast<int>(frames.size()) + 1);

  DynamicsFilter filter(model, filter_options, qp_solver);
  filter.reset(frames.front());
  ReferenceFrame ref(model.nq(), model.nv());
  std::size_t segment = 0, next_frame = 0, previewed = 0;
  OfflineTick tick;
  tick.count = s.ticks;
  tick.reference = &ref;
  tick.filter = &filter;
  std::uint32_t status_since_row = 0;
  ReseedReason reseed_since_row = ReseedReason::kNone;
  for (long k = 0; k < s.ticks; ++k) {
    const double t = s.uniform ? frames[static_cast<std::size_t>(k / s.substeps)].time_s +
                                     static_cast<double>(k % s.substeps) * dt
                               : t0 + static_cast<double>(k) * dt;
    while (segment + 2 < frames.size() && frames[segment + 1].time_s <= t) ++segment;
    while (previewed < frames.size() &&
           frames[previewed].time_s <= t + filter_options.balance.preview_s + 1e-9)
      filter.previewFrame(frames[previewed++]);
    interpolateReference(model.info().floating_base, frames[segment], frames[segment + 1], t, ref);
    const FilterOutput& out = filter.step(ref);
    bool row = options.every_tick || (s.uniform && k % s.substeps == 0);
    if (!s.uniform)
      while (next_frame < frames.size() && frames[next_frame].time_s < t + 0.5 * dt) {
        row = true;
        ++next_frame;
      }
    status_since_row |= out.status;
    if (out.status & kStatusReseeded) reseed_since_row = out.reseed_reason;
    tick.index = k;
    tick.time_s = t;
    tick.row = row;
    tick.row_status = row ? status_since_row : 0;
    tick.row_reseed_reason = row ? reseed_since_row : ReseedReason::kNone;
    if (row) {
      status_since_row = 0;
      reseed_since_row = ReseedReason::kNone;
    }
    tick.output = &out;
    if (on_tick) on_tick(tick);
  }
  return s;
}

}  // namespace dynfilter::io
