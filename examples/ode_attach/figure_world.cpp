#include "figure_world.hpp"

#include <map>
#include <stdexcept>

#include <Eigen/Geometry>
#include <urdf_parser/urdf_parser.h>

namespace {

Eigen::Isometry3d toEigen(const urdf::Pose& p) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = Eigen::Quaterniond(p.rotation.w, p.rotation.x, p.rotation.y, p.rotation.z)
                   .toRotationMatrix();
  X.translation() = Eigen::Vector3d(p.position.x, p.position.y, p.position.z);
  return X;
}

void toOde(const Eigen::Matrix3d& R, dMatrix3 out) {
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) out[4 * i + j] = R(i, j);
    out[4 * i + 3] = 0.0;
  }
}

}  // namespace

FigureWorld::FigureWorld(const std::string& urdf_path) {
  const urdf::ModelInterfaceSharedPtr model = urdf::parseURDFFile(urdf_path);
  if (!model) throw std::runtime_error("cannot parse " + urdf_path);
  dInitODE2(0);
  world = dWorldCreate();
  dWorldSetGravity(world, 0, 0, -9.81);
  dWorldSetERP(world, 0.2);
  dWorldSetCFM(world, 1e-10);
  space = dSimpleSpaceCreate(nullptr);
  contacts_ = dJointGroupCreate(0);
  dCreatePlane(space, 0, 0, 1, 0);  // the ground: z = 0
  robot.name = model->getName();
  robot.world = world;
  robot.space = space;

  // Links parent-first, each posed at the zero configuration.
  std::map<std::string, Eigen::Isometry3d> X_WL;
  std::map<std::string, dBodyID> body_of;
  std::vector<urdf::LinkConstSharedPtr> pending{model->getRoot()};
  X_WL[model->getRoot()->name] = Eigen::Isometry3d::Identity();
  while (!pending.empty()) {
    const urdf::LinkConstSharedPtr link = pending.back();
    pending.pop_back();
    const Eigen::Isometry3d& X = X_WL[link->name];
    if (!link->inertial) throw std::runtime_error("link " + link->name + " has no inertia");
    // The body at the centre of mass with the link's axes (ODE wants the CoM at the origin).
    const Eigen::Isometry3d X_LI = toEigen(link->inertial->origin);
    const auto& in = *link->inertial;
    Eigen::Matrix3d I_I;
    I_I << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
    const Eigen::Matrix3d I_L = X_LI.linear() * I_I * X_LI.linear().transpose();
    dBodyID body = dBodyCreate(world);
    dMass mass;
    dMassSetParameters(&mass, in.mass, 0, 0, 0, I_L(0, 0), I_L(1, 1), I_L(2, 2), I_L(0, 1),
                       I_L(0, 2), I_L(1, 2));
    dBodySetMass(body, &mass);
    const Eigen::Vector3d c = X * X_LI.translation();
    dBodySetPosition(body, c.x(), c.y(), c.z());
    dMatrix3 R;
    toOde(X.linear(), R);
    dBodySetRotation(body, R);
    body_of[link->name] = body;
    Eigen::Isometry3d X_BL = Eigen::Isometry3d::Identity();
    X_BL.translation() = -X_LI.translation();
    robot.bodies.push_back({link->name, body, X_BL});

    for (const auto& collision : link->collision_array) {
      const auto* g = collision->geometry.get();
      dGeomID geom = nullptr;
      if (g->type == urdf::Geometry::BOX) {
        const auto& d = static_cast<const urdf::Box*>(g)->dim;
        geom = dCreateBox(space, d.x, d.y, d.z);
      } else if (g->type == urdf::Geometry::SPHERE) {
        geom = dCreateSphere(space, static_cast<const urdf::Sphere*>(g)->radius);
      } else if (g->type == urdf::Geometry::CYLINDER) {
        const auto* cyl = static_cast<const urdf::Cylinder*>(g);
        geom = dCreateCylinder(space, cyl->radius, cyl->length);
      }
      if (geom == nullptr) continue;  // meshes: not in this example
      const Eigen::Isometry3d X_BS = X_BL * toEigen(collision->origin);
      dGeomSetBody(geom, body);
      dGeomSetOffsetPosition(geom, X_BS.translation().x(), X_BS.translation().y(),
                             X_BS.translation().z());
      toOde(X_BS.linear(), R);
      dGeomSetOffsetRotation(geom, R);
    }

    for (const auto& joint : link->child_joints) {
      const urdf::LinkConstSharedPtr child = model->getLink(joint->child_link_name);
      const Eigen::Isometry3d X_WJ = X * toEigen(joint->parent_to_joint_origin_transform);
      X_WL[child->name] = X_WJ;
      pending.push_back(child);
    }
  }

  // Joints, created with the bodies at the zero pose (ODE's hinge angles start there).
  for (const auto& [name, joint] : model->joints_) {
    const dBodyID child = body_of.at(joint->child_link_name);
    const dBodyID parent = body_of.at(joint->parent_link_name);
    const Eigen::Isometry3d& X_WJ = X_WL.at(joint->child_link_name);
    const Eigen::Vector3d a = X_WJ.linear() * Eigen::Vector3d(joint->axis.x, joint->axis.y, joint->axis.z);
    dJointID j = nullptr;
    if (joint->type == urdf::Joint::REVOLUTE || joint->type == urdf::Joint::CONTINUOUS) {
      j = dJointCreateHinge(world, nullptr);
      dJointAttach(j, child, parent);
      dJointSetHingeAnchor(j, X_WJ.translation().x(), X_WJ.translation().y(), X_WJ.translation().z());
      dJointSetHingeAxis(j, a.x(), a.y(), a.z());
    } else if (joint->type == urdf::Joint::PRISMATIC) {
      j = dJointCreateSlider(world, nullptr);
      dJointAttach(j, child, parent);
      dJointSetSliderAxis(j, a.x(), a.y(), a.z());
    } else if (joint->type == urdf::Joint::FIXED) {
      j = dJointCreateFixed(world, nullptr);
      dJointAttach(j, child, parent);
      dJointSetFixed(j);
    } else {
      throw std::runtime_error("joint " + name + ": type not in this example");
    }
    dynfilter::ode_backend::OdeJointRef ref;
    ref.name = name;
    ref.joint = j;
    if (joint->limits && joint->type != urdf::Joint::FIXED) {
      ref.tau_max = joint->limits->effort > 0 ? joint->limits->effort : ref.tau_max;
      ref.v_max = joint->limits->velocity > 0 ? joint->limits->velocity : ref.v_max;
    }
    robot.joints.push_back(ref);
  }
}

FigureWorld::~FigureWorld() {
  dJointGroupDestroy(contacts_);
  dSpaceDestroy(space);
  dWorldDestroy(world);
}

void FigureWorld::nearCallback(void* data, dGeomID g1, dGeomID g2) {
  auto* self = static_cast<FigureWorld*>(data);
  const dBodyID b1 = dGeomGetBody(g1), b2 = dGeomGetBody(g2);
  if (b1 != nullptr && b2 != nullptr) return;  // robot against ground only
  dContact contact[16];
  const int n = dCollide(g1, g2, 16, &contact[0].geom, sizeof(dContact));
  for (int i = 0; i < n; ++i) {
    contact[i].surface.mode = dContactApprox1;
    contact[i].surface.mu = 0.8;
    contact[i].surface.bounce = 0.0;
    dJointID j = dJointCreateContact(self->world, self->contacts_, &contact[i]);
    dJointAttach(j, b1, b2);
  }
}

void FigureWorld::step(double dt_s) {
  dSpaceCollide(space, this, &nearCallback);
  dWorldStep(world, dt_s);
  dJointGroupEmpty(contacts_);
}
