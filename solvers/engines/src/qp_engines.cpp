#include "dynfilter/qp_engines/qp_engines.hpp"

#include <stdexcept>

#include "dynfilter/daqp/daqp_solver.hpp"
#include "dynfilter/proxqp/proxqp_solver.hpp"

namespace dynfilter::qp_engines {

QpSolverFactory factory(const std::string& name) {
  if (name == "daqp") return daqp::factory();
  if (name == "proxqp") return proxqp::factory();
  throw std::invalid_argument("qp.engine: unknown QP engine \"" + name + "\" (known: daqp, proxqp)");
}

}  // namespace dynfilter::qp_engines
