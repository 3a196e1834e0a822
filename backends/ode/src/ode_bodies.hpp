#pragma once
// Internal: the ODE bodies and joints an OdeBodyModel computes with, and their collision
// geoms — built from a URDF (ode_model.cpp) or read off a user's world (ode_attach.cpp).

#include <memory>
#include <vector>

#include <Eigen/Core>
#include <ode/ode.h>

#include "dynfilter/core/environment.hpp"
#include "dynfilter/core/ground_contacts.hpp"
#include "dynfilter/core/model_info.hpp"
#include "dynfilter/ode/body_model.hpp"
#include "ode_world.hpp"

namespace dynfilter::ode_backend {

/// An ODE 3-vector (dVector3, or the first three of any dReal array) as Eigen's.
inline Eigen::Vector3d toEigen(const dReal* v) { return Eigen::Vector3d(v[0], v[1], v[2]); }

/// What a geom is to the model.
struct GeomRole {
  bool robot = false;
  int link = -1;               ///< robot geoms: body index
  int object = kGroundObject;  ///< other geoms: environment object index
  double friction = 0.0;       ///< other geoms: Coulomb μ
};

class OdeBodies {
 public:
  virtual ~OdeBodies() = default;
  virtual dWorldID world() const = 0;
  virtual dJointGroupID contactGroup() const = 0;
  /// Parent-first, the root (base) first.
  virtual const std::vector<OdeNode>& nodes() const = 0;
  /// By body index.
  virtual const std::vector<OdeLinkFrame>& links() const = 0;
  /// Most coordinates on one root-to-node path (scratch sizes).
  virtual int maxPathCoordinates() const = 0;
  /// Calls @p callback(data, g1, g2) for every pair of geoms that may touch and of which
  /// at least one is the robot's.
  virtual void collide(void* data, dNearCallback* callback) const = 0;
  /// Returns false for a geom the model does not know.
  virtual bool role(dGeomID geom, GeomRole& out) const = 0;
  /// The convex hulls and cylinders whose contacts with the ground plane the model
  /// computes itself (core/ground_contacts.hpp) instead of ODE's colliders. Default: none (a
  /// user's world keeps ODE's contacts).
  virtual const GroundContactShapes& groundShapes() const {
    static const GroundContactShapes none;
    return none;
  }
};

/// The model over @p bodies; (q, v) start as the bodies' current state when
/// @p pull_initial_state, else at the neutral configuration.
std::unique_ptr<OdeBodyModel> makeOdeBodyModel(std::unique_ptr<OdeBodies> bodies, ModelInfo info,
                                               Environment environment,
                                               const Eigen::Vector3d& gravity_W,
                                               bool pull_initial_state);

}  // namespace dynfilter::ode_backend
