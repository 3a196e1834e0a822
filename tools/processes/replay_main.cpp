// dynfilter-replay — publishes reference motion files in real time.
//
//   dynfilter-replay walk.csv [jump.bvh ...] [--mapping jump.yaml ...] [--speed 1] [--loop]
//                    [--start-s 0] [--switch 5.0:1 ...] [--rate-hz R] [--duration-s D]
//
// Clips are reference motion CSV files or BVH captures; every .bvh clip takes the next
// --mapping (retargeting to the model, README "Motion capture (BVH)").
//
// Clips switch on a schedule (--switch <seconds>:<clip index>) or from the keyboard: type
// a clip number (or "n" for the next one) and Enter. Frames carry the wall-clock utime.
#include <atomic>
#include <cstdio>
#include <exception>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include <unistd.h>

#include <CLI/CLI.hpp>
#include <lcm/lcm-cpp.hpp>

#include "dynfilter/backends/make_model.hpp"
#include "dynfilter/io/reference_motion.hpp"
#include "dynfilter/io/reference_cleanup.hpp"
#include "dynfilter/io/retarget.hpp"
#include "dynfilter/lcm/messages.hpp"
#include "dynfilter/realtime/replay_player.hpp"
#include "dynfilter/proxqp/proxqp_solver.hpp"
#include "model_cli.hpp"
#include "process_support.hpp"

namespace {
using namespace dynfilter;
namespace msg = dynfilter::messages;

struct Switch {
  double at_s;
  int clip;
};
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"dynfilter-replay: stream reference motion files over LCM in real time."};
  std::vector<std::string> files;
  std::vector<std::string> switches, mappings;
  std::string model_path = DYNFILTER_DEFAULT_MODEL, url, channel = msg::kReferenceChannel;
  realtime::ReplayOptions options;
  double rate_hz = 0.0, duration_s = 0.0;
  app.add_option("clips", files, "reference motion CSV files or BVH captures")->required();
  app.add_option("--mapping", mappings, "retargeting mapping YAML, one per .bvh clip, in order");
  bool no_cleanup = false;
  app.add_flag("--no-cleanup", no_cleanup,
               "stream a .bvh clip as retargeted, without dynfilter-bvh2ref's reference clean-up");
  app.add_option("-m,--model", model_path, "URDF model the files are for");
  dynfilter::tools::ModelCli model_cli;
  dynfilter::tools::addModelOptions(app, model_cli);
  app.add_option("--speed", options.speed, "playback speed factor")->check(CLI::PositiveNumber);
  app.add_flag("--loop", options.loop, "restart a clip at its end");
  app.add_option("--start-s", options.start_offset_s, "start every clip this far in (s)");
  app.add_option("--switch", switches, "<seconds>:<clip index>, e.g. 5:1 (repeatable)");
  app.add_option("--rate-hz", rate_hz, "publishing rate (default: the first clip's frame rate)");
  app.add_option("--duration-s", duration_s, "stop after this long (0: at the end or on SIGINT)");
  app.add_option("--lcm-url", url, "LCM URL (default: $LCM_DEFAULT_URL)");
  app.add_option("--channel", channel, "reference channel");
  CLI11_PARSE(app, argc, argv);

  try {
    auto model = makeModel("dart", dynfilter::tools::loadRobot(model_path, model_cli), ModelOptions{});
    const ModelInfo& info = model->info();
    std::vector<realtime::Clip> clips;
    std::size_t next_mapping = 0;
    for (const auto& f : files) {
      if (f.size() > 4 && f.compare(f.size() - 4, 4, ".bvh") == 0) {
        if (next_mapping >= mappings.size())
          throw std::invalid_argument(f + ": a BVH clip needs a --mapping (one per .bvh, in order)");
        const auto mapping = io::readRetargetMapping(mappings[next_mapping++]);
        const auto retargeted = io::retargetBvhFile(f, mapping, *model);
        std::fprintf(stderr, "%s", io::formatLimitReport(retargeted).c_str());
        if (no_cleanup) {
          clips.push_back({f, retargeted.motion.frames});
        } else {  // the same reference as dynfilter-bvh2ref writes
          const io::CleanupResult cleaned = io::cleanupReference(retargeted.motion, *model, mapping.cleanup, proxqp::factory());
          std::fprintf(stderr, "%s", io::formatCleanupReport(cleaned.report).c_str());
          clips.push_back({f, cleaned.motion.frames});
        }
      } else {
        clips.push_back({f, io::readReferenceMotion(f, info).frames});
      }
    }
    if (next_mapping != mappings.size())
      throw std::invalid_argument("more --mapping files than .bvh clips");
    std::vector<Switch> schedule;
    for (const auto& s : switches) {
      const auto colon = s.find(':');
      if (colon == std::string::npos) throw std::invalid_argument("--switch wants <seconds>:<clip>, got " + s);
      schedule.push_back({std::stod(s.substr(0, colon)), std::stoi(s.substr(colon + 1))});
      if (schedule.back().clip < 0 || schedule.back().clip >= static_cast<int>(clips.size()))
        throw std::invalid_argument("--switch " + s + ": no such clip");
    }
    realtime::ReplayPlayer player(std::move(clips), options, info.floating_base);
    if (rate_hz <= 0.0) rate_hz = player.frameRate();

    lcm::LCM lcm(url);
    if (!lcm.good()) throw std::runtime_error("cannot open LCM");
    processes::installStopHandlers();
    std::atomic<int> requested{-1};
    if (isatty(STDIN_FILENO)) {
      std::thread([&requested, &player] {
        std::string line;
        while (std::getline(std::cin, line)) {
          if (line == "n") requested = (player.currentClip() + 1) % static_cast<int>(player.clips().size());
          else if (!line.empty() && std::isdigit(static_cast<unsigned char>(line[0]))) requested = std::stoi(line);
        }
      }).detach();
    }
    std::fprintf(stderr, "dynfilter-replay: %zu clip(s) at %.1f Hz, speed %.2f%s on %s\n",
                 player.clips().size(), rate_hz, options.speed, options.loop ? ", looping" : "",
                 channel.c_str());

    reference_frame_t message;
    std::vector<std::uint8_t> buffer;
    ReferenceFrame frame(info.nq, info.nv);
    processes::Ticker ticker(rate_hz);
    const double start = processes::nowSeconds();
    player.switchTo(0, 0.0);
    std::size_t next_switch = 0;
    std::int64_t sequence = 0;
    while (!processes::g_stop) {
      ticker.wait();
      const double t = processes::nowSeconds() - start;
      if (duration_s > 0.0 && t >= duration_s) break;
      while (next_switch < schedule.size() && schedule[next_switch].at_s <= t) {
        player.switchTo(schedule[next_switch].clip, t);
        std::fprintf(stderr, "dynfilter-replay: t = %.2f s, clip %d\n", t, schedule[next_switch].clip);
        ++next_switch;
      }
      const int want = requested.exchange(-1);
      if (want >= 0 && want < static_cast<int>(player.clips().size())) player.switchTo(want, t);
      const bool running = player.frameAt(t, frame);
      msg::fillReferenceFrame(info, frame, processes::nowMicros(), ++sequence, message);
      lcm.publish(channel, buffer.data(), msg::encodeMessage(message, buffer));
      if (!running && duration_s <= 0.0) break;
    }
    std::fprintf(stderr, "dynfilter-replay: published %lld frames\n", static_cast<long long>(sequence));
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dynfilter-replay: error: %s\n", e.what());
    return 2;
  }
}
