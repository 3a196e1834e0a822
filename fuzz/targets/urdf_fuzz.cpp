// Fuzz target: a URDF through the project's loader (backends/urdf) as every tool loads a
// model, minus building the engine model: loadUrdfString, validateForDynamics and
// makeModelInfo for a floating and a fixed base, and the parent-first link order the
// backends build in. Documented error: ModelError (dynfilter/core/errors.hpp).
#include <string>
#include <vector>

#include "dynfilter/core/errors.hpp"
#include "dynfilter/urdf/robot_description.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "fuzz_support.hpp"

namespace {
constexpr const char* kTarget = "urdf_fuzz";

void checkDescription(const dynfilter::urdf::RobotDescription& robot) {
  using dynfilter::fuzz::violated;
  const int links = static_cast<int>(robot.links.size());
  const int joints = static_cast<int>(robot.joints.size());
  if (robot.root_link < 0 || robot.root_link >= links) violated(kTarget, "root link out of range");
  for (const auto& joint : robot.joints)
    if (joint.parent_link < 0 || joint.parent_link >= links || joint.child_link < 0 ||
        joint.child_link >= links)
      violated(kTarget, "joint " + joint.name + " refers to a link out of range");
  for (const auto& link : robot.links)
    if (link.parent_joint < -1 || link.parent_joint >= joints)
      violated(kTarget, "link " + link.name + " has a parent joint out of range");
  const std::vector<int> order = robot.linksParentFirst();
  if (order.size() != robot.links.size())
    violated(kTarget, "linksParentFirst does not list every link once");
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string xml(reinterpret_cast<const char*>(data), size);
  try {
    const dynfilter::urdf::RobotDescription robot =
        dynfilter::urdf::loadUrdfString(xml, "fuzz.urdf");
    checkDescription(robot);
    for (const bool floating_base : {true, false}) {
      try {
        dynfilter::urdf::validateForDynamics(robot, floating_base);
        const dynfilter::ModelInfo info = dynfilter::urdf::makeModelInfo(robot, floating_base);
        if (info.nj != static_cast<int>(info.joint_names.size()) ||
            info.q_lower.size() != info.nj || info.body_names.size() != robot.links.size())
          dynfilter::fuzz::violated(kTarget, "ModelInfo sizes disagree");
      } catch (const dynfilter::ModelError&) {
      }
    }
  } catch (const dynfilter::ModelError&) {
  } catch (...) {
    dynfilter::fuzz::unexpectedException(kTarget);
  }
  return 0;
}
