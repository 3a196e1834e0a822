// dynfilter._dynfilter: the filter, its models and its files from Python. The pure-Python
// package dynfilter (python/dynfilter) wraps this module; its docs are the user's.
#include <exception>

#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "dynfilter/core/errors.hpp"
#include "dynfilter/core/filter_options.hpp"
#include "dynfilter/io/config.hpp"
#include "dynfilter/io/input_error.hpp"

namespace dynfilter::python {
namespace {

void bindConfig(py::module_& m) {
  py::class_<io::FilterConfig>(m, "Config",
                               "A filter configuration (FilterOptions and the environment), as "
                               "read from YAML by the tools (tools/config/default.yaml lists "
                               "every key).")
      .def(py::init<>(), "The defaults of every key.")
      .def_property(
          "mode", [](const io::FilterConfig& c) { return std::string(toString(c.filter.mode)); },
          [](io::FilterConfig& c, const std::string& mode) {
            if (!parseFilterMode(mode, c.filter.mode))
              throw std::invalid_argument("unknown mode \"" + mode + "\" (paper or qp)");
          },
          "Solver: \"paper\" (Eq. 21-23) or \"qp\" (contact-consistent QP).")
      .def_property(
          "dt_s", [](const io::FilterConfig& c) { return c.filter.dt_s; },
          [](io::FilterConfig& c, double dt) { c.filter.dt_s = dt; },
          "Tick of Filter.step (s); filter_motion ticks at its own tick_hz.")
      .def_property_readonly(
          "ground_friction",
          [](const io::FilterConfig& c) { return c.environment.ground.friction; },
          "Coulomb coefficient of the ground.")
      .def_property_readonly(
          "has_ground", [](const io::FilterConfig& c) { return c.environment.has_ground; })
      .def("copy", [](const io::FilterConfig& c) { return io::FilterConfig(c); },
           "An independent copy.")
      .def("__copy__", [](const io::FilterConfig& c) { return io::FilterConfig(c); })
      .def("validate", [](const io::FilterConfig& c) {
        c.filter.validate();
        c.environment.validate();
      }, "Raises ValueError naming the first invalid option.");

  m.def("load_config", &io::loadFilterConfig, py::arg("path"),
        "Reads and validates a YAML configuration file. Raises InputError "
        "('<file>:<line>:<column>: <key path>: <reason>').");
  m.def("parse_config", &io::parseFilterConfig, py::arg("yaml_text"),
        py::arg("source_label") = "<string>",
        "Same as load_config for YAML text; source_label stands for the file name in errors.");
}

}  // namespace

// The module's exception types (created once in PYBIND11_MODULE, see there).
py::exception<io::InputError>* input_error = nullptr;
py::exception<ModelError>* model_error = nullptr;
py::exception<InvalidStateError>* state_error = nullptr;

}  // namespace dynfilter::python

PYBIND11_MODULE(_dynfilter, m) {
  using namespace dynfilter;
  using namespace dynfilter::python;
  namespace py = pybind11;
  m.doc() = "dynfilter's native module; use the package dynfilter.";

  // ValueError subclasses carrying the message of the C++ tools unchanged. Created once and
  // never destroyed (they must outlive every translation, up to interpreter shutdown).
  input_error = new py::exception<io::InputError>(m, "InputError", PyExc_ValueError);
  model_error = new py::exception<ModelError>(m, "ModelError", PyExc_ValueError);
  state_error = new py::exception<InvalidStateError>(m, "InvalidStateError", PyExc_ValueError);
  input_error->doc() = "A bad input file: what() reads '<file>:<line>:<column>: <reason>'; "
                       "attributes file, line, column, reason.";
  model_error->doc() = "A URDF or model build failed: '<file>:<line>: <element>: <reason>'; "
                       "attributes file, line, element, reason.";
  state_error->doc() = "A state handed to a model is invalid (size, non-finite, quaternion).";
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const io::InputError& e) {
      py::object exc = py::handle(input_error->ptr())(e.what());
      exc.attr("file") = e.file();
      exc.attr("line") = e.line();
      exc.attr("column") = e.column();
      exc.attr("reason") = e.reason();
      PyErr_SetObject(input_error->ptr(), exc.ptr());
    } catch (const ModelError& e) {
      py::object exc = py::handle(model_error->ptr())(e.what());
      exc.attr("file") = e.file();
      exc.attr("line") = e.line();
      exc.attr("element") = e.element();
      exc.attr("reason") = e.reason();
      PyErr_SetObject(model_error->ptr(), exc.ptr());
    } catch (const InvalidStateError& e) {
      PyErr_SetString(state_error->ptr(), e.what());
    }
  });

  python::bindConfig(m);
  python::bindModel(m);
  python::bindMotion(m);
  python::bindFilter(m);
}
