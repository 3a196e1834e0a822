#include "ode_world.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include <Eigen/Eigenvalues>

#include "dynfilter/core/errors.hpp"
#include "dynfilter/urdf/rigid_mass.hpp"

namespace dynfilter::ode_backend {
namespace {

/// Smallest principal moment (kg m²) an ODE body is given in ODE's own stepper (dMass
/// must be positive definite); the analytic queries take the lift off (OdeNode).
constexpr double kTokenInertia = 1e-9;

}  // namespace

void ensureOdeInitialised() {
  static const bool initialised = [] {
    if (dInitODE2(0) == 0) throw std::runtime_error("ODE: dInitODE2 failed");
    if (dCheckConfiguration("ODE_double_precision") == 0)
      throw std::runtime_error("ODE: the library is not built in double precision (" +
                               std::string(dGetConfiguration()) + ")");
    return true;
  }();
  static_cast<void>(initialised);
  thread_local const bool thread_ready = dAllocateODEDataForThread(dAllocateMaskAll) != 0;
  if (!thread_ready) throw std::runtime_error("ODE: dAllocateODEDataForThread failed");
}

OdeWorld::OdeWorld(const urdf::RobotDescription& robot, bool floating_base,
                   const Eigen::Vector3d& gravity_W, const Environment& environment,
                   bool enforce_joint_limits) {
  // Everything that can throw happens before the first ODE object exists.
  buildNodes(robot, floating_base);
  std::size_t num_geoms = environment.boxes.size() + (environment.has_ground ? 1 : 0);
  for (const auto& link : robot.links) num_geoms += link.collisions.size();
  geom_tags_.reserve(num_geoms);  // dGeomSetData keeps pointers into it

  world_ = dWorldCreate();
  dWorldSetGravity(world_, gravity_W.x(), gravity_W.y(), gravity_W.z());
  // Baumgarte correction of joint and contact drift, and a tiny constraint force mixing
  // (nearly hard constraints; dWorldStep's direct solver does not need regularisation).
  dWorldSetERP(world_, 0.2);
  dWorldSetCFM(world_, 1e-10);
  dWorldSetContactSurfaceLayer(world_, 0.0);
  dWorldSetAutoDisableFlag(world_, 0);
  robot_space_ = dSimpleSpaceCreate(nullptr);
  environment_space_ = dSimpleSpaceCreate(nullptr);
  contact_group_ = dJointGroupCreate(0);

  createBodiesAndJoints(enforce_joint_limits);
  createRobotGeoms(robot);
  createEnvironmentGeoms(environment);
}

OdeWorld::~OdeWorld() {
  dJointGroupDestroy(contact_group_);
  dSpaceDestroy(robot_space_);        // destroys its geoms (cleanup mode is on)
  dSpaceDestroy(environment_space_);
  dWorldDestroy(world_);              // destroys bodies and joints
}

void OdeWorld::buildNodes(const urdf::RobotDescription& robot, bool floating_base) {
  links_.assign(robot.links.size(), OdeLinkFrame{});
  node_of_coordinate_.assign(robot.moving_joints.size(), -1);

  std::vector<int> depth;
  for (const int link_index : robot.linksParentFirst()) {
    const urdf::LinkDesc& link = robot.links[static_cast<std::size_t>(link_index)];
    OdeLinkFrame& frame = links_[static_cast<std::size_t>(link_index)];
    const urdf::JointDesc* joint =
        link.parent_joint >= 0 ? &robot.joints[static_cast<std::size_t>(link.parent_joint)]
                               : nullptr;
    if (joint != nullptr && !joint->moving()) {
      // Welded: a frame on the parent's node.
      const OdeLinkFrame& parent = links_[static_cast<std::size_t>(joint->parent_link)];
      frame.node = parent.node;
      frame.X_NL = parent.X_NL * joint->X_PJ;
      continue;
    }
    OdeNode node;
    node.link = link_index;
    if (joint != nullptr) {
      const OdeLinkFrame& parent = links_[static_cast<std::size_t>(joint->parent_link)];
      node.parent = parent.node;
      node.X_PJ = parent.X_NL * joint->X_PJ;  // the joint sits on the parent link's frame
      node.axis_J = joint->axis_J.normalized();
      node.prismatic = joint->type == urdf::JointType::kPrismatic;
      node.lower = joint->lower;
      node.upper = joint->upper;
      if (joint->mimics()) {
        node.follower = true;
        node.coordinate = robot.joints[static_cast<std::size_t>(joint->mimic_leader)].coordinate;
        node.factor = joint->mimic_multiplier;
        node.offset = joint->mimic_offset;
      } else {
        node.coordinate = joint->coordinate;
        node_of_coordinate_[static_cast<std::size_t>(node.coordinate)] =
            static_cast<int>(nodes_.size());
      }
    }
    frame.node = static_cast<int>(nodes_.size());
    frame.X_NL = Eigen::Isometry3d::Identity();
    depth.push_back(node.parent < 0 ? 1 : depth[static_cast<std::size_t>(node.parent)] + 1);
    nodes_.push_back(node);
  }

  // Lumped mass properties per node.
  std::vector<urdf::RigidMass> lumped(nodes_.size());
  for (std::size_t l = 0; l < robot.links.size(); ++l)
    lumped[static_cast<std::size_t>(links_[l].node)].add(robot.links[l].inertial, links_[l].X_NL);
  for (std::size_t n = 0; n < nodes_.size(); ++n) {
    OdeNode& node = nodes_[n];
    node.mass_kg = lumped[n].mass_kg;
    node.p_NCom = lumped[n].p_FCom();
    node.I_Com_N = lumped[n].I_Com_F();
  }
  for (std::size_t l = 0; l < links_.size(); ++l) {
    const OdeNode& node = nodes_[static_cast<std::size_t>(links_[l].node)];
    links_[l].X_BL = Eigen::Translation3d(-node.p_NCom) * links_[l].X_NL;
  }
  for (const int d : depth) max_depth_ = std::max(max_depth_, d);
  // A fixed-base root is the world: it gets no ODE body (see createBodiesAndJoints).
  fixed_root_ = !floating_base;
}

void OdeWorld::createBodiesAndJoints(bool enforce_joint_limits) {
  // Bodies at q = 0 with the base at the origin: ODE measures hinge angles and slider
  // positions from the pose at joint creation, so zero there is zero here.
  std::vector<Eigen::Isometry3d> X_WN(nodes_.size(), Eigen::Isometry3d::Identity());
  for (std::size_t n = 0; n < nodes_.size(); ++n) {
    OdeNode& node = nodes_[n];
    if (node.parent >= 0) X_WN[n] = X_WN[static_cast<std::size_t>(node.parent)] * node.X_PJ;
    if (node.parent < 0 && fixed_root_) continue;
    node.body = dBodyCreate(world_);
    dMass mass;
    dMassSetZero(&mass);
    // ODE needs mass on every body: a massless node gets a token 1 g with a 1e-6 kg m²
    // inertia in ODE's own stepper only (the analytic queries skip massless nodes).
    // A body whose inertia is singular there (a point mass: validateForDynamics accepts
    // positive semi-definite inertias) has its principal moments lifted to kTokenInertia.
    const bool massless = !(node.mass_kg > 0.0);
    const double m = massless ? 1e-3 : node.mass_kg;
    Eigen::Matrix3d I = massless ? Eigen::Matrix3d(1e-6 * Eigen::Matrix3d::Identity()) : node.I_Com_N;
    const double smallest = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(I).eigenvalues()[0];
    node.inertia_lift = massless ? 0.0 : std::max(0.0, kTokenInertia - smallest);
    I.diagonal().array() += node.inertia_lift;
    dMassSetParameters(&mass, m, 0.0, 0.0, 0.0, I(0, 0), I(1, 1), I(2, 2), I(0, 1),
                       I(0, 2), I(1, 2));
    dBodySetMass(node.body, &mass);
    const Eigen::Vector3d p = X_WN[n] * node.p_NCom;
    dMatrix3 R;
    toOdeRotation(X_WN[n].linear(), R);
    dBodySetPosition(node.body, p.x(), p.y(), p.z());
    dBodySetRotation(node.body, R);
  }
  for (std::size_t n = 0; n < nodes_.size(); ++n) {
    OdeNode& node = nodes_[n];
    if (node.parent < 0) continue;
    const Eigen::Isometry3d X_WJ = X_WN[static_cast<std::size_t>(node.parent)] * node.X_PJ;
    const Eigen::Vector3d a = X_WJ.linear() * node.axis_J;
    const Eigen::Vector3d o = X_WJ.translation();
    dBodyID parent_body = nodes_[static_cast<std::size_t>(node.parent)].body;  // null: world
    // Body 1 is the child: ODE's hinge angle, hinge torque and slider force then act on
    // the child along +axis, as the joint coordinate does.
    if (node.prismatic) {
      node.joint = dJointCreateSlider(world_, nullptr);
      dJointAttach(node.joint, node.body, parent_body);
      dJointSetSliderAxis(node.joint, a.x(), a.y(), a.z());
    } else {
      node.joint = dJointCreateHinge(world_, nullptr);
      dJointAttach(node.joint, node.body, parent_body);
      dJointSetHingeAnchor(node.joint, o.x(), o.y(), o.z());
      dJointSetHingeAxis(node.joint, a.x(), a.y(), a.z());
    }
    if (enforce_joint_limits) setJointLimits(node);
    if (node.follower) {
      // The coupling in ODE's stepper: a motor on the follower's axis whose target
      // velocity is set every step (OdeModel::simulateStep).
      if (node.prismatic) {
        node.mimic_motor = dJointCreateLMotor(world_, nullptr);
        dJointAttach(node.mimic_motor, node.body, parent_body);
        dJointSetLMotorNumAxes(node.mimic_motor, 1);
        dJointSetLMotorAxis(node.mimic_motor, 0, parent_body ? 2 : 0, a.x(), a.y(), a.z());
        dJointSetLMotorParam(node.mimic_motor, dParamFMax, dInfinity);
      } else {
        node.mimic_motor = dJointCreateAMotor(world_, nullptr);
        dJointAttach(node.mimic_motor, node.body, parent_body);
        dJointSetAMotorNumAxes(node.mimic_motor, 1);
        dJointSetAMotorAxis(node.mimic_motor, 0, parent_body ? 2 : 0, a.x(), a.y(), a.z());
        dJointSetAMotorParam(node.mimic_motor, dParamFMax, dInfinity);
      }
    }
  }
}

void OdeWorld::setJointLimits(const OdeNode& node) {
  const double lower = node.lower;
  const double upper = node.upper;
  if (node.prismatic) {
    if (std::isfinite(lower)) dJointSetSliderParam(node.joint, dParamLoStop, lower);
    if (std::isfinite(upper)) dJointSetSliderParam(node.joint, dParamHiStop, upper);
    return;
  }
  // ODE measures hinge angles in (−π, π]: a stop at or beyond ±π cannot be expressed and
  // is left open.
  if (lower > -M_PI) dJointSetHingeParam(node.joint, dParamLoStop, lower);
  if (upper < M_PI) dJointSetHingeParam(node.joint, dParamHiStop, upper);
}

void OdeWorld::createRobotGeoms(const urdf::RobotDescription& robot) {
  for (std::size_t l = 0; l < robot.links.size(); ++l) {
    const OdeLinkFrame& frame = links_[l];
    const OdeNode& node = nodes_[static_cast<std::size_t>(frame.node)];
    for (const auto& shape : robot.links[l].collisions) {
      dGeomID geom = nullptr;
      Eigen::Vector3d p_SO = Eigen::Vector3d::Zero();  // the geom's origin in the shape frame
      switch (shape.kind) {
        case urdf::ShapeKind::kBox:
          geom = dCreateBox(robot_space_, shape.box_size_m.x(), shape.box_size_m.y(),
                            shape.box_size_m.z());
          break;
        case urdf::ShapeKind::kSphere:
          geom = dCreateSphere(robot_space_, shape.radius_m);
          break;
        case urdf::ShapeKind::kCylinder:  // both along the shape's z
          geom = dCreateCylinder(robot_space_, shape.radius_m, shape.length_m);
          break;
        case urdf::ShapeKind::kConvexHull:
          geom = createConvexGeom(shape.hull, p_SO);
          break;
      }
      if (geom == nullptr) continue;
      OdeGeomTag tag;
      tag.robot = true;
      tag.link = static_cast<int>(l);
      tag.node = frame.node;
      geom_tags_.push_back(tag);
      dGeomSetData(geom, &geom_tags_.back());
      dMatrix3 R;
      if (node.body != nullptr) {
        const Eigen::Isometry3d X_BS = frame.X_BL * shape.X_LS * Eigen::Translation3d(p_SO);
        toOdeRotation(X_BS.linear(), R);
        dGeomSetBody(geom, node.body);
        dGeomSetOffsetPosition(geom, X_BS.translation().x(), X_BS.translation().y(),
                               X_BS.translation().z());
        dGeomSetOffsetRotation(geom, R);
      } else {
        // On the fixed root, i.e. the world (the root's frame is the world frame).
        const Eigen::Isometry3d X_WS = frame.X_NL * shape.X_LS * Eigen::Translation3d(p_SO);
        toOdeRotation(X_WS.linear(), R);
        dGeomSetPosition(geom, X_WS.translation().x(), X_WS.translation().y(),
                         X_WS.translation().z());
        dGeomSetRotation(geom, R);
      }
    }
  }
}

dGeomID OdeWorld::createConvexGeom(const urdf::ConvexHull& hull, Eigen::Vector3d& p_SO) {
  // ODE's convex colliders take the geom's origin to be inside the hull: give it the
  // vertices and planes about their centroid O, and the caller places the geom at O.
  p_SO.setZero();
  for (const Eigen::Vector3d& v : hull.vertices_S) p_SO += v;
  p_SO /= static_cast<double>(hull.vertices_S.size());
  auto data = std::make_unique<ConvexData>();
  for (const Eigen::Vector4d& p : hull.planes_S) {
    const Eigen::Vector4d about_o(p.x(), p.y(), p.z(), p.w() - p.head<3>().dot(p_SO));
    data->planes.insert(data->planes.end(), about_o.data(), about_o.data() + 4);
  }
  for (const Eigen::Vector3d& v : hull.vertices_S) {
    const Eigen::Vector3d about_o = v - p_SO;
    data->points.insert(data->points.end(), about_o.data(), about_o.data() + 3);
  }
  for (const auto& face : hull.faces) {
    // ODE checks a face's winding on its first three vertices (their triple product about
    // O): start the loop where they span the most volume, not on a nearly straight run.
    const std::size_t m = face.size();
    std::size_t start = 0;
    double widest = -1.0;
    for (std::size_t k = 0; k < m; ++k) {
      const auto at = [&](std::size_t j) { return hull.vertices_S[static_cast<std::size_t>(face[(k + j) % m])] - p_SO; };
      const double volume = at(0).dot(at(1).cross(at(2)));
      if (volume > widest) {
        widest = volume;
        start = k;
      }
    }
    data->polygons.push_back(static_cast<unsigned int>(m));
    for (std::size_t j = 0; j < m; ++j)
      data->polygons.push_back(static_cast<unsigned int>(face[(start + j) % m]));
  }
  dGeomID geom = dCreateConvex(robot_space_, data->planes.data(),
                               static_cast<unsigned int>(hull.planes_S.size()), data->points.data(),
                               static_cast<unsigned int>(hull.vertices_S.size()),
                               data->polygons.data());
  convex_data_.push_back(std::move(data));
  return geom;
}

void OdeWorld::createEnvironmentGeoms(const Environment& environment) {
  if (environment.has_ground) {
    // ODE's plane is { p : n · p = d } with the solid below, exactly the GroundPlane.
    const GroundPlane& g = environment.ground;
    dGeomID plane = dCreatePlane(environment_space_, g.n_W.x(), g.n_W.y(), g.n_W.z(), g.offset_m);
    OdeGeomTag tag;
    tag.object = kGroundObject;
    tag.friction = g.friction;
    geom_tags_.push_back(tag);
    dGeomSetData(plane, &geom_tags_.back());
  }
  for (std::size_t i = 0; i < environment.boxes.size(); ++i) {
    const EnvironmentBox& box = environment.boxes[i];
    dGeomID geom = dCreateBox(environment_space_, box.size_m.x(), box.size_m.y(), box.size_m.z());
    dMatrix3 R;
    toOdeRotation(box.X_WO.linear(), R);
    dGeomSetPosition(geom, box.X_WO.translation().x(), box.X_WO.translation().y(),
                     box.X_WO.translation().z());
    dGeomSetRotation(geom, R);
    OdeGeomTag tag;
    tag.object = static_cast<int>(i);
    tag.friction = box.friction;
    geom_tags_.push_back(tag);
    dGeomSetData(geom, &geom_tags_.back());
  }
}

}  // namespace dynfilter::ode_backend
