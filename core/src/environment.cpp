#include "dynfilter/core/environment.hpp"

#include <cmath>
#include <stdexcept>

namespace dynfilter {

GroundPlane GroundPlane::sloped(double slope_rad, double heading_rad, double height_m,
                                double friction) {
  GroundPlane g;
  const double s = std::sin(slope_rad);
  g.n_W = Eigen::Vector3d(s * std::cos(heading_rad), s * std::sin(heading_rad),
                          std::cos(slope_rad));
  g.offset_m = g.n_W.z() * height_m;
  g.friction = friction;
  return g;
}

void Environment::validate() const {
  if (has_ground) {
    if (!ground.n_W.allFinite() || std::abs(ground.n_W.norm() - 1.0) > 1e-9)
      throw std::invalid_argument("environment: ground normal must be a finite unit vector");
    if (!std::isfinite(ground.offset_m))
      throw std::invalid_argument("environment: ground offset is not finite");
    if (!(ground.friction >= 0.0))
      throw std::invalid_argument("environment: ground friction must be >= 0");
  }
  for (std::size_t i = 0; i < boxes.size(); ++i) {
    const EnvironmentBox& box = boxes[i];
    const std::string label = "environment: box " + std::to_string(i) + " \"" + box.name + "\": ";
    if (!box.size_m.allFinite() || (box.size_m.array() <= 0.0).any())
      throw std::invalid_argument(label + "size must be finite and positive");
    if (!box.X_WO.matrix().allFinite())
      throw std::invalid_argument(label + "pose is not finite");
    if (!(box.friction >= 0.0)) throw std::invalid_argument(label + "friction must be >= 0");
  }
}

}  // namespace dynfilter
