#include "dynfilter/core/reference_buffer.hpp"

namespace dynfilter {

ReferenceBuffer::ReferenceBuffer(int nq, int nv, bool floating_base, int capacity)
    : floating_base_(floating_base),
      frames_(static_cast<std::size_t>(capacity < 2 ? 2 : capacity), ReferenceFrame(nq, nv)) {}

const ReferenceFrame& ReferenceBuffer::at(int i) const {
  return frames_[static_cast<std::size_t>((head_ + i) % static_cast<int>(frames_.size()))];
}

double ReferenceBuffer::newestTime() const { return size_ ? at(size_ - 1).time_s : 0.0; }
double ReferenceBuffer::oldestTime() const { return size_ ? at(0).time_s : 0.0; }

bool ReferenceBuffer::push(const ReferenceFrame& frame) {
  if (size_ > 0 && !(frame.time_s > newestTime())) return false;
  const int capacity = static_cast<int>(frames_.size());
  if (size_ == capacity) {
    head_ = (head_ + 1) % capacity;
    --size_;
  }
  ReferenceFrame& slot = frames_[static_cast<std::size_t>((head_ + size_) % capacity)];
  slot.time_s = frame.time_s;
  slot.q = frame.q;  // same sizes: no allocation
  slot.v = frame.v;
  slot.vdot = frame.vdot;
  ++size_;
  return true;
}

bool ReferenceBuffer::sample(double t_s, ReferenceFrame& out) const {
  if (size_ == 0) return false;
  if (t_s >= newestTime()) {
    const ReferenceFrame& newest = at(size_ - 1);
    out.time_s = t_s;
    out.q = newest.q;
    out.v.setZero();
    out.vdot.setZero();
    if (size_ == 1 || t_s == newestTime()) {
      out.v = newest.v;
      out.vdot = newest.vdot;
    }
    return true;
  }
  if (t_s < oldestTime()) {  // before the stream starts: its first pose, at rest
    out.time_s = t_s;
    out.q = at(0).q;
    out.v.setZero();
    out.vdot.setZero();
    return true;
  }
  int i = size_ - 2;
  while (i > 0 && at(i).time_s > t_s) --i;
  interpolateReference(floating_base_, at(i), at(i + 1), t_s, out);
  return true;
}

}  // namespace dynfilter
