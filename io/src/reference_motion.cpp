#include "dynfilter/io/reference_motion.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string_view>
#include <unordered_map>
#include <unordered_set>

#include <Eigen/Geometry>
#include <Eigen/QR>

#include "csv.hpp"
#include "dynfilter/core/lie_group.hpp"

namespace dynfilter::io {
namespace {

using detail::NumberStatus;

// A base quaternion whose norm is 1 to within this is kept bit for bit (so that files
// written by FilteredMotionWriter read back exactly); anything further off, up to the
// tolerance of the options, is normalised.
constexpr double kExactUnitNorm = 1e-14;

// Where a column's value goes.
enum class Target { kTime, kQ, kV, kA, kIgnore };

enum class Group { kTime, kBase, kJoint, kVelocity, kAcceleration, kExtra };

struct ColumnRole {
  Target target = Target::kIgnore;
  int index = 0;  // in q, v or vdot
  Group group = Group::kExtra;
  bool base = false;  // a base column (must be absent for a fixed base)
};

// Every column name the format knows for this model, with its role.
std::unordered_map<std::string, ColumnRole> knownColumns(const std::string& path,
                                                         const ModelInfo& info) {
  std::unordered_map<std::string, ColumnRole> known;
  auto add = [&](const std::string& name, ColumnRole role) {
    if (!known.emplace(name, role).second)
      throw InputError(path, 0,
                       "model \"" + info.name + "\": joint column " + detail::quoted(name) +
                           " clashes with another column of the format");
  };
  add(detail::kTimeColumn, {Target::kTime, 0, Group::kTime, false});
  for (int i = 0; i < 3; ++i)
    add(detail::kBasePositionColumns[static_cast<std::size_t>(i)],
        {Target::kQ, i, Group::kBase, true});
  for (int i = 0; i < 4; ++i)
    add(detail::kBaseQuaternionColumns[static_cast<std::size_t>(i)],
        {Target::kQ, 3 + i, Group::kBase, true});
  for (int i = 0; i < 6; ++i) {
    add(detail::kBaseVelocityColumns[static_cast<std::size_t>(i)],
        {Target::kV, i, Group::kVelocity, true});
    add(detail::kBaseAccelerationColumns[static_cast<std::size_t>(i)],
        {Target::kA, i, Group::kAcceleration, true});
  }
  for (int j = 0; j < info.nj; ++j) {
    const std::string& name = info.joint_names[static_cast<std::size_t>(j)];
    add(name, {Target::kQ, info.configurationIndex(j), Group::kJoint, false});
    add(name + detail::kVelocitySuffix, {Target::kV, info.velocityIndex(j), Group::kVelocity, false});
    add(name + detail::kAccelerationSuffix,
        {Target::kA, info.velocityIndex(j), Group::kAcceleration, false});
  }
  return known;
}

// Names of the velocity (or acceleration) columns of the model, in v order.
std::vector<std::string> derivativeColumns(const ModelInfo& info, bool acceleration) {
  std::vector<std::string> names;
  if (info.floating_base)
    for (const char* name :
         acceleration ? detail::kBaseAccelerationColumns : detail::kBaseVelocityColumns)
      names.emplace_back(name);
  for (const std::string& joint : info.joint_names)
    names.push_back(joint + (acceleration ? detail::kAccelerationSuffix : detail::kVelocitySuffix));
  return names;
}

}  // namespace

void ReferenceReadOptions::validate() const {
  if (smoothing_window < 3 || smoothing_window % 2 == 0)
    throw std::invalid_argument("ReferenceReadOptions::smoothing_window must be odd and >= 3, got " +
                                std::to_string(smoothing_window));
  if (!(quaternion_tolerance > 0.0 && quaternion_tolerance < 1.0))
    throw std::invalid_argument("ReferenceReadOptions::quaternion_tolerance must be in (0, 1)");
}

ReferenceMotion readReferenceMotion(const std::string& path, const ModelInfo& info,
                                    const ReferenceReadOptions& options) {
  options.validate();
  const std::unordered_map<std::string, ColumnRole> known = knownColumns(path, info);
  std::unordered_set<std::string> locked;
  for (const std::string& joint : info.locked_joint_names)
    for (const char* suffix : {"", detail::kVelocitySuffix, detail::kAccelerationSuffix})
      locked.insert(joint + suffix);

  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    const int err = errno;
    throw InputError(path, 0,
                     std::string("cannot open file") + (err != 0 ? ": " + std::string(std::strerror(err)) : ""));
  }

  ReferenceMotion motion;
  motion.source = path;

  std::vector<ColumnRole> roles;           // per column
  std::vector<std::string> header;         // per column
  int header_line = 0;
  int time_column = -1;                    // 0-based
  int quat_column = -1;                    // 0-based column of base_qw
  std::vector<std::string> fields;
  std::size_t count = 0, bad = 0;
  std::string line;
  int line_no = 0;
  int last_frame_line = 0;
  std::vector<int> frame_lines;            // per frame

  while (std::getline(in, line)) {
    ++line_no;
    std::string_view text(line);
    if (!text.empty() && text.back() == '\r') text.remove_suffix(1);
    if (line_no == 1 && text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);
    const std::string_view trimmed = detail::trim(text);
    if (trimmed.empty() || trimmed.front() == '#') continue;

    if (!detail::splitCsvLine(text, fields, count, bad))
      throw InputError(path, line_no, static_cast<int>(bad) + 1, "malformed quoted field");

    if (header_line == 0) {
      // ---------------------------------------------------------------- header
      header_line = line_no;
      std::unordered_map<std::string, int> seen;
      for (std::size_t c = 0; c < count; ++c) {
        const std::string& name = fields[c];
        const int column = static_cast<int>(c) + 1;
        if (name.empty()) throw InputError(path, line_no, column, "empty column name");
        const auto [it, inserted] = seen.emplace(name, column);
        if (!inserted)
          throw InputError(path, line_no, column,
                           "duplicate column " + detail::quoted(name) + " (also column " +
                               std::to_string(it->second) + ")");
        const auto role = known.find(name);
        if (role == known.end()) {
          if (locked.count(name) != 0) motion.ignored_columns.push_back(name);
          else if (!options.allow_extra_columns)
            throw InputError(path, line_no, column, "unknown column " + detail::quoted(name));
          roles.push_back(ColumnRole{});
        } else {
          if (role->second.base && !info.floating_base)
            throw InputError(path, line_no, column,
                             "column " + detail::quoted(name) + " is a base column but model \"" +
                                 info.name + "\" has a fixed base");
          roles.push_back(role->second);
          if (role->second.target == Target::kTime) time_column = static_cast<int>(c);
          if (name == detail::kBaseQuaternionColumns[0]) quat_column = static_cast<int>(c);
        }
        header.push_back(name);
      }
      // Required columns, in a fixed order so that the first missing one is named.
      std::vector<std::string> required{detail::kTimeColumn};
      if (info.floating_base) {
        for (const char* name : detail::kBasePositionColumns) required.emplace_back(name);
        for (const char* name : detail::kBaseQuaternionColumns) required.emplace_back(name);
      }
      for (const std::string& joint : info.joint_names) required.push_back(joint);
      for (const std::string& name : required)
        if (seen.count(name) == 0)
          throw InputError(path, line_no, "missing column " + detail::quoted(name));
      // Velocities and accelerations: all or none.
      for (const bool acceleration : {false, true}) {
        const std::vector<std::string> names = derivativeColumns(info, acceleration);
        std::size_t present = 0;
        for (const std::string& name : names) present += seen.count(name);
        if (present == 0) continue;
        if (present < names.size()) {
          for (const std::string& name : names)
            if (seen.count(name) == 0)
              throw InputError(path, line_no,
                               std::string("incomplete ") +
                                   (acceleration ? "acceleration" : "velocity") +
                                   " columns: missing " + detail::quoted(name) + " (give all " +
                                   std::to_string(names.size()) + " or none)");
        }
        (acceleration ? motion.had_accelerations : motion.had_velocities) = true;
      }
      continue;
    }

    // ------------------------------------------------------------------ data row
    if (count != roles.size())
      throw InputError(path, line_no,
                       "expected " + std::to_string(roles.size()) + " fields, found " +
                           std::to_string(count));
    ReferenceFrame frame(info.nq, info.nv);
    for (std::size_t c = 0; c < count; ++c) {
      const ColumnRole& role = roles[c];
      if (role.target == Target::kIgnore) continue;
      double value = 0.0;
      const NumberStatus status = detail::parseDouble(fields[c], value);
      if (status != NumberStatus::kOk)
        throw InputError(path, line_no, static_cast<int>(c) + 1,
                         "column " + detail::quoted(header[c]) + ": " + detail::describe(status) + ": " +
                             detail::quoted(fields[c]));
      switch (role.target) {
        case Target::kTime: frame.time_s = value; break;
        case Target::kQ: frame.q[role.index] = value; break;
        case Target::kV: frame.v[role.index] = value; break;
        case Target::kA: frame.vdot[role.index] = value; break;
        case Target::kIgnore: break;
      }
    }
    if (!motion.frames.empty() && !(frame.time_s > motion.frames.back().time_s)) {
      std::string message = "time ";
      detail::appendDouble(message, frame.time_s);
      message += " s is not after the previous frame's ";
      detail::appendDouble(message, motion.frames.back().time_s);
      message += " s (line " + std::to_string(last_frame_line) + ")";
      throw InputError(path, line_no, time_column + 1, message);
    }
    if (info.floating_base) {
      auto quat = frame.q.segment<4>(3);
      const double norm = quat.norm();
      if (!(std::abs(norm - 1.0) <= options.quaternion_tolerance)) {
        std::string message = "base quaternion norm ";
        detail::appendDouble(message, norm);
        message += " differs from 1 by more than ";
        detail::appendDouble(message, options.quaternion_tolerance);
        throw InputError(path, line_no, quat_column + 1, message);
      }
      if (std::abs(norm - 1.0) > kExactUnitNorm) quat /= norm;
    }
    motion.frames.push_back(std::move(frame));
    last_frame_line = line_no;
    frame_lines.push_back(line_no);
  }
  if (in.bad()) throw InputError(path, 0, "read error");
  if (header_line == 0)
    throw InputError(path, 0, "empty file: no header line (only comments or blank lines)");
  if (motion.frames.size() < 2)
    throw InputError(path, motion.frames.empty() ? header_line : last_frame_line,
                     "a reference motion needs at least 2 frames, found " +
                         std::to_string(motion.frames.size()));

  if (!motion.had_velocities || !motion.had_accelerations) {
    estimateDerivatives(motion.frames, info.floating_base, options.smoothing_window,
                        !motion.had_velocities, !motion.had_accelerations);
    // Finite numbers can still be too close together (a time step whose square
    // underflows) or too far apart (a difference that overflows) for the fit.
    for (std::size_t k = 0; k < motion.frames.size(); ++k)
      if (!motion.frames[k].v.allFinite() || !motion.frames[k].vdot.allFinite())
        throw InputError(path, frame_lines[k],
                         "the estimated velocity or acceleration of this frame is not finite "
                         "(time steps or values too small or too large for the fit)");
  }
  return motion;
}

void estimateDerivatives(std::vector<ReferenceFrame>& frames, bool floating_base,
                         int smoothing_window, bool fill_velocities, bool fill_accelerations) {
  if (smoothing_window < 3 || smoothing_window % 2 == 0)
    throw std::invalid_argument("estimateDerivatives: smoothing_window must be odd and >= 3");
  const int n = static_cast<int>(frames.size());
  if (n < 2) throw std::invalid_argument("estimateDerivatives: needs at least 2 frames");
  const int nq = static_cast<int>(frames.front().q.size());
  const int nb = floating_base ? kFloatingBaseNv : 0;
  const int nj = nq - (floating_base ? kFloatingBaseNq : 0);
  if (nj < 0) throw std::invalid_argument("estimateDerivatives: q too short for a floating base");
  const int nv = nb + nj;
  for (int k = 0; k < n; ++k) {
    const ReferenceFrame& f = frames[static_cast<std::size_t>(k)];
    if (f.q.size() != nq)
      throw std::invalid_argument("estimateDerivatives: frames differ in the size of q");
    if (k > 0 && !(f.time_s > frames[static_cast<std::size_t>(k - 1)].time_s))
      throw std::invalid_argument("estimateDerivatives: time must increase strictly");
  }
  if (!fill_velocities && !fill_accelerations) return;

  std::vector<Eigen::Isometry3d> poses;
  if (floating_base) {
    poses.reserve(static_cast<std::size_t>(n));
    for (const ReferenceFrame& f : frames) poses.push_back(basePoseFromConfiguration(f.q));
  }

  const int m = std::min(smoothing_window, n);  // frames per fit
  const int degree = std::min(2, m - 1);
  const int half = smoothing_window / 2;
  Eigen::MatrixXd A(m, degree + 1), Y(m, nv), C(degree + 1, nv);
  Eigen::HouseholderQR<Eigen::MatrixXd> qr(m, degree + 1);

  for (int k = 0; k < n; ++k) {
    const int lo = std::clamp(k - half, 0, n - m);
    const double t_k = frames[static_cast<std::size_t>(k)].time_s;
    // τ is scaled into [−1, 1] so that the least-squares problem is well conditioned.
    const double scale = std::max(t_k - frames[static_cast<std::size_t>(lo)].time_s,
                                  frames[static_cast<std::size_t>(lo + m - 1)].time_s - t_k);
    Eigen::Isometry3d X_kW = Eigen::Isometry3d::Identity();
    if (floating_base) X_kW = poses[static_cast<std::size_t>(k)].inverse();
    for (int r = 0; r < m; ++r) {
      const ReferenceFrame& f = frames[static_cast<std::size_t>(lo + r)];
      const double tau = (f.time_s - t_k) / scale;
      A(r, 0) = 1.0;
      A(r, 1) = tau;
      if (degree == 2) A(r, 2) = tau * tau;
      if (floating_base)
        Y.row(r).head<6>() = logSE3(X_kW * poses[static_cast<std::size_t>(lo + r)]).transpose();
      Y.row(r).tail(nj) = f.q.tail(nj).transpose();
    }
    qr.compute(A);
    C = qr.solve(Y);
    ReferenceFrame& out = frames[static_cast<std::size_t>(k)];
    if (fill_velocities) out.v = C.row(1).transpose() / scale;
    if (fill_accelerations) {
      if (degree == 2)
        out.vdot = (2.0 / (scale * scale)) * C.row(2).transpose();
      else
        out.vdot = Eigen::VectorXd::Zero(nv);
    }
  }
}

void lowPassConfigurations(std::vector<ReferenceFrame>& frames, bool floating_base, double cutoff_hz) {
  if (!(cutoff_hz > 0) || !std::isfinite(cutoff_hz))
    throw std::invalid_argument("lowPassConfigurations: cutoff_hz must be > 0");
  const int n = static_cast<int>(frames.size());
  if (n < 3) return;
  const Eigen::Index nq = frames.front().q.size();
  for (const ReferenceFrame& f : frames)
    if (f.q.size() != nq) throw std::invalid_argument("lowPassConfigurations: frames differ in the size of q");
  const double sigma = 0.1325 / cutoff_hz;
  const std::vector<ReferenceFrame> in = frames;
  const int b0 = floating_base ? kFloatingBaseNq : 0;  // first joint coordinate
  for (int k = 0; k < n; ++k) {
    const double t = in[static_cast<std::size_t>(k)].time_s;
    int lo = k, hi = k;
    while (lo > 0 && t - in[static_cast<std::size_t>(lo - 1)].time_s <= 3.0 * sigma) --lo;
    while (hi + 1 < n && in[static_cast<std::size_t>(hi + 1)].time_s - t <= 3.0 * sigma) ++hi;
    Eigen::VectorXd sum = Eigen::VectorXd::Zero(nq);
    Eigen::Vector3d rot = Eigen::Vector3d::Zero();
    double weight = 0.0;
    Eigen::Matrix3d R_k = Eigen::Matrix3d::Identity();
    if (floating_base) R_k = basePoseFromConfiguration(in[static_cast<std::size_t>(k)].q).linear();
    for (int j = lo; j <= hi; ++j) {
      const ReferenceFrame& f = in[static_cast<std::size_t>(j)];
      const double d = (f.time_s - t) / sigma;
      const double w = std::exp(-0.5 * d * d);
      weight += w;
      sum += w * f.q;
      if (floating_base) rot += w * logSO3(R_k.transpose() * basePoseFromConfiguration(f.q).linear());
    }
    Eigen::VectorXd& q = frames[static_cast<std::size_t>(k)].q;
    q.tail(nq - b0) = sum.tail(nq - b0) / weight;
    if (floating_base) {
      q.head<3>() = sum.head<3>() / weight;
      const Eigen::Quaterniond Q(R_k * expSO3(rot / weight));
      q.segment<4>(3) << Q.w(), Q.x(), Q.y(), Q.z();
    }
  }
}

}  // namespace dynfilter::io
