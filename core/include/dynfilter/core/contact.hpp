#pragma once
/// @file
/// Contact candidates reported by a backend's collision engine.

#include <cstddef>
#include <vector>

#include <Eigen/Core>

namespace dynfilter {

/// Index of the environment object a contact touches.
constexpr int kGroundObject = -1;

/// One point where a robot body touches (or penetrates) the environment.
struct ContactCandidate {
  int body = -1;                     ///< robot body index (ModelInfo::body_names)
  int object = kGroundObject;        ///< kGroundObject, or the index of an EnvironmentBox
  Eigen::Vector3d p_BC = Eigen::Vector3d::Zero();  ///< contact point on the body, body frame (m)
  Eigen::Vector3d p_WC = Eigen::Vector3d::Zero();  ///< the same point in world (m)
  Eigen::Vector3d n_W = Eigen::Vector3d::UnitZ();  ///< unit normal pushing the body out of the environment
  double depth_m = 0.0;              ///< penetration depth (m, ≥ 0)
};

/// A unit vector orthogonal to the unit vector @p n_W, preferring the projection of
/// @p hint_W onto the plane of @p n_W (x or y when @p hint_W is nearly parallel to it).
/// The tangent of every contact frame the core builds.
Eigen::Vector3d contactTangent(const Eigen::Vector3d& n_W, const Eigen::Vector3d& hint_W);

/// A contact list of fixed capacity: filling it never allocates. Candidates beyond the
/// capacity are counted in overflow() and dropped.
class ContactList {
 public:
  explicit ContactList(std::size_t capacity = 64) : items_(capacity) {}

  void clear() {
    size_ = 0;
    overflow_ = 0;
  }
  /// Appends @p c; returns false (and counts an overflow) when full.
  bool push(const ContactCandidate& c) {
    if (size_ == items_.size()) {
      ++overflow_;
      return false;
    }
    items_[size_++] = c;
    return true;
  }
  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  std::size_t capacity() const { return items_.size(); }
  std::size_t overflow() const { return overflow_; }
  const ContactCandidate& operator[](std::size_t i) const { return items_[i]; }
  const ContactCandidate* begin() const { return items_.data(); }
  const ContactCandidate* end() const { return items_.data() + size_; }

 private:
  std::vector<ContactCandidate> items_;
  std::size_t size_ = 0;
  std::size_t overflow_ = 0;
};

}  // namespace dynfilter
