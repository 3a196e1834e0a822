// Built against an installed dynfilter by tests/support/CheckExportedPackage.cmake: every
// exported library is linked and used once, so a target missing from the package (or a
// dependency missing from dynfilterConfig.cmake) fails the build or the run.
#include <iostream>
#include <vector>

#include "dynfilter/dart/dart_model.hpp"
#include "dynfilter/filter_status_t.hpp"
#include "dynfilter/io/config.hpp"
#include "dynfilter/lcm/messages.hpp"
#include "dynfilter/ode/ode_model.hpp"
#include "dynfilter/realtime/realtime_filter.hpp"

int main(int argc, char** argv) {
  if (argc < 2) return 2;
  dynfilter::ModelOptions options;
  options.floating_base = false;
  auto dart = dynfilter::dart_backend::loadDartModel(argv[1], options);
  auto ode = dynfilter::ode_backend::loadOdeModel(argv[1], options);
  const auto config = dynfilter::io::parseFilterConfig("mode: qp\n", "consumer");
  dynfilter::realtime::RealtimeOptions rt;
  {
    dynfilter::filter_status_t status{};
    status.utime = 1;
    std::vector<std::uint8_t> buffer;
    if (dynfilter::messages::encodeMessage(status, buffer) <= 0) return 1;
  }
  std::cout << "nv=" << dart->nv() << " ode_nv=" << ode->nv()
            << " qp=" << (config.filter.mode == dynfilter::FilterMode::kQp)
            << " stale=" << rt.stale_timeout_s << "\n";
  return 0;
}
