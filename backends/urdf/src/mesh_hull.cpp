#include "mesh_hull.hpp"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <stdexcept>

#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <LinearMath/btConvexHullComputer.h>

namespace dynfilter::urdf {
namespace {

namespace fs = std::filesystem;

bool isFile(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

std::vector<std::string> splitColonList(const char* list) {
  std::vector<std::string> out;
  if (list == nullptr) return out;
  std::string s(list);
  std::size_t start = 0;
  while (start <= s.size()) {
    const std::size_t end = s.find(':', start);
    const std::string item = s.substr(start, end == std::string::npos ? end : end - start);
    if (!item.empty()) out.push_back(item);
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return out;
}

void collectVertices(const aiScene& scene, const aiNode& node, const aiMatrix4x4& parent,
                     const Eigen::Vector3d& scale, std::vector<Eigen::Vector3d>& out) {
  const aiMatrix4x4 T = parent * node.mTransformation;
  for (unsigned m = 0; m < node.mNumMeshes; ++m) {
    const aiMesh& mesh = *scene.mMeshes[node.mMeshes[m]];
    for (unsigned i = 0; i < mesh.mNumVertices; ++i) {
      const aiVector3D p = T * mesh.mVertices[i];
      out.emplace_back(scale.x() * p.x, scale.y() * p.y, scale.z() * p.z);
    }
  }
  for (unsigned c = 0; c < node.mNumChildren; ++c)
    collectVertices(scene, *node.mChildren[c], T, scale, out);
}

}  // namespace

std::string resolveMeshUri(const std::string& uri, const std::string& base_directory,
                           const std::vector<std::string>& package_paths) {
  const std::string kPackage = "package://";
  const std::string kFile = "file://";
  if (uri.rfind(kPackage, 0) == 0) {
    std::string rest = uri.substr(kPackage.size());
    rest.erase(0, rest.find_first_not_of('/'));  // "package:///name/..." occurs in the wild
    const std::size_t slash = rest.find('/');
    if (slash == std::string::npos || slash == 0)
      throw std::runtime_error("malformed package URI \"" + uri + "\"");
    const std::string package = rest.substr(0, slash);
    const std::string inside = rest.substr(slash + 1);
    std::vector<std::string> roots = package_paths;
    for (const auto& r : splitColonList(std::getenv("ROS_PACKAGE_PATH"))) roots.push_back(r);
    for (const auto& root : roots) {
      const fs::path dir(root);
      if (dir.filename() == package && isFile(dir / inside)) return (dir / inside).string();
      if (isFile(dir / package / inside)) return (dir / package / inside).string();
    }
    // Last, the folders above the URDF: a description installed as <pkg>/urdf/robot.urdf
    // (or beside a folder named <pkg>) resolves without any path given.
    if (!base_directory.empty()) {
      for (fs::path dir = fs::absolute(base_directory); !dir.empty(); dir = dir.parent_path()) {
        if (dir.filename() == package && isFile(dir / inside)) return (dir / inside).string();
        if (isFile(dir / package / inside)) return (dir / package / inside).string();
        if (dir == dir.parent_path()) break;
      }
      roots.push_back("the folders above " + base_directory);
    }
    std::string searched;
    for (const auto& r : roots) searched += (searched.empty() ? "" : ", ") + r;
    throw std::runtime_error("mesh \"" + uri + "\" not found: package \"" + package +
                             "\" is in none of " +
                             (searched.empty() ? std::string("(no package path: give "
                                                             "--package-path or set "
                                                             "ROS_PACKAGE_PATH)")
                                               : "[" + searched + "]"));
  }
  fs::path path = uri.rfind(kFile, 0) == 0 ? fs::path(uri.substr(kFile.size())) : fs::path(uri);
  if (path.is_relative() && !base_directory.empty()) path = fs::path(base_directory) / path;
  if (!isFile(path)) throw std::runtime_error("mesh file \"" + path.string() + "\" not found");
  return path.string();
}

ConvexHull convexHullOfMesh(const std::string& path, const Eigen::Vector3d& scale) {
  Assimp::Importer importer;
  // URDF meshes are in the link's axes: keep COLLADA's own up axis (assimp would turn it
  // to y-up) but its <unit> scale.
  importer.SetPropertyBool(AI_CONFIG_IMPORT_COLLADA_IGNORE_UP_DIRECTION, true);
  const aiScene* scene = importer.ReadFile(path, aiProcess_JoinIdenticalVertices);
  if (scene == nullptr || scene->mRootNode == nullptr)
    throw std::runtime_error("cannot read mesh \"" + path + "\": " + importer.GetErrorString());
  std::vector<Eigen::Vector3d> points;
  collectVertices(*scene, *scene->mRootNode, aiMatrix4x4(), scale, points);
  if (points.size() < 4) throw std::runtime_error("mesh \"" + path + "\" has fewer than 4 vertices");

  btConvexHullComputer computer;
  computer.compute(points.data()->data(), static_cast<int>(sizeof(Eigen::Vector3d)),
                   static_cast<int>(points.size()), 0.0, 0.0);
  if (computer.vertices.size() < 4 || computer.faces.size() < 4)
    throw std::runtime_error("mesh \"" + path + "\" is flat: its convex hull has no volume");

  ConvexHull hull;
  // Bullet's hull vertices are its (single-precision) copies of input points: take the
  // input point each one came from, so the hull is exact in double.
  if (computer.original_vertex_index.size() != computer.vertices.size())
    throw std::runtime_error("mesh \"" + path + "\": Bullet's convex hull gave no input index per vertex");
  for (int i = 0; i < computer.vertices.size(); ++i)
    hull.vertices_S.push_back(points[static_cast<std::size_t>(computer.original_vertex_index[i])]);
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& v : hull.vertices_S) centroid += v;
  centroid /= static_cast<double>(hull.vertices_S.size());
  for (int f = 0; f < computer.faces.size(); ++f) {
    std::vector<int> loop;
    const btConvexHullComputer::Edge* first = &computer.edges[computer.faces[f]];
    const btConvexHullComputer::Edge* e = first;
    do {
      loop.push_back(e->getTargetVertex());
      e = e->getNextEdgeOfFace();
    } while (e != first && loop.size() <= hull.vertices_S.size());
    // Newell's normal of the loop, then oriented away from the centroid.
    Eigen::Vector3d n = Eigen::Vector3d::Zero();
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (std::size_t i = 0; i < loop.size(); ++i) {
      const Eigen::Vector3d& a = hull.vertices_S[static_cast<std::size_t>(loop[i])];
      const Eigen::Vector3d& b = hull.vertices_S[static_cast<std::size_t>(loop[(i + 1) % loop.size()])];
      n += a.cross(b);
      c += a;
    }
    c /= static_cast<double>(loop.size());
    if (n.norm() == 0.0) continue;
    n.normalize();
    if (n.dot(c - centroid) < 0.0) {
      n = -n;
      std::reverse(loop.begin(), loop.end());
    }
    hull.faces.push_back(loop);
    hull.planes_S.emplace_back(n.x(), n.y(), n.z(), n.dot(c));
  }
  return hull;
}

}  // namespace dynfilter::urdf
