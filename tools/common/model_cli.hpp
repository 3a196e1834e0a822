#pragma once
// The model options every tool that takes --model shares: where package:// meshes are,
// which joints to lock, and --verbose (what the URDF held that the model ignores).
#include <cstdio>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "dynfilter/urdf/urdf_loader.hpp"

namespace dynfilter::tools {

struct ModelCli {
  urdf::UrdfLoadOptions load;
  bool verbose = false;
};

/// Adds --package-path, --lock-joints and --verbose to @p app.
inline void addModelOptions(CLI::App& app, ModelCli& cli) {
  app.add_option("--package-path", cli.load.package_paths,
                 "directory for package:// meshes (a package or a folder of packages; "
                 "repeatable, searched before ROS_PACKAGE_PATH)");
  app.add_option("--lock-joints", cli.load.lock_joints,
                 "weld joints: names or glob patterns (* ?), comma-separated, each "
                 "optionally =position (rad or m; default 0)")
      ->delimiter(',');
  app.add_flag("--verbose", cli.verbose,
               "list the URDF elements the model ignores (simulator tags, visuals, ...)");
}

/// Loads @p urdf_path with the shared options; with --verbose, prints the ignored
/// elements and the loader's warnings to stderr once. Always says so when a model whose
/// base floats has no collision geometry at all (a visual-only description): it touches
/// neither the ground nor a box, and no filter or simulator can stand it up.
inline urdf::RobotDescription loadRobot(const std::string& urdf_path, const ModelCli& cli,
                                        bool floating_base = true) {
  urdf::RobotDescription robot = urdf::loadUrdfFile(urdf_path, cli.load);
  bool any_collision = false;
  for (const auto& link : robot.links) any_collision = any_collision || !link.collisions.empty();
  if (floating_base && !any_collision)
    std::fprintf(stderr,
                 "warning: %s: no <link> has <collision> geometry: the model touches neither the "
                 "ground nor a box, so it has nothing to stand on (add collision shapes, e.g. boxes "
                 "under the feet)\n",
                 urdf_path.c_str());
  if (cli.verbose) {
    for (const auto& e : robot.ignored_elements) std::fprintf(stderr, "ignored: %s\n", e.c_str());
    for (const auto& w : robot.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
    if (!cli.load.lock_joints.empty())
      std::fprintf(stderr, "after --lock-joints: %zu fixed joints, %zu moving\n",
                   robot.joints.size() - robot.moving_joints.size() - robot.mimic_joints.size(),
                   robot.moving_joints.size());
  }
  return robot;
}

}  // namespace dynfilter::tools
