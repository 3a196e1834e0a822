// dynfilter-offline: a reference motion file in, a physically consistent motion out.
//
//   dynfilter-offline reference.csv -o filtered.csv [--model robot.urdf] [--config cfg.yaml]
//                     [--tick-hz 500] [--slope-deg 5] [--friction 0.8] [--every-tick]
//
// The filter ticks at about --tick-hz (default 500 Hz; the config's dt_s is the real-time
// process's tick and is not used here) against the reference interpolated between its
// frames; for a uniformly sampled reference the tick is a whole fraction of the frame
// period (the loop is io::runOffline, io/offline_run.hpp, shared with the Python binding).
// One output row per reference frame (or per tick with --every-tick),
// plus <output stem>.contacts.csv. Nothing is written unless the whole run succeeds.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <stdexcept>
#include <string>

#include <unistd.h>

#include <CLI/CLI.hpp>

#include "model_cli.hpp"
#include "dynfilter/core/dynamics_filter.hpp"
#include "dynfilter/core/errors.hpp"
#include "dynfilter/core/lie_group.hpp"
#include "dynfilter/backends/make_model.hpp"
#include "dynfilter/qp_engines/qp_engines.hpp"
#include "dynfilter/io/config.hpp"
#include "dynfilter/io/filtered_motion.hpp"
#include "dynfilter/io/offline_run.hpp"
#include "dynfilter/io/reference_motion.hpp"
#include "dynfilter/io/terrain_follow.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"
#include "run_summary.hpp"

namespace {

using namespace dynfilter;

class ProgressBar {
 public:
  explicit ProgressBar(bool enabled) : enabled_(enabled) {}
  void update(double fraction) {
    if (!enabled_) return;
    const int percent = static_cast<int>(100.0 * fraction);
    if (percent == last_) return;
    last_ = percent;
    const int width = 40, filled = width * percent / 100;
    std::fprintf(stderr, "\r[%.*s%*s] %3d %%", filled, "########################################",
                 width - filled, "", percent);
    std::fflush(stderr);
  }
  void done() {
    if (enabled_) std::fprintf(stderr, "\n");
  }

 private:
  bool enabled_;
  int last_ = -1;
};

// Link origins in world for pictures: "time,source,<link>.x,<link>.y,<link>.z,...".
// Written to <path>.tmp and renamed on commit, like the filtered motion.
class BodyPositionWriter {
 public:
  BodyPositionWriter(std::string path, const ModelInfo& info) : path_(std::move(path)) {
    if (path_.empty()) return;
    out_ = std::fopen((path_ + ".tmp").c_str(), "w");
    if (out_ == nullptr) throw std::runtime_error("cannot write " + path_ + ".tmp");
    std::fprintf(out_, "time,source");
    for (const auto& link : info.body_names)
      std::fprintf(out_, ",%s.x,%s.y,%s.z", link.c_str(), link.c_str(), link.c_str());
    std::fprintf(out_, "\n");
    v_ = Eigen::VectorXd::Zero(info.nv);
  }
  ~BodyPositionWriter() {
    if (out_ != nullptr) {
      std::fclose(out_);
      std::remove((path_ + ".tmp").c_str());
    }
  }
  explicit operator bool() const { return out_ != nullptr; }
  void write(IDynamicsModel& model, const char* source, double time_s, const Eigen::VectorXd& q) {
    model.setState(q, v_);
    std::fprintf(out_, "%.9g,%s", time_s, source);
    for (int b = 0; b < static_cast<int>(model.info().body_names.size()); ++b) {
      const Eigen::Vector3d p = model.bodyPose(b).translation();
      std::fprintf(out_, ",%.6f,%.6f,%.6f", p.x(), p.y(), p.z());
    }
    std::fprintf(out_, "\n");
  }
  void commit() {
    if (out_ == nullptr) return;
    const bool ok = std::fclose(out_) == 0;
    out_ = nullptr;
    if (!ok || std::rename((path_ + ".tmp").c_str(), path_.c_str()) != 0)
      throw std::runtime_error("cannot write " + path_);
  }

 private:
  std::string path_;
  std::FILE* out_ = nullptr;
  Eigen::VectorXd v_;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Filter a reference motion into a physically consistent one (Yamane & Nakamura)."};
  std::string reference_path, output_path, model_path = DYNFILTER_DEFAULT_MODEL, config_path;
  std::string backend = "dart", mode;
  double tick_hz = 500.0, slope_deg = NAN, heading_deg = 0.0, friction = NAN;
  bool every_tick = false, quiet = false, no_progress = false, skip_extra_columns = false;
  std::string bodies_path, events_path;
  app.add_option("reference", reference_path, "reference motion CSV (see README)")->required();
  app.add_option("-o,--output", output_path, "filtered motion CSV to write")->required();
  app.add_option("-m,--model", model_path, "URDF model (default: the human figure)");
  dynfilter::tools::ModelCli model_cli;
  dynfilter::tools::addModelOptions(app, model_cli);
  app.add_option("-c,--config", config_path, "YAML configuration (tools/config/default.yaml)");
  app.add_option("--backend", backend, "dynamics backend: dart or ode")
      ->check(CLI::IsMember(availableBackends()));
  app.add_option("--mode", mode, "solver: paper (Eq. 21-23) or qp (contact-consistent QP); "
                 "overrides the config's mode")
      ->check(CLI::IsMember({"paper", "qp"}));
  app.add_option("--tick-hz", tick_hz, "filter rate (Hz)")
      ->check(CLI::PositiveNumber);
  app.add_option("--slope-deg", slope_deg,
                 "ground slope, overrides the config (deg); the plane passes under the "
                 "reference's first base position, and each reference frame's base moves "
                 "with the plane under it (a motion made on level ground follows the slope)");
  app.add_option("--slope-heading-deg", heading_deg, "direction the ground descends (deg)");
  app.add_option("--friction", friction, "ground friction coefficient, overrides the config");
  app.add_flag("--every-tick", every_tick, "write every filter tick, not only reference frames");
  app.add_flag("--skip-extra-columns", skip_extra_columns,
               "skip the reference's columns that are not part of its format instead of rejecting "
               "the file (e.g. a filtered motion, this tool's own output, filtered again)");
  app.add_flag("--no-progress", no_progress, "no progress bar");
  app.add_option("--bodies-csv", bodies_path,
                 "also write every link's world position, reference and filtered, per row "
                 "(for pictures)");
  double preview_s = NAN;
  app.add_option("--preview-s", preview_s,
                 "look-ahead of the balance layer (QP mode), s; default: the whole clip")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--events-csv", events_path,
                 "also write one row per tick that re-seeded, relaxed or fell back: "
                 "time,tick,status,reseed_reason,qp_relaxation,qp_violated,base_error_m,"
                 "base_rotation_rad,max_joint_error_rad,base_tilt_rad,base_heading_rad (qp_violated "
                 "quoted: a comma-separated list of constraint families; tilt: the angle between the "
                 "filtered and reference bases' z axes, heading: their turn about world z; what "
                 "tools/diagnose_reseeds.py reads)");
  app.add_flag("-q,--quiet", quiet, "no summary");
  CLI11_PARSE(app, argc, argv);

  try {
    io::FilterConfig config = config_path.empty() ? io::FilterConfig{} : io::loadFilterConfig(config_path);
    const auto robot = dynfilter::tools::loadRobot(model_path, model_cli);
    for (const auto& w : robot.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
    // The motion is read first (any model of the robot knows its coordinates): a slope
    // given on the command line passes under the motion's first base position.
    const auto coordinates = makeModel(backend, robot, ModelOptions{});
    io::ReferenceReadOptions read_options;
    read_options.allow_extra_columns = skip_extra_columns;
    io::ReferenceMotion motion = io::readReferenceMotion(reference_path, coordinates->info(), read_options);
    if (!motion.ignored_columns.empty()) {
      std::string names;
      for (const std::string& c : motion.ignored_columns) names += (names.empty() ? "" : ", ") + c;
      std::fprintf(stderr, "%s: columns of locked joints not read: %s\n", reference_path.c_str(), names.c_str());
    }
    if (!std::isnan(slope_deg)) {
      const double slope = slope_deg * M_PI / 180.0, heading = heading_deg * M_PI / 180.0;
      const Eigen::VectorXd q0 = motion.frames.front().q;
      const double along = std::cos(heading) * q0[0] + std::sin(heading) * q0[1];
      config.environment.ground = GroundPlane::sloped(
          slope, heading, coordinates->info().floating_base ? std::tan(slope) * along : 0.0,
          config.environment.ground.friction);
      if (coordinates->info().floating_base) {
        // The motion (made on level ground) follows the terrain: base and feet rise or sink
        // with the plane beneath them, the soles turn with it.
        const io::TerrainFollowReport terrain =
            io::followTerrain(motion, *coordinates, config.environment.ground);
        std::fprintf(stderr,
                     "slope: %d feet carried onto the plane, joints changed by %.3f rad RMS, base moved "
                     "by up to %.1f mm, feet within %.1f mm and %.3f rad of their targets\n",
                     terrain.feet, terrain.joint_change_rms_rad, 1e3 * terrain.base_change_max_m,
                     1e3 * terrain.foot_position_error_max_m, terrain.foot_orientation_error_max_rad);
      }
    }
    if (!std::isnan(friction)) config.environment.ground.friction = friction;
    if (!mode.empty()) parseFilterMode(mode, config.filter.mode);
    config.filter.validate();

    ModelOptions model_options;
    model_options.environment = config.environment;
    auto model = makeModel(backend, robot, model_options);

    io::OfflineRunOptions run_options;
    run_options.tick_hz = tick_hz;
    run_options.every_tick = every_tick;
    run_options.preview_s = preview_s;  // NaN: offline the whole clip is known
    std::FILE* events = nullptr;
    if (!events_path.empty()) {
      events = std::fopen((events_path + ".tmp").c_str(), "w");
      if (events == nullptr) throw std::runtime_error("cannot write " + events_path + ".tmp");
      std::fprintf(events, "time,tick,status,reseed_reason,qp_relaxation,qp_violated,base_error_m,"
                           "base_rotation_rad,max_joint_error_rad,base_tilt_rad,base_heading_rad\n");
    }
    const int nb = model->info().floating_base ? 6 : 0;
    io::FilteredMotionWriter writer(output_path, model->info());
    BodyPositionWriter bodies(bodies_path, model->info());
    tools::RunSummary summary(model->info(), jointGroupsOf(*coordinates));
    ProgressBar progress(!no_progress && !quiet && isatty(STDERR_FILENO));
    const auto wall0 = std::chrono::steady_clock::now();
    int written = 0;
    io::runOffline(
        *model, config.filter, motion, run_options, qp_engines::factory(config.filter.qp.solver.engine),
        [&](const io::OfflineTick& tick) {
          const FilterOutput& out = *tick.output;
          if (tick.index == 0 && config.filter.task.enabled && config.filter.task.body.empty() &&
              !quiet)
            std::fprintf(stderr, "task point on \"%s\" (task.body not configured: the model's trunk)\n",
                         model->info().body_names[static_cast<std::size_t>(tick.filter->taskBody())].c_str());
          summary.add(out);
          if (events != nullptr &&
              (out.status & (kStatusReseeded | kStatusQpRelaxed | kStatusQpFallback))) {
            char violated[96];
            const Eigen::VectorXd& e = out.tracking_error;
            // The base's orientation error split: a lean (a fall) against a lagging turn.
            const TiltHeading split = nb ? tiltAndHeading(basePoseFromConfiguration(tick.reference->q).linear(),
                                                          basePoseFromConfiguration(out.q).linear())
                                         : TiltHeading{};
            std::fprintf(events, "%.6f,%ld,%u,%s,%u,\"%s\",%.6g,%.6g,%.6g,%.6g,%.6g\n", tick.time_s, tick.index,
                         out.status, (out.status & kStatusReseeded) ? toString(out.reseed_reason) : "",
                         out.qp_relaxation,
                         describeQpFamilies(out.qp_violated, violated, sizeof violated),
                         nb ? e.head<3>().norm() : 0.0, nb ? e.segment<3>(3).norm() : 0.0,
                         model->nj() > 0 ? e.tail(model->nj()).cwiseAbs().maxCoeff() : 0.0,
                         split.tilt_rad, split.heading_rad);
          }
          if (tick.row) {
            writer.append(out, tick.row_status);
            ++written;
            if (bodies) {
              // After the tick, so the filter's next setState is unaffected.
              bodies.write(*model, "reference", tick.reference->time_s, tick.reference->q);
              bodies.write(*model, "filtered", out.time_s, out.q);
            }
          }
          progress.update(static_cast<double>(tick.index + 1) / static_cast<double>(tick.count));
        });
    progress.done();
    writer.commit();
    bodies.commit();
    if (events != nullptr) {
      const bool ok = std::fclose(events) == 0;
      if (!ok || std::rename((events_path + ".tmp").c_str(), events_path.c_str()) != 0)
        throw std::runtime_error("cannot write " + events_path);
    }
    const double t0 = motion.frames.front().time_s, t_end = motion.frames.back().time_s;
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
    if (!quiet) {
      std::fprintf(stderr, "wrote %s and %s\n", writer.path().c_str(), writer.contactsPath().c_str());
      summary.print(stderr, written, t_end - t0, wall);
    }
    return 0;
  } catch (const io::InputError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const ModelError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
