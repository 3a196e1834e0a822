#include "dynfilter/core/contact.hpp"

#include <cmath>

#include <Eigen/Geometry>

namespace dynfilter {

Eigen::Vector3d contactTangent(const Eigen::Vector3d& n_W, const Eigen::Vector3d& hint_W) {
  Eigen::Vector3d t = hint_W - n_W * n_W.dot(hint_W);
  if (t.norm() < 1e-6) {
    const Eigen::Vector3d other =
        std::abs(n_W.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    t = other - n_W * n_W.dot(other);
  }
  return t.normalized();
}

}  // namespace dynfilter
