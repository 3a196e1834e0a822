#pragma once
// Statistics gathered over an offline run and the closing summary printed from them.

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "dynfilter/core/filter_output.hpp"
#include "dynfilter/core/kinematic_tree.hpp"
#include "dynfilter/core/model_info.hpp"

namespace dynfilter::tools {

class RunSummary {
 public:
  /// @param joint_groups dim nj (jointGroupsOf): the tracking RMS is printed per group.
  RunSummary(const ModelInfo& info, const std::vector<JointGroup>& joint_groups);
  /// Accumulates one filter tick.
  void add(const FilterOutput& out);
  /// Prints the table to @p stream: @p frames written, @p motion_s of motion, @p wall_s of
  /// wall time for the whole run.
  void print(std::FILE* stream, int frames, double motion_s, double wall_s) const;
  double maxBaseResidual() const { return max_base_residual_n_; }

 private:
  struct Group {
    std::string name;
    std::vector<int> coordinates;  // indices into v
    double sum_squares = 0.0;
    long samples = 0;
  };
  const ModelInfo& info_;
  std::vector<Group> groups_;
  int ticks_ = 0;
  double max_residual_ = 0.0;
  double max_base_residual_n_ = 0.0;
  double min_normal_force_n_ = 0.0, max_normal_force_n_ = 0.0;
  bool any_contact_ = false;
  double max_penetration_m_ = 0.0;
  double tick_time_sum_s_ = 0.0;
  unsigned status_union_ = 0;
  int ticks_with_pulling_ = 0;
  int reseeds_ = 0;
  double first_reseed_s_ = 0.0;
  std::uint64_t leash_ticks_ = 0;
  Eigen::Isometry3d X_reference_offset_ = Eigen::Isometry3d::Identity();
};

}  // namespace dynfilter::tools
