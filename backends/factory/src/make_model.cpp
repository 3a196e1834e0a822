#include "dynfilter/backends/make_model.hpp"

#include <stdexcept>

#include "dynfilter/dart/dart_model.hpp"
#include "dynfilter/ode/ode_model.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"

namespace dynfilter {

const std::vector<std::string>& availableBackends() {
  static const std::vector<std::string> names{"dart", "ode"};
  return names;
}

std::unique_ptr<IDynamicsModel> makeModel(std::string_view backend,
                                          const urdf::RobotDescription& robot,
                                          const ModelOptions& options) {
  if (backend == "dart") return dart_backend::makeDartModel(robot, options);
  if (backend == "ode") return ode_backend::makeOdeModel(robot, options);
  std::string known;
  for (const auto& name : availableBackends()) known += (known.empty() ? "" : ", ") + name;
  throw std::invalid_argument("unknown backend \"" + std::string(backend) + "\" (known: " + known +
                              ")");
}

std::unique_ptr<IDynamicsModel> loadModel(std::string_view backend, const std::string& urdf_path,
                                          const ModelOptions& options) {
  return makeModel(backend, urdf::loadUrdfFile(urdf_path), options);
}

}  // namespace dynfilter
