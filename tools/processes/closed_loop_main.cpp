// dynfilter-closed-loop — the LCM closed loop (dynfilter --use-measured-state,
// dynfilter-sim --servo-error-rad 0, dynfilter-replay) in one process, deterministic and
// faster than real time (closed_loop_sim.hpp): where and why a clip makes the robot fall.
//
//   dynfilter-closed-loop walk.csv [--robot ode|dart] [--seconds 10] [--mode qp|paper]
//       [--no-balance-preview] [--no-align-reference] [--stream-blend-s 2]
//       [--sender-gap-s 0.08 --sender-gap-every-s 0.5] [--log run.txt]
//
// Prints the lowest base height and when, when the robot fell (base below 0.5 m), the
// re-seeds by reason, the status bits seen, and when the robot's engine refused a step (a
// diverged simulation ends the run); exits 1 when it fell or its engine refused a step.
#include <cstdio>
#include <exception>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "closed_loop_sim.hpp"
#include "dynfilter/backends/make_model.hpp"
#include "dynfilter/io/config.hpp"
#include "dynfilter/io/reference_motion.hpp"
#include "dynfilter/io/retarget.hpp"
#include "model_cli.hpp"

int main(int argc, char** argv) {
  using namespace dynfilter;
  CLI::App app{"dynfilter-closed-loop: the real-time closed loop on a simulated robot, in one process."};
  std::vector<std::string> files, mappings;
  std::string model_path = DYNFILTER_DEFAULT_MODEL, config_path, mode = "qp", log_path;
  processes::ClosedLoopSetup setup;
  app.add_option("clips", files, "reference motion CSV files or BVH captures (the first is played)")->required();
  app.add_option("--mapping", mappings, "retargeting mapping YAML, one per .bvh clip, in order");
  app.add_option("-m,--model", model_path, "URDF model (default: the human figure)");
  tools::ModelCli model_cli;
  tools::addModelOptions(app, model_cli);
  app.add_option("-c,--config", config_path, "filter YAML configuration");
  app.add_option("--mode", mode, "paper or qp")->check(CLI::IsMember({"paper", "qp"}));
  app.add_option("--robot", setup.robot_engine, "the robot's engine")->check(CLI::IsMember({"ode", "dart"}));
  app.add_option("--seconds", setup.seconds, "simulated time after the replay starts")->check(CLI::PositiveNumber);
  app.add_option("--replay-start-s", setup.replay_start_s, "the filter holds the standing pose this long");
  app.add_option("--start-s", setup.replay.start_offset_s, "start the clip this far in (s)");
  app.add_option("--speed", setup.replay.speed, "playback speed")->check(CLI::PositiveNumber);
  app.add_flag("--loop", setup.replay.loop, "restart the clip at its end");
  app.add_flag("--balance-preview,!--no-balance-preview", setup.realtime.balance_preview,
               "the reference delay's frames as the balance layer's look-ahead (default: on)");
  app.add_flag("--align-reference,!--no-align-reference", setup.realtime.align_to_robot,
               "place the stream under the robot (default: on)");
  app.add_option("--stream-blend-s", setup.realtime.stream_blend_s, "soft start of a stream (s)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--reference-delay-s", setup.realtime.reference_delay_s, "play the reference this far behind");
  app.add_option("--sender-gap-s", setup.gap_s, "the sender is descheduled this long ...")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--sender-gap-every-s", setup.gap_every_s, "... this often (0: never)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--sender-gap-first-s", setup.gap_first_s, "first gap this long after the replay starts")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--state-delay-s", setup.state_delay_s,
                 "the robot's states are held back this long (the robot steps on), then arrive together")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--state-delay-at-s", setup.state_delay_at_s, "... from this long after the replay starts");
  app.add_flag("--gap-stalls-robot", setup.gap_stalls_robot,
               "the robot stalls with the sender (its CPU frozen): no step, no state during a gap");
  app.add_option("--log", log_path, "one line a tick (closed_loop_sim.hpp)");
  CLI11_PARSE(app, argc, argv);

  try {
    io::FilterConfig config = config_path.empty() ? io::FilterConfig{} : io::loadFilterConfig(config_path);
    setup.filter = config.filter;
    setup.filter.dt_s = 1e-3;
    parseFilterMode(mode, setup.filter.mode);
    const urdf::RobotDescription robot = tools::loadRobot(model_path, model_cli);
    auto model = makeModel("dart", robot, ModelOptions{});
    std::vector<realtime::Clip> clips;
    std::size_t next_mapping = 0;
    for (const std::string& f : files) {
      if (f.size() > 4 && f.compare(f.size() - 4, 4, ".bvh") == 0) {
        if (next_mapping >= mappings.size()) throw std::invalid_argument(f + ": a BVH clip needs a --mapping");
        const auto mapping = io::readRetargetMapping(mappings[next_mapping++]);
        clips.push_back({f, io::retargetBvhFile(f, mapping, *model).motion.frames});
      } else {
        clips.push_back({f, io::readReferenceMotion(f, model->info()).frames});
      }
    }
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> log(
        log_path.empty() ? nullptr : std::fopen(log_path.c_str(), "w"), &std::fclose);
    if (!log_path.empty() && !log) throw std::runtime_error("cannot write " + log_path);
    const processes::ClosedLoopResult r = processes::runClosedLoop(robot, setup, clips, log.get());
    std::printf("%s on %s, %s mode, preview %s, align %s, blend %.2f s: %d ticks, %llu frames sent\n",
                files.front().c_str(), setup.robot_engine.c_str(), mode.c_str(),
                setup.realtime.balance_preview ? "on" : "off", setup.realtime.align_to_robot ? "on" : "off",
                setup.realtime.stream_blend_s, r.ticks, static_cast<unsigned long long>(r.frames_sent));
    std::printf("lowest base %.4f m at %.3f s, max tilt %.4f rad; ", r.min_base_z_m, r.min_base_z_time_s,
                r.max_tilt_rad);
    if (r.fell_at_s >= 0.0) std::printf("FELL at %.3f s (base below %.2f m)\n", r.fell_at_s, setup.fallen_below_m);
    else std::printf("stood\n");
    if (r.engine_refused_at_s >= 0.0)
      std::printf("the robot's engine refused a step at %.3f s (%s): the run ended there\n", r.engine_refused_at_s,
                  r.engine_error.c_str());
    std::printf("re-seeds %llu", static_cast<unsigned long long>(r.reseeds));
    for (int i = 1; i < 7; ++i)
      if (r.reseed_ticks_by_reason[static_cast<std::size_t>(i)] > 0)
        std::printf(", %s: %llu", toString(static_cast<ReseedReason>(i)),
                    static_cast<unsigned long long>(r.reseed_ticks_by_reason[static_cast<std::size_t>(i)]));
    std::printf("; status bits seen 0x%x\n", r.status_union);
    return r.fell_at_s >= 0.0 || r.engine_refused_at_s >= 0.0 ? 1 : 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dynfilter-closed-loop: error: %s\n", e.what());
    return 2;
  }
}
