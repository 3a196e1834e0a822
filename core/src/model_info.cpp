#include "dynfilter/core/model_info.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

#include "dynfilter/core/errors.hpp"

namespace dynfilter {
namespace {
std::string formatNumber(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

int findName(const std::vector<std::string>& names, std::string_view name) {
  const auto it = std::find(names.begin(), names.end(), name);
  return it == names.end() ? -1 : static_cast<int>(it - names.begin());
}
}  // namespace

int ModelInfo::findJoint(std::string_view joint_name) const {
  return findName(joint_names, joint_name);
}

int ModelInfo::findBody(std::string_view link_name) const {
  return findName(body_names, link_name);
}

StateCheck ModelInfo::checkState(const Eigen::Ref<const Eigen::VectorXd>& q,
                                 const Eigen::Ref<const Eigen::VectorXd>& v) const {
  StateCheck check;
  auto fail = [&check](int index, bool in_velocity, const char* reason) {
    check.ok = false;
    check.index = index;
    check.in_velocity = in_velocity;
    check.reason = reason;
    return check;
  };
  if (q.size() != nq) return fail(-1, false, "configuration has the wrong size");
  if (v.size() != nv) return fail(-1, true, "velocity has the wrong size");
  for (int i = 0; i < nq; ++i)
    if (!std::isfinite(q[i])) return fail(i, false, "not finite");
  for (int i = 0; i < nv; ++i)
    if (!std::isfinite(v[i])) return fail(i, true, "not finite");
  if (floating_base) {
    const double norm = q.segment<4>(3).norm();
    if (std::abs(norm - 1.0) > kUnitQuaternionTolerance)
      return fail(3, false, "base quaternion (w, x, y, z) is not unit norm");
  }
  return check;
}

void ModelInfo::requireValidState(const Eigen::Ref<const Eigen::VectorXd>& q,
                                  const Eigen::Ref<const Eigen::VectorXd>& v) const {
  const StateCheck check = checkState(q, v);
  if (check.ok) return;
  std::string msg = "model \"" + name + "\": invalid state: ";
  if (check.index < 0) {
    msg += check.reason;
    msg += " (q has " + std::to_string(q.size()) + " entries, expected nq = " +
           std::to_string(nq) + "; v has " + std::to_string(v.size()) +
           ", expected nv = " + std::to_string(nv) + ")";
  } else if (floating_base && !check.in_velocity && check.index == 3 &&
             std::string(check.reason).find("quaternion") != std::string::npos) {
    msg += std::string(check.reason) + " (norm " + formatNumber(q.segment<4>(3).norm()) +
           ", tolerance " + formatNumber(kUnitQuaternionTolerance) + ")";
  } else {
    msg += std::string(check.in_velocity ? "v[" : "q[") + std::to_string(check.index) +
           "] is " + check.reason;
  }
  throw InvalidStateError(msg);
}

Eigen::VectorXd ModelInfo::neutralConfiguration() const {
  Eigen::VectorXd q = Eigen::VectorXd::Zero(nq);
  if (floating_base) q[3] = 1.0;
  for (int j = 0; j < nj; ++j)
    q[configurationIndex(j)] = std::clamp(0.0, q_lower[j], q_upper[j]);
  return q;
}

}  // namespace dynfilter
