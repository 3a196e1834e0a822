#pragma once
/// @file
/// States for checks and tools: random valid states, and where a model stands.

#include <random>
#include <vector>

#include <Eigen/Core>

#include "dynfilter/core/contact.hpp"
#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/core/model_info.hpp"

namespace dynfilter {

/// A random valid state: base within 1 m of (0, 0, 1) with a uniformly random orientation
/// (floating base), joints uniform within their limits (continuous joints in [−π, π]),
/// velocities uniform in [−velocity_scale, velocity_scale]. Resizes @p q (nq), @p v (nv).
void randomState(const ModelInfo& info, std::mt19937& rng, double velocity_scale,
                 Eigen::VectorXd& q, Eigen::VectorXd& v);

/// The base height (world z, m) at which @p model, in configuration @p q with its base at
/// that height, first touches the environment according to its own collision engine
/// (bisection to 1e-9 m over [0, 3] m; when no height there touches — a base origin below
/// the feet — a downward scan in 5 cm steps to −3 m, then bisection within the step).
/// Changes the model's state. Floating base only.
double standingBaseHeight(IDynamicsModel& model, Eigen::VectorXd q);

/// standingBaseHeight against the ground plane alone (boxes of the environment ignored),
/// searched from the ground's height under the base (x, y of @p q) up. Requires a ground.
double standingBaseHeightOnGround(IDynamicsModel& model, Eigen::VectorXd q);

/// The collision points of @p model standing in configuration @p q on its environment: the
/// base at standingBaseHeight less 0.1 mm, so that the collision engine reports every point
/// that touches (the soles). Fills @p contacts (at most its capacity), leaves the model in
/// that state with zero velocity and returns the standing base height (m). Floating base only.
double standingContacts(IDynamicsModel& model, Eigen::VectorXd q, ContactList& contacts);

/// A body a model stands on: its collision points (body frame, m) and their centroid.
struct StandingSole {
  int body = -1;
  std::vector<Eigen::Vector3d> points_B;
  Eigen::Vector3d centre_B = Eigen::Vector3d::Zero();
};

/// @p contacts (e.g. of standingContacts) grouped by body, in ascending body order.
std::vector<StandingSole> standingSoles(const ContactList& contacts);

}  // namespace dynfilter
