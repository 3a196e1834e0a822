#pragma once
/// @file
/// Reads back what FilteredMotionWriter wrote — states, accelerations, joint torques and
/// contact wrenches — so that another backend can re-evaluate Eq. 12 on every frame.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "dynfilter/core/model_info.hpp"
#include "dynfilter/core/reference_frame.hpp"
#include "dynfilter/core/types.hpp"
#include "dynfilter/io/input_error.hpp"

namespace dynfilter::io {

/// One contact's wrench as written: body, the contact frame origin and the world wrench
/// [force; moment about p_WC] (N, N m).
struct ContactWrench {
  int body = -1;
  Eigen::Vector3d p_WC = Eigen::Vector3d::Zero();
  Vector6d wrench_W = Vector6d::Zero();
};

struct FilteredFrame {
  ReferenceFrame state;           ///< q, v and vdot = v̇ of the row (time_s too)
  Eigen::VectorXd tau_J;          ///< dim nj (N m / N)
  std::vector<ContactWrench> contacts;
};

/// Reads `<path>` and `<stem>.contacts.csv` (FilteredMotionWriter's two files) for the
/// model @p info. Throws InputError naming file, line and column on malformed input, on a
/// missing `<joint>.tau` column or on a contact whose body is not a link of the model.
std::vector<FilteredFrame> readFilteredMotion(const std::string& path, const ModelInfo& info);

}  // namespace dynfilter::io
