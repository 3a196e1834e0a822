// dynfilter-bvh2ref: retargets a BVH motion-capture clip onto the human figure and writes
// a reference motion CSV for dynfilter-offline.
//
//   dynfilter-bvh2ref clip.bvh --mapping m.yaml -o reference.csv [--model urdf] [--clamp]

#include <cmath>
#include <cstdio>
#include <exception>
#include <string>

#include <CLI/CLI.hpp>

#include "dynfilter/backends/make_model.hpp"
#include "dynfilter/io/retarget.hpp"

int main(int argc, char** argv) {
  CLI::App app{"Retarget a BVH clip onto the human figure; writes a reference motion CSV."};
  std::string bvh_path, mapping_path, out_path, model_path = DYNFILTER_DEFAULT_MODEL;
  std::string backend = "dart";
  bool clamp = false;
  app.add_option("bvh", bvh_path, "BVH file")->required();
  app.add_option("--mapping,-m", mapping_path, "mapping YAML")->required();
  app.add_option("-o,--output", out_path, "reference motion CSV to write")->required();
  app.add_option("--model", model_path, "URDF of the figure")->capture_default_str();
  app.add_option("--backend", backend, "dynamics backend for kinematics")->capture_default_str();
  app.add_flag("--clamp", clamp, "clamp joint angles into the model's limits");
  CLI11_PARSE(app, argc, argv);

  try {
    dynfilter::io::RetargetMapping mapping = dynfilter::io::readRetargetMapping(mapping_path);
    if (clamp) mapping.clamp_to_limits = true;
    auto model = dynfilter::loadModel(backend, model_path, {});
    const dynfilter::io::RetargetResult result =
        dynfilter::io::retargetBvhFile(bvh_path, mapping, *model);
    dynfilter::io::writeReferenceMotionCsv(out_path, model->info(), result.motion);

    const auto& frames = result.motion.frames;
    const Eigen::Vector3d p0 = frames.front().q.head<3>(), p1 = frames.back().q.head<3>();
    std::printf("%s: %zu frames (BVH frames from %d), %.3f s, ground offset %+.4f m\n",
                out_path.c_str(), frames.size(), result.first_bvh_frame,
                frames.back().time_s, result.ground_offset_m);
    std::printf("base: start (%.3f, %.3f, %.3f) m, end (%.3f, %.3f, %.3f) m, horizontal %.3f m\n",
                p0.x(), p0.y(), p0.z(), p1.x(), p1.y(), p1.z(), (p1 - p0).head<2>().norm());
    if (!result.unmapped_joints.empty()) {
      std::printf("joints left at 0 (segments not mapped):");
      for (const auto& j : result.unmapped_joints) std::printf(" %s", j.c_str());
      std::printf("\n");
    }
    std::printf("joint limits:\n%s", dynfilter::io::formatLimitReport(result).c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dynfilter-bvh2ref: %s\n", e.what());
    return 1;
  }
}
