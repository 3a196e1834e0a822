#include "dynfilter/realtime/replay_player.hpp"

#include <cmath>
#include <stdexcept>

namespace dynfilter::realtime {

ReplayPlayer::ReplayPlayer(std::vector<Clip> clips, const ReplayOptions& options,
                           bool floating_base)
    : clips_(std::move(clips)), options_(options), floating_base_(floating_base) {
  if (clips_.empty()) throw std::invalid_argument("replay: no clip");
  for (const Clip& c : clips_)
    if (c.frames.size() < 2) throw std::invalid_argument("replay: clip \"" + c.name + "\" has < 2 frames");
  if (!(options_.speed > 0.0) || !std::isfinite(options_.speed))
    throw std::invalid_argument("replay: speed must be > 0");
  if (options_.start_offset_s < 0.0 || options_.start_offset_s >= clips_.front().duration())
    throw std::invalid_argument("replay: start offset outside the first clip");
}

void ReplayPlayer::switchTo(int index, double wall_s) {
  if (index < 0 || index >= static_cast<int>(clips_.size()))
    throw std::invalid_argument("replay: no clip " + std::to_string(index));
  current_ = index;
  clip_start_wall_s_ = wall_s;
}

double ReplayPlayer::frameRate() const {
  const Clip& c = clips_[static_cast<std::size_t>(current_)];
  return static_cast<double>(c.frames.size() - 1) / c.duration();
}

bool ReplayPlayer::frameAt(double wall_s, ReferenceFrame& out) const {
  const Clip& clip = clips_[static_cast<std::size_t>(current_)];
  const double duration = clip.duration();
  double t = std::min(options_.start_offset_s, duration) +
             options_.speed * std::max(0.0, wall_s - clip_start_wall_s_);
  bool running = true;
  if (t > duration) {
    if (options_.loop) {
      t = std::fmod(t, duration);
    } else {
      t = duration;
      running = false;
    }
  }
  const double t_clip = clip.frames.front().time_s + t;
  std::size_t i = 0;
  while (i + 2 < clip.frames.size() && clip.frames[i + 1].time_s <= t_clip) ++i;
  interpolateReference(floating_base_, clip.frames[i], clip.frames[i + 1], t_clip, out);
  // Velocities and accelerations scale with the playback speed.
  out.v *= options_.speed;
  out.vdot *= options_.speed * options_.speed;
  return running;
}

}  // namespace dynfilter::realtime
