#pragma once
/// @file
/// Plays reference clips in real time for a stream: speed factor, loop, start offset and
/// clip switching (on a schedule or on demand — the paper's interactivity: the filter
/// turns the jump between clips into a feasible transition).

#include <string>
#include <vector>

#include "dynfilter/core/reference_frame.hpp"

namespace dynfilter::realtime {

struct Clip {
  std::string name;
  std::vector<ReferenceFrame> frames;  ///< ≥ 2 frames, increasing time
  double duration() const { return frames.back().time_s - frames.front().time_s; }
};

struct ReplayOptions {
  double speed = 1.0;           ///< motion seconds per wall second (> 0)
  bool loop = false;            ///< restart a clip at its end instead of finishing
  double start_offset_s = 0.0;  ///< motion time at which every clip starts (s)
};

class ReplayPlayer {
 public:
  /// Throws std::invalid_argument on no clips, a clip with < 2 frames, speed ≤ 0 or an
  /// offset outside the first clip.
  ReplayPlayer(std::vector<Clip> clips, const ReplayOptions& options, bool floating_base);

  /// Starts clip @p index from its start offset at wall time @p wall_s.
  void switchTo(int index, double wall_s);

  /// The reference at wall time @p wall_s (seconds on the player's clock): the current
  /// clip interpolated at its motion time, with time_s set to that motion time. Returns
  /// false when a non-looping clip has ended (@p out then holds its last frame).
  bool frameAt(double wall_s, ReferenceFrame& out) const;

  int currentClip() const { return current_; }
  const std::vector<Clip>& clips() const { return clips_; }
  /// Frames per second of the current clip (its mean).
  double frameRate() const;

 private:
  std::vector<Clip> clips_;
  ReplayOptions options_;
  bool floating_base_;
  int current_ = 0;
  double clip_start_wall_s_ = 0.0;
};

}  // namespace dynfilter::realtime
