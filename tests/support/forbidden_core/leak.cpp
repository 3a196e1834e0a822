// Fixture for core_include_guard_rejects_backend_headers: the guard must reject this.
#include <Eigen/Core>
#include <dart/dynamics/Skeleton.hpp>
