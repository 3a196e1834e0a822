#pragma once
/// @file
/// The static environment a model touches: a ground plane of any slope and boxes.
/// Backends build their collision geometry from this description.

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace dynfilter {

/// The half-space { p : n_W · p ≤ offset_m } is solid; its surface is the ground.
struct GroundPlane {
  Eigen::Vector3d n_W = Eigen::Vector3d::UnitZ();  ///< unit outward normal (world)
  double offset_m = 0.0;                           ///< n_W · p on the surface (m)
  double friction = 0.8;                           ///< Coulomb coefficient μ

  /// A plane through p_W = (0, 0, height_m) that descends by @p slope_rad along the
  /// horizontal direction at @p heading_rad from +x (about +z). slope 0 is level ground.
  static GroundPlane sloped(double slope_rad, double heading_rad = 0.0, double height_m = 0.0,
                            double friction = 0.8);
  /// Signed height of @p p_W above the surface along the normal (m).
  double signedDistance(const Eigen::Vector3d& p_W) const { return n_W.dot(p_W) - offset_m; }
  /// World z of the surface above (@p x, @p y) (m). Not for a vertical plane (n_W.z() = 0).
  double heightAt(double x, double y) const { return (offset_m - n_W.x() * x - n_W.y() * y) / n_W.z(); }
};

/// A static box obstacle (a step, a table, a platform).
struct EnvironmentBox {
  std::string name;
  Eigen::Vector3d size_m = Eigen::Vector3d::Ones();     ///< full edge lengths (m)
  Eigen::Isometry3d X_WO = Eigen::Isometry3d::Identity();  ///< box centre pose in world
  double friction = 0.8;
};

struct Environment {
  bool has_ground = true;
  GroundPlane ground;
  std::vector<EnvironmentBox> boxes;

  /// Coulomb μ of a contact object: box @p object, else (the ground, kGroundObject) the ground's.
  double friction(int object) const {
    return object >= 0 && object < static_cast<int>(boxes.size()) ? boxes[static_cast<std::size_t>(object)].friction
                                                                   : ground.friction;
  }

  /// Throws std::invalid_argument naming the entry on a non-unit or non-finite normal,
  /// a negative friction or a non-positive box size.
  void validate() const;
};

}  // namespace dynfilter
