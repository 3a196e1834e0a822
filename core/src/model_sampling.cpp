#include "dynfilter/core/model_sampling.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace dynfilter {

void randomState(const ModelInfo& info, std::mt19937& rng, double velocity_scale,
                 Eigen::VectorXd& q, Eigen::VectorXd& v) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::normal_distribution<double> normal(0.0, 1.0);
  q.resize(info.nq);
  v.resize(info.nv);
  if (info.floating_base) {
    q.head<3>() = Eigen::Vector3d(unit(rng), unit(rng), 1.0 + unit(rng));
    // A normalised 4-D Gaussian is uniform on the rotation group.
    q.segment<4>(3) =
        Eigen::Vector4d(normal(rng), normal(rng), normal(rng), normal(rng)).normalized();
  }
  for (int j = 0; j < info.nj; ++j) {
    const double lo = std::isfinite(info.q_lower[j]) ? info.q_lower[j] : -M_PI;
    const double hi = std::isfinite(info.q_upper[j]) ? info.q_upper[j] : M_PI;
    q[info.configurationIndex(j)] = lo + (hi - lo) * 0.5 * (1.0 + unit(rng));
  }
  for (int i = 0; i < info.nv; ++i) v[i] = velocity_scale * unit(rng);
}

namespace {

constexpr double kStandingRange_m = 3.0;  // searched above the start height
constexpr double kStandingStep_m = 0.05;  // the downward scan of a base origin below the feet

// The base height at which @p model in @p q first touches what @p touches accepts of its
// contacts: bisection over [start, start + 3 m], taking the start as touching (a query far
// below the surface can make an engine report garbage that its persistent contact
// manifolds keep for later queries). When no query touched, the base origin lies below
// the feet: a downward scan from the start in 5 cm steps (to 3 m), then bisection in the step.
template <typename Touches>
double standingHeightFrom(IDynamicsModel& model, Eigen::VectorXd q, double start_z, const Touches& touches) {
  if (!model.info().floating_base)
    throw std::invalid_argument("standingBaseHeight needs a floating-base model");
  const Eigen::VectorXd v = Eigen::VectorXd::Zero(model.nv());
  ContactList contacts;
  auto touchesAt = [&](double z) {
    q[2] = z;
    model.setState(q, v);
    model.detectContacts(contacts);
    return touches(contacts);
  };
  double touching = start_z, free = start_z + kStandingRange_m;
  bool touched = false;
  auto bisect = [&] {
    for (int it = 0; it < 32; ++it) {
      const double mid = 0.5 * (touching + free);
      const bool t = touchesAt(mid);
      touched = touched || t;
      (t ? touching : free) = mid;
    }
  };
  bisect();
  if (touched) return free;
  for (free = start_z; free > start_z - kStandingRange_m; free -= kStandingStep_m)
    if (touchesAt(free - kStandingStep_m)) break;
  touching = free - kStandingStep_m;
  bisect();
  return free;
}

}  // namespace

double standingBaseHeight(IDynamicsModel& model, Eigen::VectorXd q) {
  return standingHeightFrom(model, std::move(q), 0.0, [](const ContactList& c) { return !c.empty(); });
}

double standingBaseHeightOnGround(IDynamicsModel& model, Eigen::VectorXd q) {
  const double start_z = model.environment().ground.heightAt(q[0], q[1]);
  return standingHeightFrom(model, std::move(q), start_z, [](const ContactList& contacts) {
    return std::any_of(contacts.begin(), contacts.end(),
                       [](const ContactCandidate& c) { return c.object == kGroundObject; });
  });
}

double standingContacts(IDynamicsModel& model, Eigen::VectorXd q, ContactList& contacts) {
  const double height = standingBaseHeight(model, q);
  q[2] = height - 1e-4;
  model.setState(q, Eigen::VectorXd::Zero(model.nv()));
  model.detectContacts(contacts);
  return height;
}

std::vector<StandingSole> standingSoles(const ContactList& contacts) {
  std::vector<StandingSole> soles;
  for (const ContactCandidate& c : contacts) {
    auto it = std::find_if(soles.begin(), soles.end(), [&](const StandingSole& s) { return s.body == c.body; });
    if (it == soles.end()) {
      soles.push_back(StandingSole{c.body, {}, Eigen::Vector3d::Zero()});
      it = soles.end() - 1;
    }
    it->points_B.push_back(c.p_BC);
  }
  for (StandingSole& s : soles) {
    for (const Eigen::Vector3d& p : s.points_B) s.centre_B += p;
    s.centre_B /= static_cast<double>(s.points_B.size());
  }
  std::sort(soles.begin(), soles.end(), [](const StandingSole& a, const StandingSole& b) { return a.body < b.body; });
  return soles;
}

}  // namespace dynfilter
