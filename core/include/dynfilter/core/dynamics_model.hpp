#pragma once
/// @file
/// IDynamicsModel: the seam between the backend-agnostic core and a physics engine.
///
/// One object per robot model and backend. It holds the current state (q, v) and answers
/// dynamics queries about it. Coordinates and units: see model_info.hpp. Spatial vectors
/// and Jacobian rows are [linear; angular]; point Jacobians are world-aligned at the point
/// (rows give the point's world velocity and the body's world angular velocity).
///
/// Threading: an object is used from one thread at a time. Queries are const but may
/// update backend caches.
///
/// Errors: configuration problems throw (ModelError, InvalidStateError); the per-tick
/// queries below do not allocate on the heap and do not throw for valid body indices.

#include <string_view>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "dynfilter/core/contact.hpp"
#include "dynfilter/core/environment.hpp"
#include "dynfilter/core/model_info.hpp"
#include "dynfilter/core/types.hpp"

namespace dynfilter {

/// Above this speed (m/s or rad/s, any coordinate of v) a simulated state counts as
/// diverged: IDynamicsModel::simulateStep refuses to step from it.
constexpr double kMaxSimulatedSpeed = 1e3;

class IDynamicsModel {
 public:
  virtual ~IDynamicsModel() = default;
  IDynamicsModel() = default;
  IDynamicsModel(const IDynamicsModel&) = delete;
  IDynamicsModel& operator=(const IDynamicsModel&) = delete;

  /// Names, sizes and limits. Valid for the object's lifetime.
  virtual const ModelInfo& info() const = 0;
  /// "dart", "ode", ...
  virtual std::string_view backendName() const = 0;
  /// The environment this model collides with.
  virtual const Environment& environment() const = 0;

  int nq() const { return info().nq; }
  int nv() const { return info().nv; }
  int nj() const { return info().nj; }

  // ---- state ---------------------------------------------------------------------------
  /// Sets the state. Throws InvalidStateError (naming the entry) on a size mismatch, a
  /// non-finite entry or a base quaternion with |‖quat‖ − 1| > kUnitQuaternionTolerance;
  /// the previous state is then kept. An accepted quaternion is normalised.
  virtual void setState(const Eigen::Ref<const Eigen::VectorXd>& q,
                        const Eigen::Ref<const Eigen::VectorXd>& v) = 0;
  virtual const Eigen::VectorXd& q() const = 0;  ///< dim nq
  virtual const Eigen::VectorXd& v() const = 0;  ///< dim nv

  // ---- kinematics ----------------------------------------------------------------------
  /// Pose of body @p body: X_WB (body frame = URDF link frame).
  virtual Eigen::Isometry3d bodyPose(int body) const = 0;
  /// Spatial velocity of body @p body at its origin, world-aligned, [linear; angular].
  virtual Vector6d bodyVelocity(int body) const = 0;
  /// World position of the point @p p_BP fixed on body @p body.
  Eigen::Vector3d pointPosition(int body, const Eigen::Vector3d& p_BP) const {
    return bodyPose(body) * p_BP;
  }
  /// World velocity (m/s) of the point of body @p body that is at @p p_WP (world) now.
  Eigen::Vector3d pointVelocity(int body, const Eigen::Vector3d& p_WP) const {
    const Vector6d V_WB = bodyVelocity(body);
    return V_WB.head<3>() + V_WB.tail<3>().cross(p_WP - bodyPose(body).translation());
  }
  /// Jacobian of the point P fixed on @p body: rows [ṗ_WP; ω_WB] = J · v.
  /// @param J_out 6 × nv
  virtual void pointJacobian(int body, const Eigen::Vector3d& p_BP,
                             Eigen::Ref<Matrix6Xd> J_out) const = 0;
  /// The drift J̇·v of pointJacobian: the point's classical acceleration [p̈_WP; ω̇_WB]
  /// when v̇ = 0, so that [p̈; ω̇] = J v̇ + J̇ v.
  virtual Vector6d pointJacobianDotTimesV(int body, const Eigen::Vector3d& p_BP) const = 0;

  // ---- dynamics ------------------------------------------------------------------------
  /// Joint-space mass matrix A(q) (Eq. 1), nv × nv, symmetric positive definite.
  virtual void massMatrix(Eigen::Ref<Eigen::MatrixXd> A_out) const = 0;
  /// Bias b(q, v): Coriolis, centrifugal and gravity terms, so that A v̇ + b = τ_G (Eq. 1).
  /// @param b_out dim nv
  virtual void bias(Eigen::Ref<Eigen::VectorXd> b_out) const = 0;
  /// Forward dynamics without contact: v̇ = A⁻¹ (H_Jᵀ τ_J − b), computed by the engine.
  /// @param tau_J dim nj (N m / N); @param vdot_out dim nv
  virtual void forwardDynamics(const Eigen::Ref<const Eigen::VectorXd>& tau_J,
                               Eigen::Ref<Eigen::VectorXd> vdot_out) const = 0;

  // ---- environment ---------------------------------------------------------------------
  /// Contact candidates between the robot's collision shapes and the environment at the
  /// current state, from the backend's collision engine. Clears @p out first.
  virtual void detectContacts(ContactList& out) const = 0;
  /// Advances the state by one step of the engine's own simulator (its own contact and
  /// integration scheme) with joint torques @p tau_J held over @p dt_s seconds. Throws
  /// std::runtime_error, keeping the previous state, if the step diverged (non-finite) or
  /// would start from a diverged state (a speed above kMaxSimulatedSpeed, or non-finite
  /// torques): the engines assert (abort) on NaN inside a step.
  virtual void simulateStep(const Eigen::Ref<const Eigen::VectorXd>& tau_J, double dt_s) = 0;
};

}  // namespace dynfilter
