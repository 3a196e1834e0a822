#include "dynfilter/io/filtered_motion_check.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "dynfilter/core/types.hpp"

namespace dynfilter::io {

FilteredMotionResiduals evaluateFilteredMotion(IDynamicsModel& model,
                                               const std::vector<FilteredFrame>& frames) {
  const ModelInfo& info = model.info();
  const int nv = info.nv, nb = info.floating_base ? 6 : 0;
  const auto bodies = static_cast<int>(info.body_names.size());
  FilteredMotionResiduals result;
  result.base_n = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(frames.size()));
  result.all = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(frames.size()));
  result.body_weight_n = info.total_mass * 9.81;
  Eigen::MatrixXd A(nv, nv);
  Eigen::VectorXd b(nv), r(nv);
  Matrix6Xd J(6, nv);
  for (std::size_t k = 0; k < frames.size(); ++k) {
    const FilteredFrame& f = frames[k];
    if (f.state.q.size() != info.nq || f.state.v.size() != nv || f.state.vdot.size() != nv ||
        f.tau_J.size() != info.nj)
      throw std::invalid_argument("filtered frame " + std::to_string(k) +
                                  ": sizes do not fit the model " + info.name);
    model.setState(f.state.q, f.state.v);
    model.massMatrix(A);
    model.bias(b);
    r = A * f.state.vdot + b;
    r.tail(info.nj) -= f.tau_J;
    for (const ContactWrench& c : f.contacts) {
      if (c.body < 0 || c.body >= bodies)
        throw std::invalid_argument("filtered frame " + std::to_string(k) + ": contact body " +
                                    std::to_string(c.body) + " is not a body of the model");
      const Eigen::Vector3d p_BC = model.bodyPose(c.body).inverse() * c.p_WC;
      model.pointJacobian(c.body, p_BC, J);
      r -= J.transpose() * c.wrench_W;
    }
    const auto i = static_cast<Eigen::Index>(k);
    result.base_n[i] = nb ? r.head(nb).cwiseAbs().maxCoeff() : 0.0;
    result.all[i] = r.cwiseAbs().maxCoeff();
    if (result.base_n[i] > result.worst_base_n) {
      result.worst_base_n = result.base_n[i];
      result.worst_base_frame = k;
    }
    result.worst_all = std::max(result.worst_all, result.all[i]);
  }
  return result;
}

}  // namespace dynfilter::io
