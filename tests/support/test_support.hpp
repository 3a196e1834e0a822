#pragma once
// Helpers for the test suites. The reference computations here are written from the
// URDF description and first principles, independent of any backend's dynamics code.

#include <functional>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <gtest/gtest.h>

#include "dynfilter/core/dynamics_model.hpp"
#include "dynfilter/core/filter_options.hpp"
#include "dynfilter/core/model_options.hpp"
#include "dynfilter/urdf/robot_description.hpp"

namespace dynfilter::test {

/// Absolute path of a file in the source tree.
std::string sourcePath(const std::string& relative);
/// tests/models/<name>
std::string testModelPath(const std::string& name);
/// models/human_figure.urdf
std::string humanFigurePath();
/// tests/models/<name> rewritten by @p edit into <TempDir>/<out_name>; returns that path.
std::string editedTestModel(const std::string& name, const std::function<std::string(std::string)>& edit,
                            const std::string& out_name);

/// How a program ran: its exit code (−1 when it did not exit normally) and what it printed.
struct ProgramRun {
  int exit_code = -1;
  std::string output;  ///< stdout and stderr together
};
/// Runs `binary args` through the shell and captures its output (through a file per
/// process: ctest runs the tests of one executable in parallel processes).
ProgramRun runProgram(const std::string& binary, const std::string& args);

/// The shipped defaults (tools/config/default.yaml) in the QP mode at tick @p dt_s.
FilterOptions qpDefaults(double dt_s);

/// Backends the parameterised suites run on.
std::vector<std::string> allBackends();
/// Names parameterised instances after the backend ("dart", "ode").
struct BackendName {
  std::string operator()(const testing::TestParamInfo<std::string>& info) const {
    return info.param;
  }
};
/// tests/models/mini_humanoid.urdf on DART, default options.
std::unique_ptr<IDynamicsModel> makeMiniHumanoid();
/// Radians per degree; seconds per hour.
inline constexpr double kRadPerDeg = 3.14159265358979323846 / 180.0;
inline constexpr double kSecondsPerHour = 3600.0;
/// Builds @p robot with the named backend.
std::unique_ptr<IDynamicsModel> makeModel(const std::string& backend,
                                          const urdf::RobotDescription& robot,
                                          const ModelOptions& options);

/// A random valid state: base pose anywhere near the origin, joints inside their limits
/// (continuous joints in [−π, π]), velocities of size about @p velocity_scale.
void randomState(const IDynamicsModel& model, std::mt19937& rng, double velocity_scale,
                 Eigen::VectorXd& q, Eigen::VectorXd& v);

/// Mass properties of every link expressed in its own frame, straight from the URDF.
struct LinkMass {
  double mass_kg;
  Eigen::Vector3d p_LCom;
  Eigen::Matrix3d I_Com_L;
};
std::vector<LinkMass> linkMasses(const urdf::RobotDescription& robot);

/// A = Σ_k J_kᵀ diag(m_k I, I_k,W) J_k and b = Σ_k J_kᵀ [m_k (a_k − g); I_k,W α_k + ω_k × I_k,W ω_k]
/// with J_k the Jacobian of link k's CoM and (a_k, α_k) = J̇_k v: the Newton–Euler sum over
/// bodies, evaluated with the model's point kinematics (which the finite-difference tests
/// check separately).
void newtonEulerReference(const IDynamicsModel& model, const std::vector<LinkMass>& masses,
                          const Eigen::Vector3d& gravity_W, Eigen::MatrixXd& A,
                          Eigen::VectorXd& b);

/// Total linear momentum (kg m/s) and angular momentum about the world origin (kg m²/s).
void momentum(const IDynamicsModel& model, const std::vector<LinkMass>& masses,
              Eigen::Vector3d& linear, Eigen::Vector3d& angular);

/// max |a − b| / max(1, max |b|)
double relativeError(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b);

}  // namespace dynfilter::test
