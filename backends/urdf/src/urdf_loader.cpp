#include "dynfilter/urdf/urdf_loader.hpp"

#include <tinyxml2.h>
#include <urdf_parser/urdf_parser.h>

#include <console_bridge/console.h>

#include <algorithm>
#include <cerrno>
#include <fnmatch.h>
#include <filesystem>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include <Eigen/Eigenvalues>

#include "dynfilter/core/errors.hpp"
#include "mesh_hull.hpp"

namespace dynfilter::urdf {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// urdfdom reports problems through console_bridge; keep the first error for our message.
class CapturingOutputHandler : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR && first_error.empty())
      first_error = text;
  }
  std::string first_error;
};

class ScopedCapture {
 public:
  explicit ScopedCapture(CapturingOutputHandler* handler) {
    console_bridge::useOutputHandler(handler);
  }
  ~ScopedCapture() { console_bridge::restorePreviousOutputHandler(); }
  ScopedCapture(const ScopedCapture&) = delete;
  ScopedCapture& operator=(const ScopedCapture&) = delete;
};

std::string quoted(const char* s) { return std::string("\"") + (s ? s : "") + "\""; }

// What the structural pass learns about the document: names in file order and their lines.
struct DocumentIndex {
  std::string robot_name;
  std::vector<std::string> link_names;
  std::vector<int> link_lines;
  std::vector<std::vector<int>> collision_lines;  ///< per link: the line of each <collision>
  std::vector<std::string> joint_names;
  std::vector<int> joint_lines;
  std::map<std::string, int> mimic_line;          ///< joint name → line of its <mimic>
  std::string floating_base_link;  ///< the child of a root `floating` joint (the root link dropped)
  std::vector<std::string> warnings;
  // Ignored elements by name: count and first line, in order of first appearance.
  std::vector<std::string> ignored_order;
  std::map<std::string, std::pair<int, int>> ignored;
};

// Children whose content builds the model; every other element is ignored (simulator and
// controller tags, visuals, extensions) and listed once in ignored_elements.
const std::set<std::string> kRobotChildren{"link", "joint"};
const std::set<std::string> kLinkChildren{"inertial", "collision"};
const std::set<std::string> kJointChildren{"origin", "parent", "child", "axis", "limit", "mimic"};
const std::set<std::string> kSupportedJointTypes{"revolute", "continuous", "prismatic", "fixed"};
const std::set<std::string> kKnownUnsupportedJointTypes{"floating", "planar"};

DocumentIndex indexDocument(const std::string& xml, const std::string& source) {
  tinyxml2::XMLDocument doc;
  if (doc.Parse(xml.c_str(), xml.size()) != tinyxml2::XML_SUCCESS) {
    const char* detail = doc.ErrorStr();
    throw ModelError(source, doc.ErrorLineNum(), "XML",
                     std::string("malformed XML: ") + (detail ? detail : doc.ErrorName()));
  }
  const tinyxml2::XMLElement* robot = doc.RootElement();
  if (robot == nullptr || std::strcmp(robot->Name(), "robot") != 0) {
    throw ModelError(source, robot ? robot->GetLineNum() : 1,
                     robot ? "<" + std::string(robot->Name()) + ">" : "document",
                     "the root element must be <robot>");
  }
  DocumentIndex index;
  index.robot_name = robot->Attribute("name") ? robot->Attribute("name") : "";
  std::map<std::string, int> link_line;
  std::map<std::string, int> joint_line;
  std::vector<const tinyxml2::XMLElement*> floating_joints;

  auto requireName = [&](const tinyxml2::XMLElement* e) -> std::string {
    const char* name = e->Attribute("name");
    if (name == nullptr || *name == '\0')
      throw ModelError(source, e->GetLineNum(), "<" + std::string(e->Name()) + ">",
                       "missing the name attribute");
    return name;
  };
  auto ignore = [&](const tinyxml2::XMLElement* e, const std::string& parent) {
    const std::string key = "<" + parent + "><" + e->Name() + ">";
    auto [it, inserted] = index.ignored.emplace(key, std::make_pair(0, e->GetLineNum()));
    if (inserted) index.ignored_order.push_back(key);
    ++it->second.first;
  };
  auto ignoreOtherChildren = [&](const tinyxml2::XMLElement* e,
                                 const std::set<std::string>& used) {
    for (auto* c = e->FirstChildElement(); c; c = c->NextSiblingElement())
      if (!used.count(c->Name())) ignore(c, e->Name());
  };

  for (auto* e = robot->FirstChildElement(); e; e = e->NextSiblingElement()) {
    const std::string tag = e->Name();
    if (!kRobotChildren.count(tag)) {
      ignore(e, "robot");
      continue;
    }
    if (tag == "link") {
      const std::string name = requireName(e);
      const std::string label = "link " + quoted(name.c_str());
      if (link_line.count(name))
        throw ModelError(source, e->GetLineNum(), label,
                         "duplicate link name (first defined on line " +
                             std::to_string(link_line[name]) + ")");
      ignoreOtherChildren(e, kLinkChildren);
      std::vector<int> collisions;
      for (auto* c = e->FirstChildElement("collision"); c; c = c->NextSiblingElement("collision")) {
        const auto* geometry = c->FirstChildElement("geometry");
        const auto* shape = geometry ? geometry->FirstChildElement() : nullptr;
        if (shape == nullptr)
          throw ModelError(source, c->GetLineNum(), label, "<collision> without a geometry");
        collisions.push_back(shape->GetLineNum());
      }
      index.collision_lines.push_back(std::move(collisions));
      link_line[name] = e->GetLineNum();
      index.link_names.push_back(name);
      index.link_lines.push_back(e->GetLineNum());
    } else if (tag == "joint") {
      const std::string name = requireName(e);
      const std::string label = "joint " + quoted(name.c_str());
      if (joint_line.count(name))
        throw ModelError(source, e->GetLineNum(), label,
                         "duplicate joint name (first defined on line " +
                             std::to_string(joint_line[name]) + ")");
      ignoreOtherChildren(e, kJointChildren);
      const char* type = e->Attribute("type");
      if (type == nullptr)
        throw ModelError(source, e->GetLineNum(), label, "missing the type attribute");
      if (std::strcmp(type, "floating") == 0)
        floating_joints.push_back(e);  // accepted from a root that is only the world (below)
      else if (kKnownUnsupportedJointTypes.count(type))
        throw ModelError(source, e->GetLineNum(), label,
                         "unsupported joint type " + quoted(type) +
                             " (supported: revolute, continuous, prismatic, fixed)");
      else if (!kSupportedJointTypes.count(type))
        throw ModelError(source, e->GetLineNum(), label,
                         "unknown joint type " + quoted(type) +
                             " (supported: revolute, continuous, prismatic, fixed)");
      if (const auto* mimic = e->FirstChildElement("mimic")) {
        const char* leader = mimic->Attribute("joint");
        if (leader == nullptr || *leader == '\0')
          throw ModelError(source, mimic->GetLineNum(), label,
                           "<mimic> without a joint attribute");
        index.mimic_line[name] = mimic->GetLineNum();
      }
      joint_line[name] = e->GetLineNum();
      index.joint_names.push_back(name);
      index.joint_lines.push_back(e->GetLineNum());
    }
  }
  // Dangling references are reported here, with the line, before urdfdom sees them.
  for (auto* e = robot->FirstChildElement("joint"); e; e = e->NextSiblingElement("joint")) {
    const std::string label = "joint " + quoted(e->Attribute("name"));
    for (const char* role : {"parent", "child"}) {
      const auto* ref = e->FirstChildElement(role);
      const char* link = ref ? ref->Attribute("link") : nullptr;
      if (link == nullptr)
        throw ModelError(source, e->GetLineNum(), label,
                         std::string("missing <") + role + " link=\"...\"/>");
      if (!link_line.count(link))
        throw ModelError(source, ref->GetLineNum(), label,
                         std::string(role) + " link " + quoted(link) + " is not defined");
    }
  }
  // The joints must form a tree. urdfdom accepts a link that is the child of two joints and
  // joints that close a loop away from the root (a link that is its own parent, or a cycle
  // of links): those links never reach the root, the tree walked from the root leaves them
  // out, and urdfdom's model of them leaks. Both are reported here, before urdfdom.
  std::map<std::string, const tinyxml2::XMLElement*> joint_of_child;
  for (auto* e = robot->FirstChildElement("joint"); e; e = e->NextSiblingElement("joint")) {
    const char* child = e->FirstChildElement("child")->Attribute("link");
    const auto [it, inserted] = joint_of_child.emplace(child, e);
    if (!inserted)
      throw ModelError(source, e->GetLineNum(), "joint " + quoted(e->Attribute("name")),
                       "child link " + quoted(child) + " already has the parent joint " +
                           quoted(it->second->Attribute("name")) + " (line " +
                           std::to_string(it->second->GetLineNum()) +
                           "; the joints must form a tree)");
  }
  for (const std::string& start : index.link_names) {
    std::string link = start;
    for (std::size_t steps = 0;; ++steps) {
      const auto it = joint_of_child.find(link);
      if (it == joint_of_child.end()) break;  // reached a root
      if (steps == joint_of_child.size())
        throw ModelError(source, it->second->GetLineNum(),
                         "joint " + quoted(it->second->Attribute("name")),
                         "closes a loop: link " + quoted(link.c_str()) +
                             " is its own ancestor (the joints must form a tree)");
      link = it->second->FirstChildElement("parent")->Attribute("link");
    }
  }
  if (index.link_names.empty())
    throw ModelError(source, robot->GetLineNum(), "<robot>", "no <link> elements");
  // A `floating` joint from a root link that stands for the world (no mass, no collision,
  // no other joint; "world" in many descriptions) to the robot's base says what every model
  // here has: a floating base. The root link and the joint are dropped; the base is the child.
  for (const tinyxml2::XMLElement* e : floating_joints) {
    const std::string name = e->Attribute("name");
    const std::string parent = e->FirstChildElement("parent")->Attribute("link");
    const std::string child = e->FirstChildElement("child")->Attribute("link");
    const tinyxml2::XMLElement* parent_link = nullptr;
    for (auto* l = robot->FirstChildElement("link"); l; l = l->NextSiblingElement("link"))
      if (parent == l->Attribute("name")) parent_link = l;
    int parent_joints = 0;
    for (auto* j = robot->FirstChildElement("joint"); j; j = j->NextSiblingElement("joint"))
      parent_joints += parent == j->FirstChildElement("parent")->Attribute("link") ? 1 : 0;
    const auto* mass = parent_link->FirstChildElement("inertial")
                           ? parent_link->FirstChildElement("inertial")->FirstChildElement("mass")
                           : nullptr;
    const bool massless = mass == nullptr || mass->DoubleAttribute("value", 1.0) == 0.0;
    if (floating_joints.size() > 1 || joint_of_child.count(parent) || parent_joints != 1 || !massless ||
        parent_link->FirstChildElement("collision") != nullptr)
      throw ModelError(source, e->GetLineNum(), "joint " + quoted(name.c_str()),
                       "unsupported joint type \"floating\" here (a floating joint is accepted only "
                       "from a root link without mass, collision or other joints, the world, to the "
                       "base; supported: revolute, continuous, prismatic, fixed)");
    const auto indexOf = [](const std::vector<std::string>& names, const std::string& n) {
      return static_cast<std::size_t>(std::find(names.begin(), names.end(), n) - names.begin());
    };
    const std::size_t l = indexOf(index.link_names, parent), j = indexOf(index.joint_names, name);
    index.link_names.erase(index.link_names.begin() + static_cast<std::ptrdiff_t>(l));
    index.link_lines.erase(index.link_lines.begin() + static_cast<std::ptrdiff_t>(l));
    index.collision_lines.erase(index.collision_lines.begin() + static_cast<std::ptrdiff_t>(l));
    index.joint_names.erase(index.joint_names.begin() + static_cast<std::ptrdiff_t>(j));
    index.joint_lines.erase(index.joint_lines.begin() + static_cast<std::ptrdiff_t>(j));
    index.floating_base_link = child;
    index.warnings.push_back(source + ":" + std::to_string(e->GetLineNum()) + ": joint " + quoted(name.c_str()) +
                             " (floating) from link " + quoted(parent.c_str()) + ": the floating base is link " +
                             quoted(child.c_str()) + "; link " + quoted(parent.c_str()) + " is the world, dropped");
  }
  return index;
}

Eigen::Isometry3d toIsometry(const ::urdf::Pose& pose) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.translation() = Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z);
  X.linear() = Eigen::Quaterniond(pose.rotation.w, pose.rotation.x, pose.rotation.y,
                                  pose.rotation.z).normalized().toRotationMatrix();
  return X;
}

RobotDescription buildDescription(const ::urdf::ModelInterface& model, DocumentIndex index,
                                  const std::string& source, const UrdfLoadOptions& options,
                                  const std::string& base_directory) {
  RobotDescription robot;
  robot.name = model.getName();
  robot.source = source;
  robot.warnings = std::move(index.warnings);
  for (const auto& key : index.ignored_order) {
    const auto& [count, line] = index.ignored.at(key);
    robot.ignored_elements.push_back(key + " x" + std::to_string(count) + " (first at " +
                                     source + ":" + std::to_string(line) + ")");
  }

  std::map<std::string, int> link_index;
  for (std::size_t i = 0; i < index.link_names.size(); ++i) {
    const auto link = model.getLink(index.link_names[i]);
    // tinyxml2 (the index) and urdfdom's TinyXML may read unusual bytes in a name apart.
    if (!link)
      throw ModelError(source, index.link_lines[i], "link " + quoted(index.link_names[i].c_str()),
                       "urdfdom reads this link's name differently "
                       "(a carriage return or unusual bytes in it)");
    LinkDesc desc;
    desc.name = index.link_names[i];
    desc.line = index.link_lines[i];
    if (link->inertial) {
      const ::urdf::Inertial& in = *link->inertial;
      desc.inertial.present = true;
      desc.inertial.mass_kg = in.mass;
      const Eigen::Isometry3d X_LI = toIsometry(in.origin);
      desc.inertial.p_LCom = X_LI.translation();
      Eigen::Matrix3d I_I;
      I_I << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
      desc.inertial.I_Com_L = X_LI.linear() * I_I * X_LI.linear().transpose();
      // Physically impossible on its own, but the dynamics need only each rigid body's sum
      // (validateForDynamics): say so, and go on.
      const Eigen::Vector3d m = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(I_I).eigenvalues();
      const double tolerance = 1e-9 * std::abs(m[2]) + 1e-15;
      if (in.mass > 0.0 && I_I.allFinite() && (m[0] < -tolerance || m[0] + m[1] < m[2] - tolerance))
        robot.warnings.push_back(source + ":" + std::to_string(desc.line) + ": link " +
                                 quoted(desc.name.c_str()) + ": inertia " +
                                 (m[0] < -tolerance ? "not positive semi-definite"
                                                    : "violates the triangle inequality") +
                                 " (principal moments " + std::to_string(m[0]) + ", " +
                                 std::to_string(m[1]) + ", " + std::to_string(m[2]) +
                                 " kg m²); accepted: the rigid body it belongs to is checked");
    }
    const std::vector<int>& collision_lines = index.collision_lines[i];
    for (std::size_t k = 0; k < link->collision_array.size(); ++k) {
      const auto& collision = link->collision_array[k];
      if (!collision || !collision->geometry) continue;
      const int line = k < collision_lines.size() ? collision_lines[k] : desc.line;
      CollisionShapeDesc shape;
      shape.X_LS = toIsometry(collision->origin);
      switch (collision->geometry->type) {
        case ::urdf::Geometry::BOX: {
          const auto& box = static_cast<const ::urdf::Box&>(*collision->geometry);
          shape.kind = ShapeKind::kBox;
          shape.box_size_m = Eigen::Vector3d(box.dim.x, box.dim.y, box.dim.z);
          break;
        }
        case ::urdf::Geometry::SPHERE:
          shape.kind = ShapeKind::kSphere;
          shape.radius_m = static_cast<const ::urdf::Sphere&>(*collision->geometry).radius;
          break;
        case ::urdf::Geometry::CYLINDER: {
          const auto& cyl = static_cast<const ::urdf::Cylinder&>(*collision->geometry);
          shape.kind = ShapeKind::kCylinder;
          shape.radius_m = cyl.radius;
          shape.length_m = cyl.length;
          break;
        }
        case ::urdf::Geometry::MESH: {
          const auto& mesh = static_cast<const ::urdf::Mesh&>(*collision->geometry);
          const std::string label = "link " + quoted(desc.name.c_str()) + " <mesh>";
          const Eigen::Vector3d scale(mesh.scale.x, mesh.scale.y, mesh.scale.z);
          // A mirrored scale (e.g. "1 -1 1", common for left/right parts) is fine: it is
          // applied to the vertices before the hull, so no engine ever sees it (DART
          // aborts on a mirrored MeshShape scale).
          if (!scale.allFinite() || !(scale.cwiseAbs().minCoeff() > 0.0))
            throw ModelError(source, line, label,
                             "mesh scale must be finite and non-zero in every axis (a zero "
                             "scale flattens the mesh)");
          shape.kind = ShapeKind::kConvexHull;
          try {
            shape.mesh_path = resolveMeshUri(mesh.filename, base_directory, options.package_paths);
            shape.hull = convexHullOfMesh(shape.mesh_path, scale);
          } catch (const std::runtime_error& e) {
            throw ModelError(source, line, label, e.what());
          }
          break;
        }
        default:
          continue;
      }
      desc.collisions.push_back(shape);
    }
    link_index[desc.name] = static_cast<int>(i);
    robot.links.push_back(std::move(desc));
  }

  for (std::size_t i = 0; i < index.joint_names.size(); ++i) {
    const auto joint = model.getJoint(index.joint_names[i]);
    if (!joint)
      throw ModelError(source, index.joint_lines[i],
                       "joint " + quoted(index.joint_names[i].c_str()),
                       "urdfdom reads this joint's name differently "
                       "(a carriage return or unusual bytes in it)");
    JointDesc desc;
    desc.name = index.joint_names[i];
    desc.line = index.joint_lines[i];
    desc.parent_link = link_index.at(joint->parent_link_name);
    desc.child_link = link_index.at(joint->child_link_name);
    desc.X_PJ = toIsometry(joint->parent_to_joint_origin_transform);
    const std::string label = "joint " + quoted(desc.name.c_str());
    switch (joint->type) {
      case ::urdf::Joint::REVOLUTE: desc.type = JointType::kRevolute; break;
      case ::urdf::Joint::CONTINUOUS: desc.type = JointType::kContinuous; break;
      case ::urdf::Joint::PRISMATIC: desc.type = JointType::kPrismatic; break;
      case ::urdf::Joint::FIXED: desc.type = JointType::kFixed; break;
      default:
        throw ModelError(source, desc.line, label, "unsupported joint type");
    }
    if (desc.moving()) {
      const Eigen::Vector3d axis(joint->axis.x, joint->axis.y, joint->axis.z);
      if (!axis.allFinite() || axis.norm() < 1e-9)
        throw ModelError(source, desc.line, label, "the joint axis is zero or not finite");
      desc.axis_J = axis.normalized();
      desc.lower = -kInf;
      desc.upper = kInf;
      desc.velocity_max = kInf;
      desc.effort_max = kInf;
      if (joint->limits) {
        const auto& lim = *joint->limits;
        if (desc.type != JointType::kContinuous) {
          desc.lower = lim.lower;
          desc.upper = lim.upper;
        }
        if (lim.velocity > 0.0) desc.velocity_max = lim.velocity;
        if (lim.effort > 0.0) desc.effort_max = lim.effort;
        if (lim.velocity < 0.0 || lim.effort < 0.0 || !std::isfinite(lim.velocity) ||
            !std::isfinite(lim.effort))
          throw ModelError(source, desc.line, label,
                           "<limit> velocity and effort must be finite and >= 0");
        if (lim.effort == 0.0 || lim.velocity == 0.0)
          robot.warnings.push_back(source + ":" + std::to_string(desc.line) + ": " + label +
                                   ": <limit> effort or velocity is 0; treated as unlimited");
      }
      if (desc.type != JointType::kContinuous &&
          !(std::isfinite(desc.lower) && std::isfinite(desc.upper) && desc.lower <= desc.upper))
        throw ModelError(source, desc.line, label,
                         "position limits must be finite with lower <= upper (lower " +
                             std::to_string(desc.lower) + ", upper " +
                             std::to_string(desc.upper) + ")");
    }
    if (joint->mimic) {
      const int line = index.mimic_line.count(desc.name) ? index.mimic_line.at(desc.name) : desc.line;
      const auto& mimic = *joint->mimic;
      if (!desc.moving()) {
        robot.warnings.push_back(source + ":" + std::to_string(line) + ": " + label +
                                 ": <mimic> on a fixed joint is ignored");
      } else {
        const auto leader = std::find(index.joint_names.begin(), index.joint_names.end(),
                                      mimic.joint_name);
        if (leader == index.joint_names.end())
          throw ModelError(source, line, label + " <mimic>",
                           "leader joint " + quoted(mimic.joint_name.c_str()) + " is not defined");
        if (!std::isfinite(mimic.multiplier) || !std::isfinite(mimic.offset))
          throw ModelError(source, line, label + " <mimic>",
                           "multiplier and offset must be finite");
        desc.mimic_leader = static_cast<int>(leader - index.joint_names.begin());
        desc.mimic_multiplier = mimic.multiplier;
        desc.mimic_offset = mimic.offset;
      }
    }
    robot.joints.push_back(std::move(desc));
  }

  // Mimic chains resolve to their first independent leader: q = k₂(k₁ q₀ + c₁) + c₂.
  for (std::size_t j = 0; j < robot.joints.size(); ++j) {
    JointDesc& follower = robot.joints[j];
    if (!follower.mimics()) continue;
    const int line = index.mimic_line.at(follower.name);
    const std::string label = "joint " + quoted(follower.name.c_str()) + " <mimic>";
    for (std::size_t steps = 0; robot.joints[static_cast<std::size_t>(follower.mimic_leader)].mimics(); ++steps) {
      const JointDesc& mid = robot.joints[static_cast<std::size_t>(follower.mimic_leader)];
      if (steps > robot.joints.size() || mid.mimic_leader == static_cast<int>(j))
        throw ModelError(source, line, label, "mimic joints form a cycle");
      follower.mimic_offset += follower.mimic_multiplier * mid.mimic_offset;
      follower.mimic_multiplier *= mid.mimic_multiplier;
      follower.mimic_leader = mid.mimic_leader;
    }
    const JointDesc& leader = robot.joints[static_cast<std::size_t>(follower.mimic_leader)];
    if (static_cast<int>(j) == follower.mimic_leader)
      throw ModelError(source, line, label, "a joint cannot mimic itself");
    if (!leader.moving())
      throw ModelError(source, line, label,
                       "leader joint " + quoted(leader.name.c_str()) + " is fixed");
  }
  for (std::size_t j = 0; j < robot.joints.size(); ++j) {
    JointDesc& desc = robot.joints[j];
    if (!desc.moving()) continue;
    if (desc.mimics()) {
      robot.mimic_joints.push_back(static_cast<int>(j));
      continue;
    }
    desc.coordinate = static_cast<int>(robot.moving_joints.size());
    robot.moving_joints.push_back(static_cast<int>(j));
  }

  for (std::size_t j = 0; j < robot.joints.size(); ++j) {
    LinkDesc& child = robot.links[robot.joints[j].child_link];
    child.parent_joint = static_cast<int>(j);
    robot.links[robot.joints[j].parent_link].child_joints.push_back(static_cast<int>(j));
  }
  robot.root_link = link_index.at(index.floating_base_link.empty() ? model.getRoot()->name : index.floating_base_link);
  return robot;
}

}  // namespace

RobotDescription loadUrdfString(const std::string& xml, const std::string& source_label,
                                const UrdfLoadOptions& options,
                                const std::string& base_directory) {
  DocumentIndex index = indexDocument(xml, source_label);
  CapturingOutputHandler handler;
  ::urdf::ModelInterfaceSharedPtr model;
  {
    ScopedCapture capture(&handler);
    model = ::urdf::parseURDF(xml);
  }
  if (!model) {
    throw ModelError(source_label, 0, "<robot>",
                     handler.first_error.empty() ? "urdfdom could not parse the model"
                                                 : "urdfdom: " + handler.first_error);
  }
  RobotDescription robot =
      buildDescription(*model, std::move(index), source_label, options, base_directory);
  if (!options.lock_joints.empty()) lockJoints(robot, resolveJointLocks(robot, options.lock_joints));
  warnSingularMassMatrix(robot);
  return robot;
}

RobotDescription loadUrdfFile(const std::string& path, const UrdfLoadOptions& options) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ModelError(path, 0, "file", std::string("cannot open: ") + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw ModelError(path, 0, "file", "read error");
  return loadUrdfString(text.str(), path, options,
                        std::filesystem::path(path).parent_path().string());
}

}  // namespace dynfilter::urdf

namespace dynfilter::urdf {

std::vector<JointLock> resolveJointLocks(const RobotDescription& robot,
                                         const std::vector<std::string>& entries) {
  std::vector<JointLock> locks;
  auto lockAt = [&](int joint, double position) {
    for (auto& l : locks)
      if (l.joint == robot.joints[static_cast<std::size_t>(joint)].name) {
        l.position = position;
        return;
      }
    locks.push_back({robot.joints[static_cast<std::size_t>(joint)].name, position});
  };
  for (const std::string& entry : entries) {
    std::size_t start = 0;
    while (start <= entry.size()) {
      const std::size_t comma = entry.find(',', start);
      const std::string token =
          entry.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
      start = comma == std::string::npos ? entry.size() + 1 : comma + 1;
      if (token.empty()) continue;
      const std::size_t eq = token.find('=');
      const std::string pattern = token.substr(0, eq);
      double position = 0.0;
      if (eq != std::string::npos) {
        const std::string value = token.substr(eq + 1);
        char* end = nullptr;
        position = std::strtod(value.c_str(), &end);
        if (value.empty() || end == nullptr || *end != '\0' || !std::isfinite(position))
          throw ModelError(robot.source, 0, "--lock-joints",
                           "\"" + token + "\": the position after '=' is not a number");
      }
      bool matched = false;
      for (std::size_t j = 0; j < robot.joints.size(); ++j) {
        const JointDesc& joint = robot.joints[j];
        if (!joint.moving() || fnmatch(pattern.c_str(), joint.name.c_str(), 0) != 0) continue;
        lockAt(static_cast<int>(j), position);
        matched = true;
      }
      if (!matched)
        throw ModelError(robot.source, 0, "--lock-joints",
                         "\"" + pattern + "\" matches no moving joint of model \"" +
                             robot.name + "\"");
    }
  }
  return locks;
}

}  // namespace dynfilter::urdf
