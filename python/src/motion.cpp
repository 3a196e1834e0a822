// Reference motions (CSV or NumPy arrays), BVH motion capture and retargeting.
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "dynfilter/io/bvh.hpp"
#include "dynfilter/io/input_error.hpp"
#include "dynfilter/io/reference_cleanup.hpp"
#include "dynfilter/io/mapping_suggestion.hpp"
#include "dynfilter/io/retarget.hpp"
#include "dynfilter/proxqp/proxqp_solver.hpp"

namespace dynfilter::python {
namespace {

constexpr double kToTheEnd = std::numeric_limits<double>::infinity();  // a window's open end

using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
constexpr const char* kArrays = "<arrays>";

std::string number(double x) {
  std::ostringstream s;
  s.precision(17);
  s << x;
  return s.str();
}

// Stacks one field of every frame into a (frames, n) array.
template <typename Field>
RowMatrix stack(const io::ReferenceMotion& motion, int n, Field field) {
  RowMatrix out(static_cast<Eigen::Index>(motion.frames.size()), n);
  for (std::size_t k = 0; k < motion.frames.size(); ++k)
    out.row(static_cast<Eigen::Index>(k)) = field(motion.frames[k]).transpose();
  return out;
}

void requireShape(const char* name, const RowMatrix& a, Eigen::Index rows, int cols) {
  if (a.rows() != rows || a.cols() != cols)
    throw io::InputError(kArrays, 0,
                         std::string(name) + " has shape (" + std::to_string(a.rows()) + ", " +
                             std::to_string(a.cols()) + "), expected (" + std::to_string(rows) +
                             ", " + std::to_string(cols) + ")");
}

// Frames from arrays with the checks of the CSV reader (io::readReferenceMotion): at least
// two frames, finite values, strictly increasing time, base quaternions within 1e-3 of
// unit norm (then normalised); missing derivatives estimated the same way.
Reference makeReference(const Model& model, const Eigen::VectorXd& time, const RowMatrix& q,
                        const std::optional<RowMatrix>& v, const std::optional<RowMatrix>& vdot,
                        int smoothing_window) {
  const ModelInfo& info = model.engine->info();
  const Eigen::Index n = time.size();
  if (n < 2)
    throw io::InputError(kArrays, 0, "a reference motion needs at least 2 frames, found " +
                                         std::to_string(n));
  requireShape("q", q, n, info.nq);
  if (v) requireShape("v", *v, n, info.nv);
  if (vdot) requireShape("vdot", *vdot, n, info.nv);
  io::ReferenceReadOptions options;
  options.smoothing_window = smoothing_window;
  options.validate();
  Reference ref;
  ref.nq = info.nq;
  ref.nv = info.nv;
  ref.motion.source = kArrays;
  ref.motion.had_velocities = v.has_value();
  ref.motion.had_accelerations = vdot.has_value();
  for (Eigen::Index k = 0; k < n; ++k) {
    const std::string row = "row " + std::to_string(k) + ": ";
    ReferenceFrame f(info.nq, info.nv);
    f.time_s = time[k];
    f.q = q.row(k).transpose();
    if (v) f.v = v->row(k).transpose();
    if (vdot) f.vdot = vdot->row(k).transpose();
    if (!std::isfinite(f.time_s) || !f.q.allFinite() || !f.v.allFinite() || !f.vdot.allFinite())
      throw io::InputError(kArrays, 0, row + "a value is not finite");
    if (k > 0 && !(f.time_s > ref.motion.frames.back().time_s))
      throw io::InputError(kArrays, 0,
                           row + "time " + number(f.time_s) +
                               " s is not after the previous frame's " +
                               number(ref.motion.frames.back().time_s) + " s");
    if (info.floating_base) {
      auto quat = f.q.segment<4>(3);
      const double norm = quat.norm();
      if (!(std::abs(norm - 1.0) <= options.quaternion_tolerance))
        throw io::InputError(kArrays, 0,
                             row + "base quaternion norm " + number(norm) +
                                 " differs from 1 by more than " +
                                 number(options.quaternion_tolerance));
      quat /= norm;
    }
    ref.motion.frames.push_back(std::move(f));
  }
  if (!v || !vdot)
    io::estimateDerivatives(ref.motion.frames, info.floating_base, smoothing_window, !v, !vdot);
  return ref;
}

Reference referenceOf(const io::ReferenceMotion& motion) {
  Reference ref;
  ref.motion = motion;
  ref.nq = static_cast<int>(motion.frames.front().q.size());
  ref.nv = static_cast<int>(motion.frames.front().v.size());
  return ref;
}

// A retargeted clip and, as dynfilter-bvh2ref does by default, its clean-up (contact
// schedule, stance feet on the ground, joints in their limits).
struct Retargeted {
  io::RetargetResult result;
  std::optional<io::CleanupResult> cleanup;

  const io::ReferenceMotion& motion() const { return cleanup ? cleanup->motion : result.motion; }
};

Retargeted retargetClip(const io::RetargetResult& result, const io::RetargetMapping& mapping,
                        Model& model, bool cleanup) {
  Retargeted r{result, std::nullopt};
  if (cleanup) r.cleanup = io::cleanupReference(result.motion, *model.engine, mapping.cleanup, proxqp::factory());
  return r;
}

// reference.csv -> reference.stance.csv, as dynfilter-bvh2ref names it.
std::string schedulePath(const std::string& csv) {
  const std::string ext = ".csv";
  const bool has_ext =
      csv.size() > ext.size() && csv.compare(csv.size() - ext.size(), ext.size(), ext) == 0;
  return (has_ext ? csv.substr(0, csv.size() - ext.size()) : csv) + ".stance.csv";
}

}  // namespace

void bindMotion(py::module_& m) {
  py::class_<Reference>(m, "Reference",
                        "A reference motion in a model's coordinates: time (frames,), q "
                        "(frames, nq), v and vdot (frames, nv), base velocity in the base "
                        "frame (README, Reference motion file).")
      .def_property_readonly("source", [](const Reference& r) { return r.motion.source; })
      .def_property_readonly("time", [](const Reference& r) {
        Eigen::VectorXd t(static_cast<Eigen::Index>(r.motion.frames.size()));
        for (std::size_t k = 0; k < r.motion.frames.size(); ++k)
          t[static_cast<Eigen::Index>(k)] = r.motion.frames[k].time_s;
        return t;
      }, "(frames,) s")
      .def_property_readonly("q", [](const Reference& r) {
        return stack(r.motion, r.nq, [](const ReferenceFrame& f) -> const Eigen::VectorXd& { return f.q; });
      }, "(frames, nq)")
      .def_property_readonly("v", [](const Reference& r) {
        return stack(r.motion, r.nv, [](const ReferenceFrame& f) -> const Eigen::VectorXd& { return f.v; });
      }, "(frames, nv)")
      .def_property_readonly("vdot", [](const Reference& r) {
        return stack(r.motion, r.nv, [](const ReferenceFrame& f) -> const Eigen::VectorXd& { return f.vdot; });
      }, "(frames, nv)")
      .def_property_readonly("had_velocities", [](const Reference& r) { return r.motion.had_velocities; })
      .def_property_readonly("had_accelerations",
                             [](const Reference& r) { return r.motion.had_accelerations; })
      .def_property_readonly(
          "ignored_columns", [](const Reference& r) { return r.motion.ignored_columns; },
          "Columns of the file for joints the model locks (and their .v/.a): not read.")
      .def("__len__", [](const Reference& r) { return r.motion.frames.size(); })
      .def("truncated",
           [](const Reference& r, double max_seconds) {
             if (!(max_seconds > 0.0)) throw std::invalid_argument("max_seconds must be > 0");
             Reference out = r;
             const double t_end = r.motion.frames.front().time_s + max_seconds;
             std::size_t keep = 0;
             while (keep < r.motion.frames.size() && r.motion.frames[keep].time_s <= t_end + 1e-12)
               ++keep;
             out.motion.frames.resize(std::max<std::size_t>(keep, 2));
             return out;
           },
           py::arg("max_seconds"),
           "The frames within max_seconds of the first (at least 2); derivatives as they were.")
      .def("write_csv",
           [](const Reference& r, const std::string& path, const Model& model) {
             io::writeReferenceMotionCsv(path, model.engine->info(), r.motion);
           },
           py::arg("path"), py::arg("model"),
           "Writes time, base pose and joint positions (%.17g) as dynfilter-bvh2ref does.");

  m.def("read_reference",
        [](const std::string& path, const Model& model, int smoothing_window, bool skip_extra_columns) {
          io::ReferenceReadOptions options;
          options.smoothing_window = smoothing_window;
          options.allow_extra_columns = skip_extra_columns;
          Reference r;
          r.motion = io::readReferenceMotion(path, model.engine->info(), options);
          r.nq = model.engine->nq();
          r.nv = model.engine->nv();
          return r;
        },
        py::arg("path"), py::arg("model"), py::arg("smoothing_window") = 7,
        py::arg("skip_extra_columns") = false,
        "Reads a reference motion CSV as dynfilter-offline does. Raises InputError "
        "('<file>:<line>:<column>: <reason>'). skip_extra_columns: columns outside the "
        "format are skipped instead of rejected (a filtered motion read back, as "
        "dynfilter-offline --skip-extra-columns).");
  m.def("make_reference", &makeReference, py::arg("model"), py::arg("time"), py::arg("q"),
        py::arg("v") = std::nullopt, py::arg("vdot") = std::nullopt,
        py::arg("smoothing_window") = 7,
        "A reference from arrays: time (frames,), q (frames, nq), optional v and vdot "
        "(frames, nv); missing derivatives estimated as for a CSV. Raises InputError "
        "('<arrays>: row k: <reason>').");

  py::class_<io::BvhMotion>(m, "Bvh", "A BVH motion-capture clip as read (the file's axes).")
      .def_readonly("source", &io::BvhMotion::source)
      .def_readonly("frame_time_s", &io::BvhMotion::frame_time_s)
      .def_readonly("frames", &io::BvhMotion::frames, "(frames, channels), rotations in degrees")
      .def_readonly("skipped_frames", &io::BvhMotion::skipped_frames)
      .def_property_readonly("joint_names", [](const io::BvhMotion& b) {
        std::vector<std::string> names;
        for (const auto& j : b.joints) names.push_back(j.name);
        return names;
      }, "Hierarchy order, End Sites included as '<parent>_end'.")
      .def_property_readonly("parents", [](const io::BvhMotion& b) {
        std::vector<int> parents;
        for (const auto& j : b.joints) parents.push_back(j.parent);
        return parents;
      })
      .def("duration_s", &io::BvhMotion::durationS)
      .def("window", &io::bvhWindow, py::arg("first_frame"), py::arg("start_s"), py::arg("end_s") = kToTheEnd,
           "The frames from start_s to end_s (s, both included; frame first_frame at 0 s, e.g. a "
           "mapping's skip_frames, which the window's retargeting then takes as 0). Raises "
           "ValueError on an empty or reversed window.")
      .def("__len__", &io::BvhMotion::frameCount);
  m.def("read_bvh",
        [](const std::string& path, double length_scale, bool skip_first_frame) {
          io::BvhReadOptions options;
          options.length_scale = length_scale;
          options.skip_first_frame = skip_first_frame;
          return io::readBvh(path, options);
        },
        py::arg("path"), py::arg("length_scale") = 1.0, py::arg("skip_first_frame") = false,
        "Reads a BVH file. Raises InputError ('<file>:<line>:<column>: <reason>').");

  py::class_<io::RetargetMapping>(m, "Mapping", "A retargeting mapping (YAML, see data/mocap).")
      .def_readonly("source", &io::RetargetMapping::source)
      .def_readwrite("length_scale", &io::RetargetMapping::length_scale)
      .def_readwrite("skip_frames", &io::RetargetMapping::skip_frames)
      .def_readwrite("clamp_to_limits", &io::RetargetMapping::clamp_to_limits)
      .def_readwrite("smoothing_window", &io::RetargetMapping::smoothing_window)
      .def_readwrite("allow_unmapped", &io::RetargetMapping::allow_unmapped);
  m.def("read_mapping", &io::readRetargetMapping, py::arg("path"),
        "Reads a mapping file. Raises InputError naming file, line and column.");
  m.def("suggest_mapping",
        [](const std::string& bvh_path, Model& model) {
          io::BvhReadOptions options;
          options.detect_t_pose = true;
          const io::BvhMotion bvh = io::readBvh(bvh_path, options);
          const io::MappingSuggestion s = io::suggestMapping(bvh, *model.engine, bvh.skipped_frames);
          return py::make_tuple(s.yaml, s.notes);
        },
        py::arg("bvh_path"), py::arg("model"),
        "A first mapping of the BVH onto the model found from the structure of both, as "
        "dynfilter-bvh2ref --suggest-mapping writes it: (yaml_text, notes). Raises InputError "
        "when the BVH has no spine, two legs and two arms, ValueError when the model does not "
        "stand on two legs.");

  py::class_<Retargeted>(m, "RetargetResult",
                         "A retargeted clip (and its clean-up, as dynfilter-bvh2ref does unless "
                         "--no-cleanup).")
      .def_property_readonly("reference", [](const Retargeted& r) { return referenceOf(r.motion()); },
                             "The reference to filter: cleaned up when cleanup was asked for.")
      .def_property_readonly("raw_reference",
                             [](const Retargeted& r) { return referenceOf(r.result.motion); },
                             "The retargeted reference before any clean-up.")
      .def_property_readonly("cleaned", [](const Retargeted& r) { return r.cleanup.has_value(); })
      .def_property_readonly("ground_offset_m", [](const Retargeted& r) { return r.result.ground_offset_m; })
      .def_property_readonly("first_bvh_frame", [](const Retargeted& r) { return r.result.first_bvh_frame; })
      .def_property_readonly("clamped", [](const Retargeted& r) { return r.result.clamped; })
      .def_property_readonly("unmapped_joints", [](const Retargeted& r) { return r.result.unmapped_joints; })
      .def_property_readonly("limits", [](const Retargeted& r) {
        py::list out;
        for (const auto& l : r.result.limits)
          out.append(py::dict(py::arg("joint") = l.joint, py::arg("frames_outside") = l.frames_outside,
                              py::arg("fraction_outside") = l.fraction_outside,
                              py::arg("worst_excess_rad") = l.worst_excess_rad,
                              py::arg("worst_frame") = l.worst_frame, py::arg("min_rad") = l.min_rad,
                              py::arg("max_rad") = l.max_rad));
        return out;
      }, "One dict per model joint: frames outside its limits (as retargeted), worst excess, range.")
      .def_property_readonly("limit_report",
                             [](const Retargeted& r) { return io::formatLimitReport(r.result); })
      .def_property_readonly("cleanup_report", [](const Retargeted& r) {
        return r.cleanup ? io::formatCleanupReport(r.cleanup->report) : std::string();
      })
      .def("write_csv",
           [](const Retargeted& r, const std::string& path, const Model& model) {
             if (r.cleanup) io::writeContactScheduleCsv(schedulePath(path), r.cleanup->schedule);
             io::writeReferenceMotionCsv(path, model.engine->info(), r.motion());
           },
           py::arg("path"), py::arg("model"),
           "Writes the reference CSV (and, when cleaned up, its contact schedule "
           "<stem>.stance.csv) as dynfilter-bvh2ref does.");
  m.def("retarget_file",
        [](const std::string& bvh_path, const io::RetargetMapping& mapping, Model& model,
           bool cleanup, std::optional<double> start_s, std::optional<double> end_s) {
          return retargetClip(io::retargetBvhFile(bvh_path, mapping, *model.engine, start_s.value_or(0.0),
                                                  end_s.value_or(kToTheEnd)),
                              mapping, model, cleanup);
        },
        py::arg("bvh_path"), py::arg("mapping"), py::arg("model"), py::arg("cleanup") = true,
        py::arg("start_s") = std::nullopt, py::arg("end_s") = std::nullopt,
        "Reads bvh_path with the mapping's length scale and retargets it (as dynfilter-bvh2ref); "
        "start_s, end_s: only that window (s after the mapping's skip_frames), as "
        "dynfilter-bvh2ref --start-s/--end-s.");
  m.def("retarget",
        [](const io::BvhMotion& bvh, const io::RetargetMapping& mapping, Model& model, bool cleanup,
           std::optional<double> start_s, std::optional<double> end_s) {
          return retargetClip(io::retargetBvhWindow(bvh, mapping, *model.engine, start_s.value_or(0.0),
                                                    end_s.value_or(kToTheEnd)),
                              mapping, model, cleanup);
        },
        py::arg("bvh"), py::arg("mapping"), py::arg("model"), py::arg("cleanup") = true,
        py::arg("start_s") = std::nullopt, py::arg("end_s") = std::nullopt,
        "Retargets a clip read with the mapping's length_scale and all frames kept; start_s, "
        "end_s: only that window, as retarget_file.");
}

}  // namespace dynfilter::python
