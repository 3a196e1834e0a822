#include "support/test_support.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/core/model_sampling.hpp"
#include "dynfilter/dart/dart_model.hpp"
#include "dynfilter/ode/ode_model.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"

namespace dynfilter::test {

std::string sourcePath(const std::string& relative) {
  return std::string(DYNFILTER_SOURCE_DIR) + "/" + relative;
}
std::string testModelPath(const std::string& name) { return sourcePath("tests/models/" + name); }
std::string humanFigurePath() { return sourcePath("models/human_figure.urdf"); }

std::string editedTestModel(const std::string& name, const std::function<std::string(std::string)>& edit,
                            const std::string& out_name) {
  std::ifstream in(testModelPath(name));
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string path = testing::TempDir() + "/" + out_name;
  std::ofstream(path) << edit(text);
  return path;
}

ProgramRun runProgram(const std::string& binary, const std::string& args) {
  const std::string log = testing::TempDir() + "/program_output_" + std::to_string(getpid()) + ".txt";
  const int status = std::system((binary + " " + args + " > " + log + " 2>&1").c_str());
  std::ifstream in(log);
  std::stringstream text;
  text << in.rdbuf();
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, text.str()};
}

FilterOptions qpDefaults(double dt_s) {
  FilterOptions options;
  options.mode = FilterMode::kQp;
  options.dt_s = dt_s;
  return options;
}

std::vector<std::string> allBackends() { return {"dart", "ode"}; }

std::unique_ptr<IDynamicsModel> makeModel(const std::string& backend,
                                          const urdf::RobotDescription& robot,
                                          const ModelOptions& options) {
  if (backend == "dart") return dart_backend::makeDartModel(robot, options);
  if (backend == "ode") return ode_backend::makeOdeModel(robot, options);
  throw std::invalid_argument("unknown backend " + backend);
}

std::unique_ptr<IDynamicsModel> makeMiniHumanoid() {
  return makeModel("dart", urdf::loadUrdfFile(testModelPath("mini_humanoid.urdf")), ModelOptions{});
}

void randomState(const IDynamicsModel& model, std::mt19937& rng, double velocity_scale,
                 Eigen::VectorXd& q, Eigen::VectorXd& v) {
  dynfilter::randomState(model.info(), rng, velocity_scale, q, v);
}

std::vector<LinkMass> linkMasses(const urdf::RobotDescription& robot) {
  std::vector<LinkMass> out;
  for (const auto& link : robot.links)
    out.push_back({link.inertial.mass_kg, link.inertial.p_LCom, link.inertial.I_Com_L});
  return out;
}

void newtonEulerReference(const IDynamicsModel& model, const std::vector<LinkMass>& masses,
                          const Eigen::Vector3d& gravity_W, Eigen::MatrixXd& A,
                          Eigen::VectorXd& b) {
  const int nv = model.nv();
  A.setZero(nv, nv);
  b.setZero(nv);
  Matrix6Xd J(6, nv);
  for (std::size_t k = 0; k < masses.size(); ++k) {
    const LinkMass& mk = masses[k];
    if (mk.mass_kg <= 0.0) continue;
    const int body = static_cast<int>(k);
    model.pointJacobian(body, mk.p_LCom, J);
    const Vector6d drift = model.pointJacobianDotTimesV(body, mk.p_LCom);
    const Eigen::Matrix3d R = model.bodyPose(body).linear();
    const Eigen::Matrix3d I_W = R * mk.I_Com_L * R.transpose();
    const Eigen::Vector3d omega = model.bodyVelocity(body).tail<3>();
    Matrix6d M = Matrix6d::Zero();
    M.topLeftCorner<3, 3>() = mk.mass_kg * Eigen::Matrix3d::Identity();
    M.bottomRightCorner<3, 3>() = I_W;
    A += J.transpose() * M * J;
    Vector6d wrench;
    wrench.head<3>() = mk.mass_kg * (drift.head<3>() - gravity_W);
    wrench.tail<3>() = I_W * drift.tail<3>() + omega.cross(I_W * omega);
    b += J.transpose() * wrench;
  }
}

void momentum(const IDynamicsModel& model, const std::vector<LinkMass>& masses,
              Eigen::Vector3d& linear, Eigen::Vector3d& angular) {
  linear.setZero();
  angular.setZero();
  Matrix6Xd J(6, model.nv());
  for (std::size_t k = 0; k < masses.size(); ++k) {
    const LinkMass& mk = masses[k];
    if (mk.mass_kg <= 0.0) continue;
    const int body = static_cast<int>(k);
    model.pointJacobian(body, mk.p_LCom, J);
    const Vector6d V = J * model.v();
    const Eigen::Isometry3d X = model.bodyPose(body);
    const Eigen::Matrix3d I_W = X.linear() * mk.I_Com_L * X.linear().transpose();
    const Eigen::Vector3d c = X * mk.p_LCom;
    linear += mk.mass_kg * V.head<3>();
    angular += c.cross(mk.mass_kg * V.head<3>()) + I_W * V.tail<3>();
  }
}

double relativeError(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  const double scale = std::max(1.0, b.cwiseAbs().maxCoeff());
  return (a - b).cwiseAbs().maxCoeff() / scale;
}

}  // namespace dynfilter::test
