#include "dart_skeleton_builder.hpp"

#include <iostream>
#include <limits>

#include <dart/dynamics/BoxShape.hpp>
#include <dart/dynamics/CylinderShape.hpp>
#include <dart/dynamics/FreeJoint.hpp>
#include <dart/dynamics/PrismaticJoint.hpp>
#include <dart/dynamics/RevoluteJoint.hpp>
#include <dart/dynamics/ShapeNode.hpp>
#include <dart/dynamics/SphereShape.hpp>
#include <dart/dynamics/WeldJoint.hpp>
#include <dart/dynamics/Inertia.hpp>
#include <dart/dynamics/MeshShape.hpp>
#include <dart/dynamics/PlaneShape.hpp>

#include <assimp/scene.h>

#include "dynfilter/core/contact.hpp"
#include "dynfilter/urdf/rigid_mass.hpp"

namespace dynfilter::dart_backend {
namespace {

using dart::dynamics::BodyNode;
using dart::dynamics::ShapePtr;

// Friction of the robot's own shapes. DART combines a pair by taking the smaller
// coefficient, so the environment's friction is the one that applies.
constexpr double kRobotShapeFriction = 1e3;
// The ground slab: edge length and thickness (m).
constexpr double kGroundSlabSize_m = 200.0;
constexpr double kGroundSlabThickness_m = 2.0;

template <typename JointT>
typename JointT::Properties jointProperties(const urdf::JointDesc& j) {
  typename JointT::Properties props;
  props.mName = j.name;
  props.mT_ParentBodyToJoint = j.X_PJ;
  props.mT_ChildBodyToJoint = Eigen::Isometry3d::Identity();
  return props;
}

// Position stops only: with limit enforcement on, DART would also clamp joint velocities
// to their limits, which ModelOptions does not promise (and ODE does not do). Velocity
// and effort limits live in ModelInfo; torque clamping is the controller's job.
template <typename JointT>
void setSingleDofLimits(JointT* joint, const urdf::JointDesc& j) {
  const double inf = std::numeric_limits<double>::infinity();
  joint->setPositionLowerLimit(0, j.lower);
  joint->setPositionUpperLimit(0, j.upper);
  joint->setVelocityLowerLimit(0, -inf);
  joint->setVelocityUpperLimit(0, inf);
  joint->setForceLowerLimit(0, -inf);
  joint->setForceUpperLimit(0, inf);
}

// A DART mesh of the hull's faces (fan-triangulated). DART's Bullet collision turns a
// MeshShape into a btGImpactMeshShape: against the ground plane it reports the hull
// vertices below the plane, against boxes the closest point per touching triangle.
ShapePtr makeHullMesh(const urdf::ConvexHull& hull) {
  auto* mesh = new aiMesh();
  mesh->mPrimitiveTypes = aiPrimitiveType_TRIANGLE;
  mesh->mNumVertices = static_cast<unsigned>(hull.vertices_S.size());
  mesh->mVertices = new aiVector3D[mesh->mNumVertices];
  for (unsigned i = 0; i < mesh->mNumVertices; ++i)
    mesh->mVertices[i] = aiVector3D(static_cast<ai_real>(hull.vertices_S[i].x()),
                                    static_cast<ai_real>(hull.vertices_S[i].y()),
                                    static_cast<ai_real>(hull.vertices_S[i].z()));
  unsigned triangles = 0;
  for (const auto& f : hull.faces) triangles += static_cast<unsigned>(f.size() - 2);
  mesh->mNumFaces = triangles;
  mesh->mFaces = new aiFace[triangles];
  unsigned t = 0;
  for (const auto& f : hull.faces) {
    for (std::size_t k = 1; k + 1 < f.size(); ++k, ++t) {
      aiFace& face = mesh->mFaces[t];
      face.mNumIndices = 3;
      face.mIndices = new unsigned[3]{static_cast<unsigned>(f[0]), static_cast<unsigned>(f[k]),
                                      static_cast<unsigned>(f[k + 1])};
    }
  }
  auto* scene = new aiScene();
  scene->mNumMeshes = 1;
  scene->mMeshes = new aiMesh*[1]{mesh};
  scene->mRootNode = new aiNode();
  scene->mRootNode->mNumMeshes = 1;
  scene->mRootNode->mMeshes = new unsigned[1]{0};
  // MeshShape owns the scene (released with aiReleaseImport, which deletes a scene that
  // no importer made).
  return std::make_shared<dart::dynamics::MeshShape>(Eigen::Vector3d::Ones(), scene);
}

ShapePtr makeShape(const urdf::CollisionShapeDesc& s) {
  switch (s.kind) {
    case urdf::ShapeKind::kBox:
      return std::make_shared<dart::dynamics::BoxShape>(s.box_size_m);
    case urdf::ShapeKind::kSphere:
      return std::make_shared<dart::dynamics::SphereShape>(s.radius_m);
    case urdf::ShapeKind::kCylinder:
      return std::make_shared<dart::dynamics::CylinderShape>(s.radius_m, s.length_m);
    case urdf::ShapeKind::kConvexHull:
      return makeHullMesh(s.hull);
  }
  return nullptr;
}

dart::dynamics::ShapeNode* addCollisionShape(BodyNode* body, const ShapePtr& shape,
                                             const Eigen::Isometry3d& X_BS, double friction) {
  auto* node = body->createShapeNodeWith<dart::dynamics::CollisionAspect,
                                         dart::dynamics::DynamicsAspect>(shape);
  node->setRelativeTransform(X_BS);
  node->getDynamicsAspect()->setFrictionCoeff(friction);
  node->getDynamicsAspect()->setRestitutionCoeff(0.0);
  return node;
}

}  // namespace

BuiltRobot buildRobotSkeleton(const urdf::RobotDescription& robot, bool floating_base) {
  BuiltRobot built;
  built.skeleton = dart::dynamics::Skeleton::create(robot.name);
  built.links.assign(robot.links.size(), LinkFrame{});
  std::vector<urdf::RigidMass> lumped(robot.links.size());

  for (const int link_index : robot.linksParentFirst()) {
    const urdf::LinkDesc& link = robot.links[link_index];
    LinkFrame& frame = built.links[link_index];
    if (link.parent_joint >= 0 && !robot.joints[link.parent_joint].moving()) {
      const urdf::JointDesc& j = robot.joints[link.parent_joint];
      const LinkFrame& parent = built.links[j.parent_link];
      frame.node = parent.node;
      frame.X_NL = parent.X_NL * j.X_PJ;
    } else {
      BodyNode::Properties body_props;
      body_props.mName = link.name;
      if (link.parent_joint < 0) {
        if (floating_base) {
          dart::dynamics::FreeJoint::Properties props;
          props.mName = "root_free_joint";
          frame.node = built.skeleton->createJointAndBodyNodePair<dart::dynamics::FreeJoint>(
                           nullptr, props, body_props).second;
        } else {
          dart::dynamics::WeldJoint::Properties props;
          props.mName = "root_weld_joint";
          frame.node = built.skeleton->createJointAndBodyNodePair<dart::dynamics::WeldJoint>(
                           nullptr, props, body_props).second;
        }
      } else {
        const urdf::JointDesc& j = robot.joints[link.parent_joint];
        // The joint sits on the parent link's frame, which may be lumped into its carrier.
        urdf::JointDesc on_carrier = j;
        on_carrier.X_PJ = built.links[j.parent_link].X_NL * j.X_PJ;
        BodyNode* parent = built.links[j.parent_link].node;
        if (j.type == urdf::JointType::kPrismatic) {
          auto props = jointProperties<dart::dynamics::PrismaticJoint>(on_carrier);
          props.mAxis = j.axis_J;
          auto pair = built.skeleton->createJointAndBodyNodePair<dart::dynamics::PrismaticJoint>(
              parent, props, body_props);
          setSingleDofLimits(pair.first, j);
          frame.node = pair.second;
        } else {  // revolute or continuous
          auto props = jointProperties<dart::dynamics::RevoluteJoint>(on_carrier);
          props.mAxis = j.axis_J;
          auto pair = built.skeleton->createJointAndBodyNodePair<dart::dynamics::RevoluteJoint>(
              parent, props, body_props);
          setSingleDofLimits(pair.first, j);
          frame.node = pair.second;
        }
      }
    }
    lumped[frame.node->getIndexInSkeleton()].add(link.inertial, frame.X_NL);
    for (const auto& shape : link.collisions) {
      auto* node = addCollisionShape(frame.node, makeShape(shape), frame.X_NL * shape.X_LS,
                                     kRobotShapeFriction);
      built.link_of_shape[node] = link_index;
    }
  }
  for (std::size_t k = 0; k < built.skeleton->getNumBodyNodes(); ++k) {
    BodyNode* node = built.skeleton->getBodyNode(k);
    // Massless bodies keep the URDF's zero (DART's default would be 1 kg): the
    // articulated inertias of the bodies beyond them keep A positive definite, which
    // validateForDynamics checks joint by joint.
    if (lumped[k].mass_kg > 0.0) {
      node->setInertia(dart::dynamics::Inertia(lumped[k].mass_kg, lumped[k].p_FCom(), lumped[k].I_Com_F()));
    } else {
      // DART warns on std::cerr about every zero mass; this one is intended.
      std::streambuf* previous = std::cerr.rdbuf(nullptr);
      node->setInertia(dart::dynamics::Inertia(0.0, Eigen::Vector3d::Zero(), Eigen::Matrix3d::Zero()));
      std::cerr.rdbuf(previous);
    }
  }

  const int nj = static_cast<int>(robot.moving_joints.size());
  const int base = floating_base ? 6 : 0;
  built.dof_of_v.assign(base + nj, -1);
  if (floating_base) {
    // Our base velocity is [v_B; ω_B]; DART's FreeJoint uses [ω_B; v_B], both in B.
    for (int i = 0; i < 3; ++i) {
      built.dof_of_v[i] = 3 + i;
      built.dof_of_v[3 + i] = i;
    }
  }
  for (int c = 0; c < nj; ++c) {
    const urdf::JointDesc& j = robot.joints[robot.moving_joints[c]];
    built.dof_of_v[base + c] = static_cast<int>(
        built.links[j.child_link].node->getParentJoint()->getIndexInSkeleton(0));
  }
  const std::size_t ndofs = built.skeleton->getNumDofs();
  built.v_of_dof.assign(ndofs, -1);
  built.factor_of_dof.assign(ndofs, 1.0);
  built.offset_of_dof.assign(ndofs, 0.0);
  for (std::size_t i = 0; i < built.dof_of_v.size(); ++i)
    built.v_of_dof[static_cast<std::size_t>(built.dof_of_v[i])] = static_cast<int>(i);
  for (const int f : robot.mimic_joints) {
    const urdf::JointDesc& j = robot.joints[static_cast<std::size_t>(f)];
    const urdf::JointDesc& leader = robot.joints[static_cast<std::size_t>(j.mimic_leader)];
    dart::dynamics::Joint* joint = built.links[j.child_link].node->getParentJoint();
    const std::size_t dof = joint->getIndexInSkeleton(0);
    built.v_of_dof[dof] = base + leader.coordinate;
    built.factor_of_dof[dof] = j.mimic_multiplier;
    built.offset_of_dof[dof] = j.mimic_offset;
    // DART's own simulator (World::step) holds the follower with a mimic motor
    // constraint; the analytic queries use factor_of_dof instead.
    joint->setActuatorType(dart::dynamics::Joint::MIMIC);
    joint->setMimicJoint(built.links[leader.child_link].node->getParentJoint(),
                         j.mimic_multiplier, j.mimic_offset);
    built.has_mimic = true;
  }
  return built;
}

BuiltEnvironment buildEnvironmentSkeleton(const Environment& environment) {
  BuiltEnvironment built;
  built.skeleton = dart::dynamics::Skeleton::create("environment");
  built.skeleton->setMobile(false);
  auto addStaticBody = [&](const std::string& name, const Eigen::Isometry3d& X_WO, int object) {
    dart::dynamics::WeldJoint::Properties props;
    props.mName = name + "_weld";
    props.mT_ParentBodyToJoint = X_WO;
    BodyNode::Properties body_props;
    body_props.mName = name;
    BodyNode* body = built.skeleton->createJointAndBodyNodePair<dart::dynamics::WeldJoint>(
                         nullptr, props, body_props).second;
    built.object_of_body.push_back(object);
    return body;
  };
  if (environment.has_ground) {
    // Bullet's plane-vs-convex test reports one point per pair, which cannot hold a flat
    // sole; box-vs-box reports the full contact polygon (up to 4 points). So the ground
    // is a slab whose top face is the plane, far larger than any scene.
    const GroundPlane& g = environment.ground;
    Eigen::Isometry3d X_WG = Eigen::Isometry3d::Identity();
    X_WG.linear() = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), g.n_W)
                        .toRotationMatrix();
    X_WG.translation() = g.n_W * (g.offset_m - 0.5 * kGroundSlabThickness_m);
    BodyNode* ground = addStaticBody("ground", X_WG, kGroundObject);
    dart::dynamics::ShapeNode* slab = addCollisionShape(
        ground,
        std::make_shared<dart::dynamics::BoxShape>(
            Eigen::Vector3d(kGroundSlabSize_m, kGroundSlabSize_m, kGroundSlabThickness_m)),
        Eigen::Isometry3d::Identity(), g.friction);
    slab->setName(kGroundSlabShapeName);
    built.ground_slab = slab;
    Eigen::Isometry3d X_GP = Eigen::Isometry3d::Identity();
    X_GP.translation().z() = 0.5 * kGroundSlabThickness_m;  // the slab's top face
    built.ground_plane = addCollisionShape(
        ground, std::make_shared<dart::dynamics::PlaneShape>(Eigen::Vector3d::UnitZ(), 0.0), X_GP,
        g.friction);
  }
  for (std::size_t i = 0; i < environment.boxes.size(); ++i) {
    const EnvironmentBox& box = environment.boxes[i];
    BodyNode* body = addStaticBody("box_" + std::to_string(i), box.X_WO, static_cast<int>(i));
    addCollisionShape(body, std::make_shared<dart::dynamics::BoxShape>(box.size_m),
                      Eigen::Isometry3d::Identity(), box.friction);
  }
  return built;
}

}  // namespace dynfilter::dart_backend
