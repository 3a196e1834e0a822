// The retargeting mapping file (YAML): parsed with every error at its file, line and column.
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include "dynfilter/io/retarget.hpp"

namespace dynfilter::io {
namespace {


class MappingParser {
 public:
  explicit MappingParser(std::string source) : source_(std::move(source)) {}

  [[noreturn]] void fail(const YAML::Mark& mark, const std::string& reason) const {
    const int line = mark.is_null() ? 0 : mark.line + 1;
    const int column = mark.is_null() ? 0 : mark.column + 1;
    throw InputError(source_, line, column, reason);
  }

  static int lineOf(const YAML::Node& node) {
    const YAML::Mark m = node.Mark();
    return m.is_null() ? 0 : m.line + 1;
  }

  template <class Handler>
  void readMap(const YAML::Node& node, const std::string& what, const std::set<std::string>& keys,
               Handler&& handle) {
    if (!node.IsMap()) fail(node.Mark(), what + ": expected a map");
    std::set<std::string> seen;
    for (const auto& item : node) {
      if (!item.first.IsScalar()) fail(item.first.Mark(), what + ": keys must be plain names");
      const std::string key = item.first.Scalar();
      if (!keys.count(key)) fail(item.first.Mark(), what + ": unknown key \"" + key + "\"");
      if (!seen.insert(key).second)
        fail(item.first.Mark(), what + ": repeated key \"" + key + "\"");
      handle(key, item.second);
    }
  }

  std::string text(const YAML::Node& v, const std::string& key) const {
    if (!v.IsScalar() || v.Scalar().empty()) fail(v.Mark(), key + ": expected a name");
    return v.Scalar();
  }

  double number(const YAML::Node& v, const std::string& key) const {
    if (!v.IsScalar()) fail(v.Mark(), key + ": expected a number");
    const std::string& s = v.Scalar();
    char* end = nullptr;
    errno = 0;
    const double x = std::strtod(s.c_str(), &end);
    if (s.empty() || end != s.c_str() + s.size() || errno == ERANGE || !std::isfinite(x))
      fail(v.Mark(), key + ": not a finite number: \"" + s + "\"");
    return x;
  }

  int integer(const YAML::Node& v, const std::string& key) const {
    const double x = number(v, key);
    if (x != std::floor(x) || std::fabs(x) > 1e9) fail(v.Mark(), key + ": expected an integer");
    return static_cast<int>(x);
  }

  bool boolean(const YAML::Node& v, const std::string& key) const {
    if (v.IsScalar()) {
      const std::string& s = v.Scalar();
      if (s == "true") return true;
      if (s == "false") return false;
    }
    fail(v.Mark(), key + ": expected true or false");
  }

  Eigen::Vector3d vector3(const YAML::Node& v, const std::string& key) const {
    if (!v.IsSequence() || v.size() != 3) fail(v.Mark(), key + ": expected [x, y, z]");
    Eigen::Vector3d out;
    for (int i = 0; i < 3; ++i) out[i] = number(v[static_cast<std::size_t>(i)], key);
    if (out.norm() < 1e-12) fail(v.Mark(), key + ": zero vector");
    return out;
  }

  Eigen::Vector3d anyVector3(const YAML::Node& v, const std::string& key) const {
    if (!v.IsSequence() || v.size() != 3) fail(v.Mark(), key + ": expected [x, y, z]");
    Eigen::Vector3d out;
    for (int i = 0; i < 3; ++i) out[i] = number(v[static_cast<std::size_t>(i)], key);
    return out;
  }

  double weight(const YAML::Node& v, const std::string& key) const {
    const double x = number(v, key);
    if (x < 0) fail(v.Mark(), key + ": must be >= 0");
    return x;
  }

  std::vector<std::string> names(const YAML::Node& v, const std::string& key) const {
    if (!v.IsSequence() || v.size() == 0) fail(v.Mark(), key + ": expected a list of names");
    std::vector<std::string> out;
    for (const auto& item : v) out.push_back(text(item, key));
    return out;
  }

  RetargetMapping parse(const std::string& yaml_text) {
    YAML::Node root;
    try {
      root = YAML::Load(yaml_text);
    } catch (const YAML::Exception& e) {
      fail(e.mark, "YAML syntax error: " + e.msg);
    }
    RetargetMapping m;
    m.source = source_;
    if (!root.IsMap()) fail(root.Mark(), "expected a map of mapping options");
    bool have_segments = false;
    readMap(root, "mapping",
            {"length_scale", "skip_frames", "up_axis", "bvh_forward", "root", "segments",
             "ground_frames", "smoothing_window", "clamp_to_limits", "mode", "ik",
             "allow_unmapped", "cleanup", "flat_soles"},
            [&](const std::string& k, const YAML::Node& v) {
              if (k == "length_scale") {
                m.length_scale = number(v, k);
                if (!(m.length_scale > 0)) fail(v.Mark(), "length_scale: must be > 0");
              } else if (k == "skip_frames") {
                m.skip_frames = integer(v, k);
                if (m.skip_frames < 0) fail(v.Mark(), "skip_frames: must be >= 0");
              } else if (k == "up_axis" || k == "bvh_forward") {
                std::string axis = text(v, k);
                if (axis.size() == 1) axis = "+" + axis;
                if (axis.size() != 2 || (axis[0] != '+' && axis[0] != '-') ||
                    (axis[1] != 'x' && axis[1] != 'y' && axis[1] != 'z'))
                  fail(v.Mark(), k + ": expected one of +x, -x, +y, -y, +z, -z");
                (k == "up_axis" ? m.up_axis : m.bvh_forward) = axis;
                if (k == "bvh_forward") forward_mark_ = v.Mark();
              } else if (k == "root") {
                bool have_bvh = false;
                readMap(v, "root", {"bvh", "link", "position", "offset_xyz"},
                        [&](const std::string& rk, const YAML::Node& rv) {
                  if (rk == "bvh") {
                    m.root_bvh = text(rv, "root.bvh");
                    have_bvh = true;
                  }
                  if (rk == "link") m.root_link = text(rv, "root.link");
                  if (rk == "position") m.root_position = names(rv, "root.position");
                  if (rk == "offset_xyz") m.root_offset_xyz = anyVector3(rv, "root.offset_xyz");
                });
                if (!have_bvh) fail(v.Mark(), "root: missing key \"bvh\"");
              } else if (k == "segments") {
                have_segments = true;
                if (!v.IsSequence()) fail(v.Mark(), "segments: expected a list");
                std::set<std::string> links;
                for (const auto& item : v) {
                  RetargetSegment s;
                  s.line = lineOf(item);
                  readMap(item, "segment",
                          {"link", "bvh", "bone_end", "align", "figure_bone", "hinge_twist",
                           "flexion", "offset_xyz", "offset_rpy", "position_weight",
                           "orientation_weight"},
                          [&](const std::string& sk, const YAML::Node& sv) {
                            if (sk == "link") s.link = text(sv, sk);
                            if (sk == "bvh") s.bvh = text(sv, sk);
                            if (sk == "bone_end") s.bone_end = text(sv, sk);
                            if (sk == "align") s.align = boolean(sv, sk);
                            if (sk == "hinge_twist") s.hinge_twist = boolean(sv, sk);
                            if (sk == "figure_bone") s.figure_bone = vector3(sv, sk).normalized();
                            if (sk == "flexion") {
                              s.flexion = vector3(sv, sk).normalized();
                              s.has_flexion = true;
                            }
                            if (sk == "offset_xyz") s.offset_xyz = anyVector3(sv, sk);
                            if (sk == "offset_rpy") {
                              const Eigen::Vector3d rpy = anyVector3(sv, sk);
                              s.R_offset = (Eigen::AngleAxisd(rpy[2], Eigen::Vector3d::UnitZ()) *
                                            Eigen::AngleAxisd(rpy[1], Eigen::Vector3d::UnitY()) *
                                            Eigen::AngleAxisd(rpy[0], Eigen::Vector3d::UnitX()))
                                               .toRotationMatrix();
                            }
                            if (sk == "position_weight") s.position_weight = weight(sv, sk);
                            if (sk == "orientation_weight") s.orientation_weight = weight(sv, sk);
                          });
                  if (s.link.empty()) fail(item.Mark(), "segment: missing key \"link\"");
                  if (s.bvh.empty()) fail(item.Mark(), "segment: missing key \"bvh\"");
                  if (!links.insert(s.link).second)
                    fail(item.Mark(), "segment: link \"" + s.link + "\" mapped twice");
                  m.segments.push_back(s);
                }
              } else if (k == "ground_frames") {
                m.ground_frames = integer(v, k);
                if (m.ground_frames < 1) fail(v.Mark(), "ground_frames: must be >= 1");
              } else if (k == "smoothing_window") {
                m.smoothing_window = integer(v, k);
                if (m.smoothing_window < 3 || m.smoothing_window % 2 == 0)
                  fail(v.Mark(), "smoothing_window: must be odd and >= 3");
              } else if (k == "clamp_to_limits") {
                m.clamp_to_limits = boolean(v, k);
              } else if (k == "allow_unmapped") {
                m.allow_unmapped = boolean(v, k);
              } else if (k == "flat_soles") {
                m.flat_soles = boolean(v, k);
              } else if (k == "mode") {
                const std::string mode = text(v, k);
                if (mode == "chain") m.mode = RetargetMode::kChain;
                else if (mode == "ik") m.mode = RetargetMode::kIk;
                else fail(v.Mark(), "mode: expected chain or ik, got \"" + mode + "\"");
              } else if (k == "ik") {
                readMap(v, "ik", {"scale", "scaling", "max_iterations", "posture_weight"},
                        [&](const std::string& ik, const YAML::Node& iv) {
                  if (ik == "scaling") {
                    const std::string scaling = text(iv, "ik.scaling");
                    if (scaling == "limbs") m.ik.limb_scaling = true;
                    else if (scaling == "uniform") m.ik.limb_scaling = false;
                    else fail(iv.Mark(), "ik.scaling: expected limbs or uniform, got \"" + scaling + "\"");
                  }
                  if (ik == "scale") {
                    m.ik.scale = number(iv, "ik.scale");
                    if (m.ik.scale < 0) fail(iv.Mark(), "ik.scale: must be >= 0 (0: auto)");
                  }
                  if (ik == "max_iterations") {
                    m.ik.max_iterations = integer(iv, "ik.max_iterations");
                    if (m.ik.max_iterations < 1) fail(iv.Mark(), "ik.max_iterations: must be >= 1");
                  }
                  if (ik == "posture_weight") m.ik.posture_weight = weight(iv, "ik.posture_weight");
                });
              } else if (k == "cleanup") {
                ReferenceCleanupOptions& c = m.cleanup;
                readMap(v, "cleanup",
                        {"feet", "contact_height", "contact_speed", "min_phase_s",
                         "base_weight", "posture_weight", "leg_weight", "continuity_weight", "lowpass_hz", "balance",
                         "zmp_margin_m", "balance_iterations", "max_com_shift_m"},
                        [&](const std::string& ck, const YAML::Node& cv) {
                  const std::string key = "cleanup." + ck;
                  if (ck == "feet") c.feet = names(cv, key);
                  if (ck == "contact_height") c.contact_height = number(cv, key);
                  if (ck == "contact_speed") c.contact_speed = number(cv, key);
                  if (ck == "min_phase_s") c.min_phase_s = number(cv, key);
                  if (ck == "base_weight") c.base_weight = weight(cv, key);
                  if (ck == "posture_weight") c.posture_weight = weight(cv, key);
                  if (ck == "leg_weight") c.leg_weight = weight(cv, key);
                  if (ck == "continuity_weight") c.continuity_weight = number(cv, key);
                  if (ck == "lowpass_hz") c.lowpass_hz = number(cv, key);
                  if (ck == "balance") c.balance = boolean(cv, key);
                  if (ck == "zmp_margin_m") c.zmp_margin_m = number(cv, key);
                  if (ck == "balance_iterations") c.balance_iterations = integer(cv, key);
                  if (ck == "max_com_shift_m") c.max_com_shift_m = number(cv, key);
                  try {
                    c.validate();
                  } catch (const std::invalid_argument& e) {
                    fail(cv.Mark(), e.what());
                  }
                });
              }
            });
    if (!have_segments) fail(root.Mark(), "missing key \"segments\"");
    try {
      m.axisConversion();
    } catch (const std::invalid_argument& e) {
      fail(forward_mark_, e.what());
    }
    return m;
  }

 private:
  std::string source_;
  YAML::Mark forward_mark_ = YAML::Mark::null_mark();
};

Eigen::Vector3d axisVector(const std::string& axis) {
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  v[axis[1] - 'x'] = axis[0] == '-' ? -1.0 : 1.0;
  return v;
}

}  // namespace

Eigen::Matrix3d RetargetMapping::axisConversion() const {
  const Eigen::Vector3d up = axisVector(up_axis);
  const Eigen::Vector3d fwd = axisVector(bvh_forward);
  if (std::fabs(up.dot(fwd)) > 0.5)
    throw std::invalid_argument("bvh_forward \"" + bvh_forward +
                                "\" is along up_axis \"" + up_axis + "\"");
  Eigen::Matrix3d R;
  R.row(0) = fwd.transpose();
  R.row(1) = up.cross(fwd).transpose();  // left = up × forward
  R.row(2) = up.transpose();
  return R;
}

RetargetMapping parseRetargetMapping(const std::string& yaml_text, const std::string& source) {
  return MappingParser(source).parse(yaml_text);
}

RetargetMapping readRetargetMapping(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, std::string("cannot open: ") + std::strerror(errno));
  std::ostringstream ss;
  ss << in.rdbuf();
  return parseRetargetMapping(ss.str(), path);
}

}  // namespace dynfilter::io
