// dynfilter.Filter (one tick at a time) and filter_motion (a whole reference, the loop of
// dynfilter-offline: io::runOffline).
#include <optional>
#include <vector>

#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "dynfilter/core/dynamics_filter.hpp"
#include "dynfilter/io/filtered_motion.hpp"
#include "dynfilter/io/filtered_motion_check.hpp"
#include "dynfilter/io/filtered_motion_reader.hpp"
#include "dynfilter/io/offline_run.hpp"
#include "dynfilter/qp_engines/qp_engines.hpp"

namespace dynfilter::python {
namespace {

using Eigen::VectorXd;

const char* kindName(ContactKind kind) {
  switch (kind) {
    case ContactKind::kPoint: return "point";
    case ContactKind::kEdge: return "edge";
    case ContactKind::kFace: return "face";
  }
  return "point";
}

py::dict countersDict(const FilterCounters& c) {
  return py::dict(py::arg("ticks") = c.ticks, py::arg("impacts") = c.impacts,
                  py::arg("reseeds") = c.reseeds, py::arg("invalid_references") = c.invalid_references,
                  py::arg("links_released") = c.links_released, py::arg("qp_solves") = c.qp_solves,
                  py::arg("qp_fallbacks") = c.qp_fallbacks, py::arg("qp_relaxed") = c.qp_relaxed,
                  py::arg("qp_iterations") = c.qp_iterations, py::arg("pivot_ticks") = c.pivot_ticks,
                  py::arg("slide_ticks") = c.slide_ticks, py::arg("leash_ticks") = c.leash_ticks);
}

// Growing row-major table of one quantity: rows × width doubles.
struct Column {
  int width = 1;
  std::vector<double> values;
  void add(const double* x) { values.insert(values.end(), x, x + width); }
  void add(double x) { values.push_back(x); }
  py::array_t<double> array(bool flat) const {
    const auto rows = static_cast<py::ssize_t>(values.size() / static_cast<std::size_t>(width));
    py::array_t<double> out = flat ? py::array_t<double>(rows)
                                   : py::array_t<double>({rows, static_cast<py::ssize_t>(width)});
    std::copy(values.begin(), values.end(), out.mutable_data());
    return out;
  }
};

template <typename T>
py::array_t<T> toArray(const std::vector<T>& v) {
  py::array_t<T> out(static_cast<py::ssize_t>(v.size()));
  std::copy(v.begin(), v.end(), out.mutable_data());
  return out;
}

// Every output row of a run, as NumPy arrays at the end (README "Python").
class Recorder {
 public:
  explicit Recorder(const ModelInfo& info)
      : q_{info.nq, {}}, v_{info.nv, {}}, vdot_{info.nv, {}}, tau_{info.nj, {}},
        err_{info.nv, {}}, task_err_{6, {}}, p_{3, {}}, n_{3, {}}, slide_{3, {}}, wrench_{6, {}}, cop_{2, {}},
        support_min_{2, {}}, support_max_{2, {}} {}

  /// @param status, reseed_reason the row's: io::OfflineTick::row_status and row_reseed_reason
  void add(const FilterOutput& out, std::uint32_t status, ReseedReason reseed_reason) {
    const auto row = static_cast<std::int64_t>(status_.size());
    time_.add(out.time_s);
    status_.push_back(status);
    q_.add(out.q.data());
    v_.add(out.v.data());
    vdot_.add(out.vdot.data());
    tau_.add(out.tau_J.data());
    err_.add(out.tracking_error.data());
    task_err_.add(out.task_error.data());
    eq12_.add(out.eq12_residual);
    base_res_.add(out.base_residual_n);
    penetration_.add(out.max_penetration_m);
    num_contacts_.push_back(out.num_contacts);
    solve_time_.add(out.solve_time_s);
    tick_time_.add(out.tick_time_s);
    reseed_reason_.push_back(static_cast<int>(reseed_reason));
    qp_status_.push_back(out.qp_status);
    qp_iterations_.push_back(out.qp_iterations);
    for (int c = 0; c < out.num_contacts; ++c) {
      const ContactOutput& k = out.contacts[static_cast<std::size_t>(c)];
      contact_row_.push_back(row);
      contact_time_.add(out.time_s);
      contact_body_.push_back(k.body);
      contact_object_.push_back(k.object);
      contact_kind_.push_back(static_cast<int>(k.kind));
      contact_pivot_.push_back(k.pivot);
      p_.add(k.p_WC.data());
      n_.add(k.n_W.data());
      slide_.add(k.slide_W.data());
      wrench_.add(k.wrench_W.data());
      normal_force_.add(k.normal_force_n);
      cop_.add(k.cop_A.data());
      support_min_.add(k.support_min_A.data());
      support_max_.add(k.support_max_A.data());
    }
  }

  py::dict result() const {
    py::dict d;
    d["time"] = time_.array(true);
    d["status"] = toArray(status_);
    d["q"] = q_.array(false);
    d["v"] = v_.array(false);
    d["vdot"] = vdot_.array(false);
    d["tau"] = tau_.array(false);
    d["tracking_error"] = err_.array(false);
    d["task_error"] = task_err_.array(false);
    d["eq12_residual"] = eq12_.array(true);
    d["base_residual_n"] = base_res_.array(true);
    d["max_penetration_m"] = penetration_.array(true);
    d["num_contacts"] = toArray(num_contacts_);
    d["solve_time_s"] = solve_time_.array(true);
    d["tick_time_s"] = tick_time_.array(true);
    d["reseed_reason"] = toArray(reseed_reason_);
    d["qp_status"] = toArray(qp_status_);
    d["qp_iterations"] = toArray(qp_iterations_);
    py::dict c;
    c["row"] = toArray(contact_row_);
    c["time"] = contact_time_.array(true);
    c["body"] = toArray(contact_body_);
    c["object"] = toArray(contact_object_);
    c["kind"] = toArray(contact_kind_);
    c["pivot"] = toArray(contact_pivot_);
    c["p_WC"] = p_.array(false);
    c["n_W"] = n_.array(false);
    c["slide_W"] = slide_.array(false);
    c["wrench_W"] = wrench_.array(false);
    c["normal_force_n"] = normal_force_.array(true);
    c["cop_A"] = cop_.array(false);
    c["support_min_A"] = support_min_.array(false);
    c["support_max_A"] = support_max_.array(false);
    d["contacts"] = c;
    return d;
  }

 private:
  Column time_;
  std::vector<std::uint32_t> status_;
  Column q_, v_, vdot_, tau_, err_, task_err_;
  Column eq12_, base_res_, penetration_, solve_time_, tick_time_;
  std::vector<int> num_contacts_, reseed_reason_, qp_status_, qp_iterations_;
  std::vector<std::int64_t> contact_row_;
  Column contact_time_;
  std::vector<int> contact_body_, contact_object_, contact_kind_, contact_pivot_;
  Column p_, n_, slide_, wrench_, cop_, support_min_, support_max_;
  Column normal_force_;
};

// One tick's output as a dict of the same keys as a row of filter_motion's result.
py::dict outputDict(const FilterOutput& out) {
  py::dict d;
  d["time"] = out.time_s;
  d["status"] = out.status;
  d["q"] = VectorXd(out.q);
  d["v"] = VectorXd(out.v);
  d["vdot"] = VectorXd(out.vdot);
  d["tau"] = VectorXd(out.tau_J);
  d["tracking_error"] = VectorXd(out.tracking_error);
  d["task_error"] = VectorXd(out.task_error);
  d["eq12_residual"] = out.eq12_residual;
  d["base_residual_n"] = out.base_residual_n;
  d["max_penetration_m"] = out.max_penetration_m;
  d["solve_time_s"] = out.solve_time_s;
  d["tick_time_s"] = out.tick_time_s;
  d["reseed_reason"] = static_cast<int>(out.reseed_reason);
  d["X_reference_offset"] = Eigen::Matrix4d(out.X_reference_offset.matrix());
  py::list contacts;
  for (int c = 0; c < out.num_contacts; ++c) {
    const ContactOutput& k = out.contacts[static_cast<std::size_t>(c)];
    contacts.append(py::dict(py::arg("body") = k.body, py::arg("object") = k.object,
                             py::arg("kind") = kindName(k.kind),
                             py::arg("p_WC") = Eigen::Vector3d(k.p_WC),
                             py::arg("n_W") = Eigen::Vector3d(k.n_W),
                             py::arg("wrench_W") = Vector6d(k.wrench_W),
                             py::arg("normal_force_n") = k.normal_force_n,
                             py::arg("cop_A") = Eigen::Vector2d(k.cop_A), py::arg("pivot") = k.pivot,
                             py::arg("slide_W") = Eigen::Vector3d(k.slide_W)));
  }
  d["contacts"] = contacts;
  d["counters"] = countersDict(out.counters);
  return d;
}

// A filter ticked from Python (the real-time process's view: one reference frame a tick).
class Filter {
 public:
  Filter(const Model& model, const io::FilterConfig& config)
      : engine_(model.make(config.environment)),
        filter_(*engine_, config.filter, qp_engines::factory(config.filter.qp.solver.engine)),
        ref_(engine_->nq(), engine_->nv()) {}

  void reset(const VectorXd& q, const std::optional<VectorXd>& v,
             const std::optional<VectorXd>& vdot, double time_s) {
    set(time_s, q, v, vdot);
    engine_->info().requireValidState(ref_.q, ref_.v);
    filter_.reset(ref_);
  }

  py::dict step(double time_s, const VectorXd& q, const std::optional<VectorXd>& v,
                const std::optional<VectorXd>& vdot) {
    set(time_s, q, v, vdot);
    return outputDict(filter_.step(ref_));
  }

  const VectorXd& q() const { return filter_.q(); }
  const VectorXd& v() const { return filter_.v(); }
  double dt() const { return filter_.options().dt_s; }

 private:
  void set(double time_s, const VectorXd& q, const std::optional<VectorXd>& v,
           const std::optional<VectorXd>& vdot) {
    const auto check = [](const char* name, Eigen::Index size, int expected) {
      if (size != expected)
        throw std::invalid_argument(std::string(name) + " has " + std::to_string(size) +
                                    " entries, expected " + std::to_string(expected));
    };
    check("q", q.size(), engine_->nq());
    if (v) check("v", v->size(), engine_->nv());
    if (vdot) check("vdot", vdot->size(), engine_->nv());
    ref_.time_s = time_s;
    ref_.q = q;
    if (v) ref_.v = *v; else ref_.v.setZero();
    if (vdot) ref_.vdot = *vdot; else ref_.vdot.setZero();
  }

  std::unique_ptr<IDynamicsModel> engine_;
  DynamicsFilter filter_;
  ReferenceFrame ref_;
};

// The whole reference through io::runOffline, as dynfilter-offline runs it; optionally
// writes the tool's two CSV files too.
py::dict filterMotion(const Model& model, const Reference& reference,
                      const io::FilterConfig& config, double tick_hz, bool every_tick,
                      std::optional<double> preview_s, const std::string& output_csv,
                      const std::function<void(double)>& progress) {
  config.filter.validate();
  auto engine = model.make(config.environment);
  const ModelInfo& info = engine->info();
  if (reference.nq != info.nq || reference.nv != info.nv)
    throw std::invalid_argument("the reference has nq " + std::to_string(reference.nq) +
                                ", the model " + std::to_string(info.nq));
  Recorder recorder(info);
  std::optional<io::FilteredMotionWriter> writer;
  if (!output_csv.empty()) writer.emplace(output_csv, info);
  io::OfflineRunOptions options;
  options.tick_hz = tick_hz;
  options.every_tick = every_tick;
  if (preview_s) options.preview_s = *preview_s;
  FilterCounters counters;
  io::OfflineSchedule schedule;
  {
    py::gil_scoped_release release;
    long report_every = 1;
    schedule = io::runOffline(
        *engine, config.filter, reference.motion, options, qp_engines::factory(config.filter.qp.solver.engine),
        [&](const io::OfflineTick& tick) {
          if (tick.index == 0) report_every = std::max(1L, tick.count / 100);
          if (tick.row) {
            recorder.add(*tick.output, tick.row_status, tick.row_reseed_reason);
            if (writer) writer->append(*tick.output, tick.row_status);
          }
          counters = tick.output->counters;
          if ((tick.index + 1) % report_every == 0 || tick.index + 1 == tick.count) {
            py::gil_scoped_acquire acquire;
            if (PyErr_CheckSignals() != 0) throw py::error_already_set();
            if (progress) progress(static_cast<double>(tick.index + 1) / static_cast<double>(tick.count));
          }
        });
    if (writer) writer->commit();
  }
  py::dict result = recorder.result();
  result["counters"] = countersDict(counters);
  result["dt_s"] = schedule.dt_s;
  result["ticks"] = schedule.ticks;
  result["joint_names"] = info.joint_names;
  result["body_names"] = info.body_names;
  return result;
}

py::dict residualsDict(const io::FilteredMotionResiduals& r) {
  py::dict d;
  d["base_residual_n"] = r.base_n;
  d["residual"] = r.all;
  d["max_base_residual_n"] = r.worst_base_n;
  d["worst_base_frame"] = r.worst_base_frame;
  d["max_residual"] = r.worst_all;
  d["max_base_residual_rel_bw"] = r.worst_base_n / r.body_weight_n;
  d["max_residual_rel_bw"] = r.worst_all / r.body_weight_n;
  return d;
}

using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// filter_motion's arrays as the frames io::evaluateFilteredMotion checks.
std::vector<io::FilteredFrame> framesOf(const RowMatrix& q, const RowMatrix& v,
                                        const RowMatrix& vdot, const RowMatrix& tau,
                                        const Eigen::Matrix<std::int64_t, Eigen::Dynamic, 1>& contact_row,
                                        const Eigen::VectorXi& contact_body,
                                        const RowMatrix& p_WC, const RowMatrix& wrench_W) {
  const Eigen::Index n = q.rows();
  if (v.rows() != n || vdot.rows() != n || tau.rows() != n)
    throw std::invalid_argument("q, v, vdot and tau must have the same number of rows");
  const Eigen::Index k = contact_row.size();
  if (contact_body.size() != k || p_WC.rows() != k || wrench_W.rows() != k || p_WC.cols() != 3 ||
      wrench_W.cols() != 6)
    throw std::invalid_argument("contacts: row, body (k,), p_WC (k, 3) and wrench_W (k, 6) must agree");
  std::vector<io::FilteredFrame> frames(static_cast<std::size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) {
    auto& f = frames[static_cast<std::size_t>(i)];
    f.state.q = q.row(i).transpose();
    f.state.v = v.row(i).transpose();
    f.state.vdot = vdot.row(i).transpose();
    f.tau_J = tau.row(i).transpose();
  }
  for (Eigen::Index c = 0; c < k; ++c) {
    if (contact_row[c] < 0 || contact_row[c] >= n)
      throw std::invalid_argument("contacts: row " + std::to_string(contact_row[c]) + " out of range");
    io::ContactWrench w;
    w.body = contact_body[c];
    w.p_WC = p_WC.row(c).transpose();
    w.wrench_W = wrench_W.row(c).transpose();
    frames[static_cast<std::size_t>(contact_row[c])].contacts.push_back(w);
  }
  return frames;
}

}  // namespace

void bindFilter(py::module_& m) {
  m.def("crosscheck_file",
        [](Model& model, const std::string& path) {
          return residualsDict(io::evaluateFilteredMotion(
              *model.engine, io::readFilteredMotion(path, model.engine->info())));
        },
        py::arg("model"), py::arg("filtered_csv"),
        "Eq. 12 of a dynfilter-offline output re-evaluated by model (dynfilter-crosscheck "
        "--filtered).");
  m.def("crosscheck_arrays",
        [](Model& model, const RowMatrix& q, const RowMatrix& v, const RowMatrix& vdot,
           const RowMatrix& tau, const Eigen::Matrix<std::int64_t, Eigen::Dynamic, 1>& contact_row,
           const Eigen::VectorXi& contact_body, const RowMatrix& p_WC, const RowMatrix& wrench_W) {
          return residualsDict(io::evaluateFilteredMotion(
              *model.engine, framesOf(q, v, vdot, tau, contact_row, contact_body, p_WC, wrench_W)));
        },
        py::arg("model"), py::arg("q"), py::arg("v"), py::arg("vdot"), py::arg("tau"),
        py::arg("contact_row"), py::arg("contact_body"), py::arg("p_WC"), py::arg("wrench_W"),
        "Same for filter_motion's arrays.");

  py::class_<Filter>(m, "Filter",
                     "The dynamics filter on its own instance of a model, in the "
                     "configuration's environment, ticking every config.dt_s.")
      .def(py::init<const Model&, const io::FilterConfig&>(), py::arg("model"), py::arg("config"),
           py::keep_alive<1, 2>(),
           "Raises ValueError on invalid options or an unknown task body.")
      .def("reset", &Filter::reset, py::arg("q"), py::arg("v") = std::nullopt,
           py::arg("vdot") = std::nullopt, py::arg("time") = 0.0,
           "Starts from this state (v, vdot default to 0); a floating base that penetrates "
           "the ground is raised until it does not. Raises InvalidStateError.")
      .def("step", &Filter::step, py::arg("time"), py::arg("q"), py::arg("v") = std::nullopt,
           py::arg("vdot") = std::nullopt,
           "One tick towards the reference frame (q (nq,), v and vdot (nv,), default 0). "
           "Never raises on a bad frame: it is replaced by the last valid one and flagged in "
           "status (bit 8). Returns a dict: time, status, q, v, vdot, tau, tracking_error, "
           "task_error, eq12_residual, base_residual_n, max_penetration_m, solve_time_s, "
           "tick_time_s, reseed_reason, X_reference_offset (4x4: the reference leash's motion "
           "so far, identity without it), contacts (list of dicts), counters.")
      .def_property_readonly("q", &Filter::q)
      .def_property_readonly("v", &Filter::v)
      .def_property_readonly("dt_s", &Filter::dt);

  m.def("filter_reference", &filterMotion, py::arg("model"), py::arg("reference"),
        py::arg("config"), py::arg("tick_hz") = 500.0, py::arg("every_tick") = false,
        py::arg("preview_s") = std::nullopt, py::arg("output_csv") = "", py::arg("progress") = nullptr,
        "The loop of dynfilter-offline (bit-identical outputs); see dynfilter.filter_motion.");
}

}  // namespace dynfilter::python
