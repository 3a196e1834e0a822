// Built against an installed dynfilter by tests/support/CheckExportedPackage.cmake.
#include <iostream>

#include "dynfilter/dart/dart_model.hpp"

int main(int argc, char** argv) {
  if (argc < 2) return 2;
  dynfilter::ModelOptions options;
  options.floating_base = false;
  auto model = dynfilter::dart_backend::loadDartModel(argv[1], options);
  std::cout << "nv=" << model->nv() << "\n";
  return 0;
}
