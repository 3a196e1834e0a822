#pragma once
/// @file
/// Filtering a whole reference motion offline: the tick schedule and the loop that
/// `dynfilter-offline` and the Python binding's `filter_motion` both run, so that the two
/// give bit-identical results.
///
/// Schedule: a uniformly sampled reference (the usual mocap case; every frame interval
/// within 1e-6 of the mean) is filtered with a whole number of ticks per frame,
/// round(period × tick_hz) ≥ 1, so that every frame time is a tick; any other reference at
/// 1 / tick_hz, each frame written by the tick nearest to it. Between frames the reference
/// is interpolated (interpolateReference: SE(3) geodesic for the base). Offline the whole
/// clip is known: the balance layer's look-ahead (QP mode) gets every frame up to
/// preview_s ahead of each tick, by default all of the clip.

#include <functional>
#include <limits>

#include "dynfilter/core/dynamics_filter.hpp"
#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/core/filter_options.hpp"
#include "dynfilter/core/filter_output.hpp"
#include "dynfilter/core/qp_solver.hpp"
#include "dynfilter/core/reference_frame.hpp"
#include "dynfilter/io/reference_motion.hpp"

namespace dynfilter::io {

struct OfflineRunOptions {
  double tick_hz = 500.0;   ///< filter rate (Hz), finite and > 0
  bool every_tick = false;  ///< a row per tick instead of one per reference frame
  /// Look-ahead of the balance layer (s, ≥ 0); NaN: the whole clip.
  double preview_s = std::numeric_limits<double>::quiet_NaN();

  /// Throws std::invalid_argument on a tick rate that is not finite and positive or a
  /// negative preview.
  void validate() const;
};

/// The ticks of an offline run.
struct OfflineSchedule {
  bool uniform = false;  ///< whole number of ticks per frame
  long substeps = 0;     ///< ticks per frame when uniform, else 0
  double dt_s = 0.0;     ///< filter tick (s)
  long ticks = 0;        ///< ticks in the run (the first at the first frame's time)
};

/// The schedule for @p motion (≥ 2 frames, increasing time) at @p options.tick_hz.
/// @throws std::invalid_argument on fewer than 2 frames or invalid @p options.
OfflineSchedule planOfflineRun(const ReferenceMotion& motion, const OfflineRunOptions& options);

/// What the loop hands to the caller after every tick.
struct OfflineTick {
  long index = 0;  ///< tick number, 0 ≤ index < count
  long count = 0;  ///< ticks in the run
  double time_s = 0.0;  ///< the tick's time (s)
  bool row = false;  ///< an output row: a reference frame's tick, or every tick with every_tick
  /// With row: the union of the statuses of the ticks since the previous row, this one
  /// included, so that a re-seed between two rows shows in the next row's status.
  std::uint32_t row_status = 0;
  /// With row: the reason of the last re-seed among those ticks (kNone: none re-seeded).
  ReseedReason row_reseed_reason = ReseedReason::kNone;
  const ReferenceFrame* reference = nullptr;  ///< the interpolated reference of the tick
  const FilterOutput* output = nullptr;       ///< the filter's output of the tick
  const DynamicsFilter* filter = nullptr;     ///< the filter (e.g. its taskBody())
};

/// Runs a DynamicsFilter on @p model through the whole of @p motion: reset to the first
/// frame, then one step per tick of planOfflineRun(). @p filter_options.dt_s is replaced by
/// the schedule's tick, balance.preview_s by @p options.preview_s (the clip's duration
/// when NaN) and balance.preview_capacity raised to hold every frame. @p on_tick is called after every tick (the model's state may be
/// changed in it: the filter sets the state it needs at each step).
/// @p model's environment (ground, boxes) is the one the filter sees.
/// @throws std::invalid_argument on invalid options (FilterOptions::validate, the QP mode
///         without @p qp_solver) or fewer than 2 frames; InvalidStateError on an invalid
///         first frame; whatever @p on_tick throws (the run stops there).
OfflineSchedule runOffline(IDynamicsModel& model, FilterOptions filter_options,
                           const ReferenceMotion& motion, const OfflineRunOptions& options,
                           const QpSolverFactory& qp_solver,
                           const std::function<void(const OfflineTick&)>& on_tick);

}  // namespace dynfilter::io
