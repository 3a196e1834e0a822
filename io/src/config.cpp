#include "dynfilter/io/config.hpp"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <initializer_list>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include "csv.hpp"

namespace dynfilter::io {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

// One value in the document: its node, where it is, and its key path ("task.p_BP").
struct Entry {
  YAML::Node node;
  YAML::Mark mark;
  std::string path;
};

class Parser {
 public:
  explicit Parser(const std::string& source) : source_(source) {}

  [[noreturn]] void fail(const YAML::Mark& mark, const std::string& path,
                         const std::string& reason) const {
    const int line = mark.is_null() ? 0 : mark.line + 1;
    const int column = mark.is_null() ? 0 : mark.column + 1;
    throw InputError(source_, line, column, path.empty() ? reason : path + ": " + reason);
  }

  static std::string describe(const YAML::Node& node) {
    switch (node.Type()) {
      case YAML::NodeType::Null: return "nothing";
      case YAML::NodeType::Scalar: return "\"" + node.Scalar() + "\"";
      case YAML::NodeType::Sequence: return "a sequence";
      case YAML::NodeType::Map: return "a map";
      default: return "an undefined node";
    }
  }

  // Calls handle(key, entry) for every key of a map; rejects unknown and duplicate keys.
  // A null node (an empty section such as "feedback:") stands for an empty map.
  template <class Handler>
  void readMap(const Entry& map, std::initializer_list<const char*> keys, Handler&& handle) {
    if (map.node.IsNull()) return;
    if (!map.node.IsMap()) fail(map.mark, map.path, "expected a map, got " + describe(map.node));
    std::set<std::string> seen;
    for (const auto& item : map.node) {
      const YAML::Node& key = item.first;
      const YAML::Mark key_mark = key.Mark();
      if (!key.IsScalar()) fail(key_mark, map.path, "keys must be plain names");
      const std::string& name = key.Scalar();
      const std::string path = map.path.empty() ? name : map.path + "." + name;
      if (!seen.insert(name).second) fail(key_mark, path, "duplicate key");
      bool known = false;
      std::string list;
      for (const char* k : keys) {
        known = known || name == k;
        list += list.empty() ? k : std::string(", ") + k;
      }
      if (!known) fail(key_mark, path, "unknown key (known here: " + list + ")");
      marks_[path] = key_mark;
      const YAML::Node value = item.second;
      const YAML::Mark value_mark = value.Mark();
      handle(name, Entry{value, value_mark.is_null() ? key_mark : value_mark, path});
    }
  }

  double number(const Entry& e) const {
    double x = 0.0;
    if (!e.node.IsScalar() || detail::parseDouble(e.node.Scalar(), x) != detail::NumberStatus::kOk)
      fail(e.mark, e.path, "expected a finite number, got " + describe(e.node));
    return x;
  }

  int integer(const Entry& e) const {
    double x = 0.0;
    if (!e.node.IsScalar() ||
        detail::parseDouble(e.node.Scalar(), x) != detail::NumberStatus::kOk ||
        x != std::floor(x) || std::abs(x) > 1e9)
      fail(e.mark, e.path, "expected an integer, got " + describe(e.node));
    return static_cast<int>(x);
  }

  bool boolean(const Entry& e) const {
    if (e.node.IsScalar()) {
      const std::string& s = e.node.Scalar();
      if (s == "true" || s == "True" || s == "TRUE") return true;
      if (s == "false" || s == "False" || s == "FALSE") return false;
    }
    fail(e.mark, e.path, "expected true or false, got " + describe(e.node));
  }

  std::string text(const Entry& e) const {
    if (!e.node.IsScalar()) fail(e.mark, e.path, "expected a string, got " + describe(e.node));
    return e.node.Scalar();
  }

  Eigen::Vector3d vector3(const Entry& e) const {
    if (!e.node.IsSequence())
      fail(e.mark, e.path, "expected a sequence of 3 numbers, got " + describe(e.node));
    if (e.node.size() != 3)
      fail(e.mark, e.path,
           "expected a sequence of 3 numbers, got " + std::to_string(e.node.size()));
    Eigen::Vector3d v;
    for (std::size_t i = 0; i < 3; ++i) {
      const YAML::Node element = e.node[i];
      const YAML::Mark mark = element.Mark();
      v[static_cast<Eigen::Index>(i)] =
          number(Entry{element, mark.is_null() ? e.mark : mark,
                       e.path + "[" + std::to_string(i) + "]"});
    }
    return v;
  }

  void readFeedback(const Entry& e, JointFeedbackGains& g) {
    readMap(e,
            {"base_linear_kp", "base_linear_kd", "base_angular_kp", "base_angular_kd",
             "joint_kp", "joint_kd"},
            [&](const std::string& k, const Entry& v) {
              if (k == "base_linear_kp") g.base_linear_kp = number(v);
              if (k == "base_linear_kd") g.base_linear_kd = number(v);
              if (k == "base_angular_kp") g.base_angular_kp = number(v);
              if (k == "base_angular_kd") g.base_angular_kd = number(v);
              if (k == "joint_kp") g.joint_kp = number(v);
              if (k == "joint_kd") g.joint_kd = number(v);
            });
  }

  void readTask(const Entry& e, TaskPointOptions& t) {
    readMap(e,
            {"enabled", "body", "p_BP", "kp_linear", "kd_linear", "kp_angular", "kd_angular",
             "as_constraint_rows", "joint_weight"},
            [&](const std::string& k, const Entry& v) {
              if (k == "enabled") t.enabled = boolean(v);
              if (k == "body") t.body = text(v);
              if (k == "p_BP") t.p_BP = vector3(v);
              if (k == "kp_linear") t.kp_linear = number(v);
              if (k == "kd_linear") t.kd_linear = number(v);
              if (k == "kp_angular") t.kp_angular = number(v);
              if (k == "kd_angular") t.kd_angular = number(v);
              if (k == "as_constraint_rows") t.as_constraint_rows = boolean(v);
              if (k == "joint_weight") t.joint_weight = number(v);
            });
  }

  void readContacts(const Entry& e, ContactOptions& c) {
    readMap(e,
            {"max_links", "stabilization_kp", "stabilization_kd", "merge_distance_m",
             "release_force_n", "release_ticks", "reengage_depth_m",
             "initial_penetration_tolerance_m", "plastic_impact"},
            [&](const std::string& k, const Entry& v) {
              if (k == "max_links") c.max_links = integer(v);
              if (k == "stabilization_kp") c.stabilization_kp = number(v);
              if (k == "stabilization_kd") c.stabilization_kd = number(v);
              if (k == "merge_distance_m") c.merge_distance_m = number(v);
              if (k == "release_force_n") c.release_force_n = number(v);
              if (k == "release_ticks") c.release_ticks = integer(v);
              if (k == "reengage_depth_m") c.reengage_depth_m = number(v);
              if (k == "initial_penetration_tolerance_m")
                c.initial_penetration_tolerance_m = number(v);
              if (k == "plastic_impact") c.plastic_impact = boolean(v);
            });
  }

  void readSolver(const Entry& e, PaperSolverOptions& s) {
    readMap(e, {"accel_weight", "force_weight", "sr_damping"},
            [&](const std::string& k, const Entry& v) {
              if (k == "accel_weight") s.accel_weight = number(v);
              if (k == "force_weight") s.force_weight = number(v);
              if (k == "sr_damping") s.sr_damping = number(v);
            });
  }

  void readDivergence(const Entry& e, DivergenceOptions& d) {
    readMap(e,
            {"max_base_error_m", "max_base_rotation_rad", "max_joint_error_rad",
             "max_base_residual_rel", "max_degraded_ticks"},
            [&](const std::string& k, const Entry& v) {
              if (k == "max_base_error_m") d.max_base_error_m = number(v);
              if (k == "max_base_rotation_rad") d.max_base_rotation_rad = number(v);
              if (k == "max_joint_error_rad") d.max_joint_error_rad = number(v);
              if (k == "max_base_residual_rel") d.max_base_residual_rel = number(v);
              if (k == "max_degraded_ticks") d.max_degraded_ticks = integer(v);
            });
  }

  void readLeash(const Entry& e, LeashOptions& l) {
    readMap(e, {"enabled", "max_offset_m", "max_heading_rad"}, [&](const std::string& k, const Entry& v) {
      if (k == "enabled") l.enabled = boolean(v);
      if (k == "max_offset_m") l.max_offset_m = number(v);
      if (k == "max_heading_rad") l.max_heading_rad = number(v);
    });
  }

  void readBalance(const Entry& e, BalanceOptions& b) {
    readMap(e,
            {"enabled", "com_weight", "dcm_gain", "height_kp", "height_kd",
             "angular_momentum_damping", "angular_momentum_weight", "preview_s",
             "preview_capacity", "stance_height_m", "stance_speed_mps", "sole_weight", "sole_kp",
             "sole_kd", "sole_margin_m", "flat_landing_max_tilt_rad", "roll_tilt_rad"},
            [&](const std::string& k, const Entry& v) {
              if (k == "enabled") b.enabled = boolean(v);
              if (k == "com_weight") b.com_weight = number(v);
              if (k == "dcm_gain") b.dcm_gain = number(v);
              if (k == "height_kp") b.height_kp = number(v);
              if (k == "height_kd") b.height_kd = number(v);
              if (k == "angular_momentum_damping") b.angular_momentum_damping = number(v);
              if (k == "angular_momentum_weight") b.angular_momentum_weight = number(v);
              if (k == "preview_s") b.preview_s = number(v);
              if (k == "preview_capacity") b.preview_capacity = integer(v);
              if (k == "stance_height_m") b.stance_height_m = number(v);
              if (k == "stance_speed_mps") b.stance_speed_mps = number(v);
              if (k == "sole_weight") b.sole_weight = number(v);
              if (k == "sole_kp") b.sole_kp = number(v);
              if (k == "sole_kd") b.sole_kd = number(v);
              if (k == "sole_margin_m") b.sole_margin_m = number(v);
              if (k == "flat_landing_max_tilt_rad") b.flat_landing_max_tilt_rad = number(v);
              if (k == "roll_tilt_rad") b.roll_tilt_rad = number(v);
            });
  }

  void readQp(const Entry& e, QpModeOptions& q) {
    readMap(e,
            {"accel_weight", "force_weight", "torque_weight", "min_normal_force_n",
             "friction_facets", "cop_margin_m", "liftoff_clearance_m", "release_transition_s",
             "joint_limit_horizon_s", "joint_limit_max_decel", "enforce_torque_limits", "enforce_joint_limits", "yaw_slip",
             "tangential_slip",
             "eps_abs", "max_iterations", "warm_start", "engine"},
            [&](const std::string& k, const Entry& v) {
              if (k == "accel_weight") q.accel_weight = number(v);
              if (k == "force_weight") q.force_weight = number(v);
              if (k == "torque_weight") q.torque_weight = number(v);
              if (k == "min_normal_force_n") q.min_normal_force_n = number(v);
              if (k == "friction_facets") q.friction_facets = integer(v);
              if (k == "cop_margin_m") q.cop_margin_m = number(v);
              if (k == "liftoff_clearance_m") q.liftoff_clearance_m = number(v);
              if (k == "release_transition_s") q.release_transition_s = number(v);
              if (k == "joint_limit_horizon_s") q.joint_limit_horizon_s = number(v);
              if (k == "joint_limit_max_decel") q.joint_limit_max_decel = number(v);
              if (k == "enforce_torque_limits") q.enforce_torque_limits = boolean(v);
              if (k == "enforce_joint_limits") q.enforce_joint_limits = boolean(v);
              if (k == "yaw_slip") q.yaw_slip = boolean(v);
              if (k == "tangential_slip") q.tangential_slip = boolean(v);
              if (k == "eps_abs") q.solver.eps_abs = number(v);
              if (k == "max_iterations") q.solver.max_iterations = integer(v);
              if (k == "warm_start") q.solver.warm_start = boolean(v);
              if (k == "engine") q.solver.engine = text(v);
            });
  }

  void readGround(const Entry& e, Environment& env) {
    if (e.node.IsScalar() && e.node.Scalar() == "none") {
      env.has_ground = false;
      return;
    }
    if (!e.node.IsMap()) fail(e.mark, e.path, "expected a map or none, got " + describe(e.node));
    const GroundPlane defaults;
    double slope_deg = 0.0, heading_deg = 0.0, height_m = 0.0, friction = defaults.friction;
    readMap(e, {"slope_deg", "heading_deg", "height_m", "friction"},
            [&](const std::string& k, const Entry& v) {
              if (k == "slope_deg") slope_deg = number(v);
              if (k == "heading_deg") heading_deg = number(v);
              if (k == "height_m") height_m = number(v);
              if (k == "friction") friction = number(v);
            });
    env.has_ground = true;
    env.ground = GroundPlane::sloped(slope_deg * kDegToRad, heading_deg * kDegToRad, height_m,
                                     friction);
  }

  void readBox(const Entry& e, EnvironmentBox& box) {
    if (!e.node.IsMap()) fail(e.mark, e.path, "expected a map, got " + describe(e.node));
    Eigen::Vector3d position = box.X_WO.translation();
    Eigen::Vector3d rpy_deg = Eigen::Vector3d::Zero();
    readMap(e, {"name", "size_m", "position_m", "rpy_deg", "friction"},
            [&](const std::string& k, const Entry& v) {
              if (k == "name") box.name = text(v);
              if (k == "size_m") box.size_m = vector3(v);
              if (k == "position_m") position = vector3(v);
              if (k == "rpy_deg") rpy_deg = vector3(v);
              if (k == "friction") box.friction = number(v);
            });
    const Eigen::Vector3d rpy = rpy_deg * kDegToRad;
    box.X_WO = Eigen::Isometry3d::Identity();
    box.X_WO.linear() = (Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) *
                         Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
                         Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()))
                            .toRotationMatrix();
    box.X_WO.translation() = position;
  }

  void readEnvironment(const Entry& e, Environment& env) {
    readMap(e, {"ground", "boxes"}, [&](const std::string& k, const Entry& v) {
      if (k == "ground") readGround(v, env);
      if (k == "boxes") {
        env.boxes.clear();
        if (v.node.IsNull()) return;
        if (!v.node.IsSequence())
          fail(v.mark, v.path, "expected a sequence of boxes, got " + describe(v.node));
        for (std::size_t i = 0; i < v.node.size(); ++i) {
          const YAML::Node element = v.node[i];
          const YAML::Mark mark = element.Mark();
          const Entry box{element, mark.is_null() ? v.mark : mark,
                          v.path + "[" + std::to_string(i) + "]"};
          marks_[box.path] = box.mark;
          env.boxes.emplace_back();
          readBox(box, env.boxes.back());
        }
      }
    });
  }

  FilterConfig parse(const std::string& yaml_text) {
    YAML::Node root;
    try {
      root = YAML::Load(yaml_text);
    } catch (const YAML::Exception& e) {
      fail(e.mark, "", "YAML syntax error: " + e.msg);
    }
    FilterConfig config;
    const Entry top{root, root.Mark(), ""};
    if (!root.IsNull() && !root.IsMap())
      fail(top.mark, "", "expected a map of options, got " + describe(root));
    FilterOptions& f = config.filter;
    readMap(top,
            {"dt_s", "mode", "feedback", "task", "contacts", "solver", "qp", "divergence",
             "balance", "leash", "environment"},
            [&](const std::string& k, const Entry& v) {
              if (k == "dt_s") f.dt_s = number(v);
              if (k == "mode" && !parseFilterMode(text(v), f.mode))
                fail(v.mark, v.path, "expected paper or qp, got \"" + text(v) + "\"");
              if (k == "qp") readQp(v, f.qp);
              if (k == "feedback") readFeedback(v, f.feedback);
              if (k == "task") readTask(v, f.task);
              if (k == "contacts") readContacts(v, f.contacts);
              if (k == "solver") readSolver(v, f.solver);
              if (k == "divergence") readDivergence(v, f.divergence);
              if (k == "balance") readBalance(v, f.balance);
              if (k == "leash") readLeash(v, f.leash);
              if (k == "environment") readEnvironment(v, config.environment);
            });
    try {
      f.validate();
    } catch (const std::invalid_argument& e) {
      failAtOption(e.what(), optionInMessage(e.what()));
    }
    try {
      config.environment.validate();
    } catch (const std::invalid_argument& e) {
      failAtOption(e.what(), environmentEntryInMessage(e.what()));
    }
    return config;
  }

 private:
  // FilterOptions::validate names the option ("filter option dt_s must be ..."); a group
  // such as "feedback.*" is located at its section.
  static std::string optionInMessage(const std::string& message) {
    static const std::string kPrefix = "filter option ";
    const std::size_t at = message.find(kPrefix);
    if (at == std::string::npos) return "";
    const std::size_t begin = at + kPrefix.size();
    const std::size_t end = message.find(' ', begin);
    return message.substr(begin, end == std::string::npos ? std::string::npos : end - begin);
  }

  // Environment::validate names "ground" or "box <i>" and what is wrong with it; the error
  // is located at the key that set the value when there is one.
  std::string environmentEntryInMessage(const std::string& message) const {
    std::string entry = "environment";
    const std::size_t box = message.find("box ");
    if (box != std::string::npos) {
      std::size_t end = box + 4;
      while (end < message.size() && std::isdigit(static_cast<unsigned char>(message[end]))) ++end;
      if (end > box + 4) entry = "environment.boxes[" + message.substr(box + 4, end - box - 4) + "]";
    } else if (message.find("ground") != std::string::npos) {
      entry = "environment.ground";
    }
    const char* const kFields[][2] = {{"friction", "friction"}, {"size", "size_m"},
                                      {"pose", "position_m"}, {"offset", "height_m"}};
    for (const auto& field : kFields) {
      const std::string key = entry + "." + field[1];
      if (message.find(field[0]) != std::string::npos && marks_.count(key) != 0) return key;
    }
    return entry;
  }

  [[noreturn]] void failAtOption(const std::string& message, const std::string& option) const {
    auto it = marks_.find(option);
    if (it == marks_.end()) it = marks_.find(option.substr(0, option.find('.')));
    if (it != marks_.end()) fail(it->second, it->first, message);
    throw InputError(source_, 0, message);
  }

  const std::string& source_;
  std::map<std::string, YAML::Mark> marks_;  // key path -> where the key is
};

}  // namespace

FilterConfig parseFilterConfig(const std::string& yaml_text, const std::string& source_label) {
  Parser parser(source_label);
  return parser.parse(yaml_text);
}

FilterConfig loadFilterConfig(const std::string& yaml_path) {
  errno = 0;
  std::ifstream in(yaml_path, std::ios::binary);
  if (!in) {
    const int err = errno;
    throw InputError(yaml_path, 0,
                     std::string("cannot open file") +
                         (err != 0 ? ": " + std::string(std::strerror(err)) : ""));
  }
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw InputError(yaml_path, 0, "read error");
  return parseFilterConfig(text.str(), yaml_path);
}

}  // namespace dynfilter::io
