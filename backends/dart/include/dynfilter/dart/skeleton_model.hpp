#pragma once
/// @file
/// IDynamicsModel over a dart::dynamics::Skeleton that lives in a dart::simulation::World:
/// the user's own (attachDartModel), or the one the DART backend builds from a URDF
/// (makeDartModel is this model over a skeleton and world it builds itself).
///
/// Coordinates (model_info.hpp, ball_joint.hpp):
/// - the root joint decides the base: a FreeJoint makes a floating base (q = [p_WB; quat
///   (w, x, y, z); joints], v = [v_B; ω_B in B; joint rates]); a WeldJoint a fixed base;
/// - joints are the skeleton's other DoFs in DART's DoF order, named by DART's DoF names:
///   RevoluteJoint and PrismaticJoint one coordinate each, BallJoint three (the rotation
///   vector of the joint, DART's own BallJoint positions, with v = θ̇, not DART's angular
///   velocity: see ball_joint.hpp), WeldJoint none. Any other joint type is refused.
/// - bodies are the skeleton's BodyNodes in index order, named by BodyNode names; a body
///   frame is the BodyNode frame.
/// - limits from DART's DoF position, velocity and force limits (±inf where DART has none).
///
/// State: setState() writes the skeleton's positions and velocities (and accelerations,
/// kept at the values that make DART's classical accelerations the drift J̇·v); queries
/// answer for that state. readSkeletonState() reads what the world integrated without
/// touching anything; pullSkeletonState() makes it the model's state. On a user's
/// skeleton, whoever steps the world owns the state: AttachedFilter saves it before a
/// filter tick and restores it after.
///
/// A and b are the rigid-body dynamics of the skeleton: joint springs, damping, Coulomb
/// friction and external forces the user set on it are not part of them (they are the
/// world's business when it steps; forwardDynamics, DART's own, does include springs,
/// damping and external forces).

#include <memory>

#include <dart/dynamics/Skeleton.hpp>
#include <dart/simulation/World.hpp>

#include "dynfilter/core/dynamics_model.hpp"

namespace dynfilter::dart_backend {

/// How the DART backend computes the mass matrix A.
enum class DartMassMatrix {
  /// Σ_k J_kᵀ M_k J_k over bodies from DART's cached body Jacobians and spatial inertias:
  /// no heap allocation, about 10× faster on a humanoid. The default.
  kBodySum,
  /// DART's own Skeleton::getMassMatrix (allocates; for cross-checks of DART itself).
  kSkeleton,
};

/// Options of attachDartModel.
struct AttachOptions {
  /// Coulomb μ the filter's QP mode assumes for every contact (the world's own contact
  /// model uses DART's shape friction when it steps).
  double friction = 0.8;
  DartMassMatrix mass_matrix = DartMassMatrix::kBodySum;
};

class SkeletonModel : public IDynamicsModel {
 public:
  /// (q, v) ← the skeleton's current positions and velocities (e.g. after world->step()).
  /// Returns false, keeping the previous (q, v), when they are not finite. No allocation.
  virtual bool pullSkeletonState() = 0;
  /// The skeleton's current state in the model's coordinates, leaving the skeleton and
  /// the model's (q, v) as they are (what a controller reads between world steps).
  /// @p q dim nq, @p v dim nv; returns false on a size mismatch or a non-finite state.
  /// No allocation.
  virtual bool readSkeletonState(Eigen::Ref<Eigen::VectorXd> q,
                                 Eigen::Ref<Eigen::VectorXd> v) const = 0;
  /// Sets the skeleton's joint forces (Skeleton::setForces) to @p tau_J (dim nj, in the
  /// model's coordinates; a ball joint's three become the joint torque J_r⁻ᵀ τ); the base
  /// DoFs get zero. No allocation; throws InvalidStateError on a size mismatch.
  virtual void setSkeletonForces(const Eigen::Ref<const Eigen::VectorXd>& tau_J) const = 0;
  virtual const dart::dynamics::SkeletonPtr& skeleton() const = 0;
  virtual const dart::simulation::WorldPtr& world() const = 0;
};

/// The model of the user's @p skeleton, which must be in @p world. Contacts
/// (detectContacts) are the skeleton's collision shapes against every other skeleton's
/// in the world, from the world's own collision detector (whichever the world's
/// ConstraintSolver uses); a contact's object index is the other BodyNode's index in a
/// table made here (the world's other BodyNodes in skeleton order), −1 for bodies added
/// later. simulateStep() sets the joint forces and steps the whole world (its time step
/// set to dt). The initial (q, v) is the skeleton's current state.
/// Throws ModelError naming the joint on an unsupported joint type or a FreeJoint that is
/// not the root, and on a skeleton with more than one tree or not in @p world;
/// std::invalid_argument on null pointers or a negative or non-finite friction.
std::unique_ptr<SkeletonModel> attachDartModel(const dart::dynamics::SkeletonPtr& skeleton,
                                               const dart::simulation::WorldPtr& world,
                                               const AttachOptions& options = {});

}  // namespace dynfilter::dart_backend
