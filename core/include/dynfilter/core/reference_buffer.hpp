#pragma once
/// @file
/// The latest reference frames, for a control loop that ticks faster than the reference
/// arrives (1 kHz against 30–120 Hz mocap): a fixed-capacity ring of frames on the
/// reference's own clock, sampled by interpolation and never extrapolated.

#include <vector>

#include "dynfilter/core/reference_frame.hpp"

namespace dynfilter {

class ReferenceBuffer {
 public:
  /// @param capacity frames kept (the oldest is dropped when full). Allocates once.
  ReferenceBuffer(int nq, int nv, bool floating_base, int capacity = 16);

  /// Appends a frame whose time is after the newest one; returns false (and keeps
  /// nothing) otherwise. The frame must be valid (the caller validated it). No allocation.
  bool push(const ReferenceFrame& frame);

  /// The reference at @p t_s: interpolated between the two frames around it (SE(3)
  /// geodesic for the base); before the oldest frame the oldest pose and after the newest
  /// the newest pose, both with zero velocity and acceleration (hold, never extrapolate).
  /// Returns false when empty. @p out must have the model's sizes. No allocation.
  bool sample(double t_s, ReferenceFrame& out) const;

  void clear() { size_ = 0; }
  int size() const { return size_; }
  bool empty() const { return size_ == 0; }
  double newestTime() const;
  double oldestTime() const;

 private:
  const ReferenceFrame& at(int i) const;  // 0 = oldest

  bool floating_base_;
  std::vector<ReferenceFrame> frames_;
  int head_ = 0;  // index of the oldest
  int size_ = 0;
};

}  // namespace dynfilter
