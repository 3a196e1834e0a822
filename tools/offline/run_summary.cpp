#include "run_summary.hpp"

#include <algorithm>
#include <cmath>

#include "dynfilter/core/lie_group.hpp"

namespace dynfilter::tools {

RunSummary::RunSummary(const ModelInfo& info, const std::vector<JointGroup>& joint_groups)
    : info_(info) {
  if (info.floating_base) {
    groups_.push_back({"base position (m)", {0, 1, 2}});
    groups_.push_back({"base orientation (rad)", {3, 4, 5}});
  }
  Group legs{"legs (rad)", {}}, arms{"arms (rad)", {}}, spine{"spine, head (rad)", {}},
      other{"other joints", {}};
  for (int j = 0; j < info.nj; ++j) {
    const int i = info.velocityIndex(j);
    switch (joint_groups.at(static_cast<std::size_t>(j))) {
      case JointGroup::kLeg: legs.coordinates.push_back(i); break;
      case JointGroup::kArm: arms.coordinates.push_back(i); break;
      case JointGroup::kSpine: spine.coordinates.push_back(i); break;
      case JointGroup::kOther: other.coordinates.push_back(i); break;
    }
  }
  for (Group* g : {&legs, &arms, &spine, &other})
    if (!g->coordinates.empty()) groups_.push_back(*g);
}

void RunSummary::add(const FilterOutput& out) {
  ++ticks_;
  for (Group& g : groups_) {
    for (int i : g.coordinates) g.sum_squares += out.tracking_error[i] * out.tracking_error[i];
    g.samples += static_cast<long>(g.coordinates.size());
  }
  max_residual_ = std::max(max_residual_, out.eq12_residual);
  max_base_residual_n_ = std::max(max_base_residual_n_, out.base_residual_n);
  max_penetration_m_ = std::max(max_penetration_m_, out.max_penetration_m);
  tick_time_sum_s_ += out.tick_time_s;
  status_union_ |= out.status;
  if (out.status & kStatusReseeded) {
    if (reseeds_ == 0) first_reseed_s_ = out.time_s;
    ++reseeds_;
  }
  bool pulling = false;
  for (int c = 0; c < out.num_contacts; ++c) {
    const double f = out.contacts[static_cast<std::size_t>(c)].normal_force_n;
    if (!any_contact_) min_normal_force_n_ = max_normal_force_n_ = f;
    any_contact_ = true;
    min_normal_force_n_ = std::min(min_normal_force_n_, f);
    max_normal_force_n_ = std::max(max_normal_force_n_, f);
    pulling |= f < 0.0;
  }
  ticks_with_pulling_ += pulling;
  leash_ticks_ = out.counters.leash_ticks;
  X_reference_offset_ = out.X_reference_offset;
}

void RunSummary::print(std::FILE* s, int frames, double motion_s, double wall_s) const {
  std::fprintf(s, "\nframes written        %d (%.3f s of motion, %d filter ticks)\n", frames,
               motion_s, ticks_);
  std::fprintf(s, "tracking RMS\n");
  for (const Group& g : groups_)
    std::fprintf(s, "  %-22s %.4g\n", g.name.c_str(),
                 g.samples ? std::sqrt(g.sum_squares / static_cast<double>(g.samples)) : 0.0);
  std::fprintf(s, "max Eq. 12 residual   %.3g (all rows), %.3g N on the base rows (%.2g of body weight)\n",
               max_residual_, max_base_residual_n_,
               max_base_residual_n_ / (info_.total_mass * 9.81));
  if (any_contact_)
    std::fprintf(s, "contact normal force  min %.1f N, max %.1f N; %d ticks with a pulling contact\n",
                 min_normal_force_n_, max_normal_force_n_, ticks_with_pulling_);
  else
    std::fprintf(s, "contact normal force  no contact\n");
  std::fprintf(s, "max penetration       %.2f mm\n", 1e3 * max_penetration_m_);
  if (reseeds_ > 0)
    std::fprintf(s, "re-seeds              %d ticks, the first at %.3f s (the state was reset to the "
                    "reference: --events-csv lists them)\n", reseeds_, first_reseed_s_);
  else
    std::fprintf(s, "re-seeds              0\n");
  if (leash_ticks_ > 0) {
    std::fprintf(s, "reference leash       moved the reference on %llu ticks; at the end by (%.3f, %.3f, %.3f) m "
                    "and %.3f rad of heading\n",
                 static_cast<unsigned long long>(leash_ticks_), X_reference_offset_.translation().x(),
                 X_reference_offset_.translation().y(), X_reference_offset_.translation().z(),
                 tiltAndHeading(Eigen::Matrix3d::Identity(), X_reference_offset_.linear()).heading_rad);
  }
  std::fprintf(s, "time per tick         %.1f µs (filter only)\n",
               ticks_ ? 1e6 * tick_time_sum_s_ / ticks_ : 0.0);
  std::fprintf(s, "time per frame        %.1f µs (everything, with I/O); %.0f× real time\n",
               frames ? 1e6 * wall_s / frames : 0.0, wall_s > 0 ? motion_s / wall_s : 0.0);
  std::fprintf(s, "status flags seen     0x%x\n", status_union_);
}

}  // namespace dynfilter::tools
