// Writes the LCM seed corpus of lcm_fuzz: encoded reference_frame_t and robot_state_t
// messages for the human figure (floating and fixed base), as the processes send them.
// Usage: dynfilter_fuzz_lcm_seeds <output directory>
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "dynfilter/lcm/messages.hpp"
#include "fuzz_support.hpp"

namespace dm = dynfilter::messages;

namespace {
std::string g_dir;

template <class Message>
void write(const Message& msg, const std::string& name) {
  std::vector<std::uint8_t> buffer;
  const int size = dm::encodeMessage(msg, buffer);
  if (size < 0) {
    std::fprintf(stderr, "cannot encode %s\n", name.c_str());
    std::exit(1);
  }
  std::ofstream out(g_dir + "/" + name, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(buffer.data()), size);
  std::printf("%s (%d bytes)\n", name.c_str(), size);
}

dynfilter::ReferenceFrame frameFor(const dynfilter::ModelInfo& info) {
  dynfilter::ReferenceFrame frame(info.nq, info.nv);
  frame.q = info.neutralConfiguration();
  for (int j = 0; j < info.nj; ++j) {
    frame.v[info.velocityIndex(j)] = 0.1 * j;
    frame.vdot[info.velocityIndex(j)] = -0.05 * j;
  }
  if (info.floating_base) frame.q[2] = 0.95;
  return frame;
}
}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s <output directory>\n", argv[0]);
    return 2;
  }
  g_dir = argv[1];
  for (const bool floating_base : {true, false}) {
    const dynfilter::ModelInfo& info =
        dynfilter::fuzz::modelInfo("models/human_figure.urdf", floating_base);
    const std::string base = floating_base ? "floating" : "fixed";
    const dynfilter::ReferenceFrame frame = frameFor(info);

    dynfilter::reference_frame_t ref;
    dm::fillReferenceFrame(info, frame, 1000000, 7, ref);
    write(ref, "reference_" + base + ".bin");

    // A task target and contact hints on the feet and hands, joint names in reverse order.
    dynfilter::reference_frame_t full = ref;
    full.has_task_target = 1;
    full.task_position[0] = 0.3;
    full.task_position[2] = 1.2;
    const char* bodies[] = {"l_foot", "r_foot", "l_hand", "r_hand"};
    full.num_contact_hints = 4;
    for (int h = 0; h < 4; ++h) {
      full.contact_hint_bodies.push_back(bodies[h]);
      full.contact_hint_active.push_back(h < 2);
    }
    std::reverse(full.joint_names.begin(), full.joint_names.end());
    std::reverse(full.q.begin(), full.q.end());
    std::reverse(full.qd.begin(), full.qd.end());
    std::reverse(full.qdd.begin(), full.qdd.end());
    write(full, "reference_" + base + "_task_hints_reversed.bin");

    dynfilter::robot_state_t state;
    Eigen::VectorXd tau = Eigen::VectorXd::Constant(info.nj, 1.5);
    dm::fillRobotState(info, 2000000, frame.q, frame.v, &tau, state);
    write(state, "robot_state_" + base + ".bin");
  }
  return 0;
}
