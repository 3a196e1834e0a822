// dynfilter-bvh2ref: retargets a BVH motion-capture clip onto a URDF model (the human figure
// by default), cleans the reference up (contact schedule, stance feet fixed on the ground,
// joints inside their limits) and writes a reference motion CSV for dynfilter-offline,
// with its contact schedule beside it.
//
//   dynfilter-bvh2ref clip.bvh --mapping m.yaml -o reference.csv [--model urdf]
//       [--allow-unmapped] [--no-cleanup] [--clamp] [--report report.txt]
//       [--start-s S] [--end-s E]
//   dynfilter-bvh2ref clip.bvh --suggest-mapping m.yaml [--model urdf]

#include <cmath>
#include <cstdio>
#include <exception>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string>

#include <CLI/CLI.hpp>

#include "dynfilter/backends/make_model.hpp"
#include "model_cli.hpp"
#include "dynfilter/io/mapping_suggestion.hpp"
#include "dynfilter/io/reference_cleanup.hpp"
#include "dynfilter/io/retarget.hpp"
#include "dynfilter/proxqp/proxqp_solver.hpp"

namespace {
// reference.csv -> reference.stance.csv
std::string contactsPath(const std::string& out) {
  const std::string ext = ".csv";
  const bool has_ext = out.size() > ext.size() && out.compare(out.size() - ext.size(), ext.size(), ext) == 0;
  return (has_ext ? out.substr(0, out.size() - ext.size()) : out) + ".stance.csv";
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Retarget a BVH clip onto a URDF model; writes a reference motion CSV and its "
               "contact schedule (<output>.stance.csv)."};
  std::string bvh_path, mapping_path, out_path, model_path = DYNFILTER_DEFAULT_MODEL;
  std::string backend = "dart", report_path;
  bool clamp = false, allow_unmapped = false, no_cleanup = false;
  double start_s = 0.0, end_s = std::numeric_limits<double>::infinity();
  app.add_option("bvh", bvh_path, "BVH file")->required();
  std::string suggest_path;
  auto* mapping_opt = app.add_option("--mapping,-m", mapping_path, "mapping YAML");
  auto* out_opt = app.add_option("-o,--output", out_path, "reference motion CSV to write");
  auto* suggest_opt = app.add_option(
      "--suggest-mapping", suggest_path,
      "write a first mapping of the BVH onto the model, found from the structure of both, to this "
      "file and stop (review it, then retarget with --mapping)");
  suggest_opt->excludes(mapping_opt)->excludes(out_opt);
  app.add_option("--model", model_path, "URDF of the robot")->capture_default_str();
  app.add_option("--backend", backend, "dynamics backend for kinematics")->capture_default_str();
  app.add_flag("--clamp", clamp, "clamp joint angles into the model's limits (without clean-up)");
  app.add_flag("--allow-unmapped", allow_unmapped,
               "hold joints between no two mapped links at their neutral value instead of failing");
  app.add_flag("--no-cleanup", no_cleanup,
               "no clean-up (contact schedule, stance feet on the ground, joint limits)");
  app.add_option("--report", report_path, "also write the report to this file");
  auto* start_opt = app.add_option("--start-s", start_s,
                                   "retarget the clip from this time on (s; 0 is the first frame the "
                                   "mapping keeps, after its skip_frames); the reference starts at 0 s");
  auto* end_opt = app.add_option("--end-s", end_s, "retarget the clip up to this time (s, same clock)");
  start_opt->excludes(suggest_opt);
  end_opt->excludes(suggest_opt);
  dynfilter::tools::ModelCli model_cli;
  dynfilter::tools::addModelOptions(app, model_cli);
  CLI11_PARSE(app, argc, argv);
  if (suggest_path.empty() && (mapping_path.empty() || out_path.empty())) {
    std::fprintf(stderr, "dynfilter-bvh2ref: --mapping and --output are required (or --suggest-mapping)\n");
    return 2;
  }

  try {
    if (!suggest_path.empty()) {
      auto model = dynfilter::makeModel(backend, dynfilter::tools::loadRobot(model_path, model_cli), {});
      dynfilter::io::BvhReadOptions read;
      read.detect_t_pose = true;
      const dynfilter::io::BvhMotion bvh = dynfilter::io::readBvh(bvh_path, read);
      const dynfilter::io::MappingSuggestion suggestion =
          dynfilter::io::suggestMapping(bvh, *model, bvh.skipped_frames);
      std::ofstream file(suggest_path);
      file << suggestion.yaml;
      if (!file) throw std::runtime_error("cannot write " + suggest_path);
      std::printf("%s", suggestion.yaml.c_str());
      for (const std::string& note : suggestion.notes) std::printf("note: %s\n", note.c_str());
      std::printf("wrote %s\n", suggest_path.c_str());
      return 0;
    }
    dynfilter::io::RetargetMapping mapping = dynfilter::io::readRetargetMapping(mapping_path);
    if (clamp) mapping.clamp_to_limits = true;
    if (allow_unmapped) mapping.allow_unmapped = true;
    auto model = dynfilter::makeModel(backend, dynfilter::tools::loadRobot(model_path, model_cli), {});
    const dynfilter::io::RetargetResult result =
        dynfilter::io::retargetBvhFile(bvh_path, mapping, *model, start_s, end_s);

    std::string report;
    char line[512];
    const auto& frames = result.motion.frames;
    const Eigen::Vector3d p0 = frames.front().q.head<3>(), p1 = frames.back().q.head<3>();
    std::snprintf(line, sizeof line,
                  "%s: %zu frames (BVH frames from %d), %.3f s, %s mode, ground offset %+.4f m\n",
                  out_path.c_str(), frames.size(), result.first_bvh_frame, frames.back().time_s,
                  mapping.mode == dynfilter::io::RetargetMode::kIk ? "IK" : "chain",
                  result.ground_offset_m);
    report += line;
    std::snprintf(line, sizeof line,
                  "base: start (%.3f, %.3f, %.3f) m, end (%.3f, %.3f, %.3f) m, horizontal %.3f m\n",
                  p0.x(), p0.y(), p0.z(), p1.x(), p1.y(), p1.z(), (p1 - p0).head<2>().norm());
    report += line;
    if (!result.unmapped_joints.empty()) {
      report += "joints held at their neutral value (between no two mapped links):";
      for (const auto& j : result.unmapped_joints) report += " " + j;
      report += "\n";
    }
    for (const auto& sole : result.soles) {
      if (sole.levelled)
        std::snprintf(line, sizeof line, "sole %s levelled in stance: turned %.1f deg (%d stance frames)\n",
                      sole.link.c_str(), sole.angle_rad * 180.0 / M_PI, sole.stance_frames);
      else
        std::snprintf(line, sizeof line, "sole %s not levelled: %d stance frames (< 10)\n",
                      sole.link.c_str(), sole.stance_frames);
      report += line;
    }
    if (!result.targets.empty()) report += dynfilter::io::formatTargetReport(result);
    report += "joint limits (retargeted):\n" + dynfilter::io::formatLimitReport(result);

    dynfilter::io::ReferenceMotion motion = result.motion;
    if (!no_cleanup) {
      dynfilter::io::CleanupResult cleaned =
          dynfilter::io::cleanupReference(result.motion, *model, mapping.cleanup, dynfilter::proxqp::factory());
      motion = std::move(cleaned.motion);
      const std::string contacts = contactsPath(out_path);
      dynfilter::io::writeContactScheduleCsv(contacts, cleaned.schedule);
      report += dynfilter::io::formatCleanupReport(cleaned.report);
      report += "contact schedule: " + contacts + "\n";
    }
    dynfilter::io::writeReferenceMotionCsv(out_path, model->info(), motion);
    std::fputs(report.c_str(), stdout);
    if (!report_path.empty()) {
      std::ofstream out(report_path);
      out << report;
      if (!out) throw std::runtime_error("cannot write " + report_path);
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dynfilter-bvh2ref: %s\n", e.what());
    return 1;
  }
}
