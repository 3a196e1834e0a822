#pragma once
// The mini humanoid (tests/models/mini_humanoid.urdf) as a BVH capture: a hierarchy whose
// forward kinematics is the model's, known joint angles, and captures of other limb
// lengths. Shared by the retargeting and mapping-suggestion tests.

#include <cstdio>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "support/test_support.hpp"

namespace dynfilter::io::testing_io {

// A BVH whose hierarchy is the mini humanoid's (Z up, X forward: R_conv = I; offsets the
// joint positions at q = 0, channels its joint axes in chain order), so that its forward
// kinematics is the model's.
inline constexpr const char* kMiniBvh = R"(HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation
  JOINT Waist
  {
    OFFSET 0 0 0.06
    CHANNELS 1 Zrotation
    JOINT LArm
    {
      OFFSET 0 0.19 0.3
      CHANNELS 2 Yrotation Xrotation
      JOINT LElbow
      {
        OFFSET 0 0 -0.25
        CHANNELS 1 Yrotation
        End Site
        {
          OFFSET 0 0 -0.24
        }
      }
    }
    JOINT RArm
    {
      OFFSET 0 -0.19 0.3
      CHANNELS 2 Yrotation Xrotation
      JOINT RElbow
      {
        OFFSET 0 0 -0.25
        CHANNELS 1 Yrotation
        End Site
        {
          OFFSET 0 0 -0.24
        }
      }
    }
  }
  JOINT LHip
  {
    OFFSET 0 0.09 -0.06
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT LKnee
    {
      OFFSET 0 0 -0.30
      CHANNELS 1 Yrotation
      JOINT LAnkle
      {
        OFFSET 0 0 -0.32
        CHANNELS 2 Yrotation Xrotation
        End Site
        {
          OFFSET 0.12 0 0
        }
      }
    }
  }
  JOINT RHip
  {
    OFFSET 0 -0.09 -0.06
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT RKnee
    {
      OFFSET 0 0 -0.30
      CHANNELS 1 Yrotation
      JOINT RAnkle
      {
        OFFSET 0 0 -0.32
        CHANNELS 2 Yrotation Xrotation
        End Site
        {
          OFFSET 0.12 0 0
        }
      }
    }
  }
}
MOTION
)";

// Model joints in the BVH's channel order (after the root's six).
inline const char* const kChannelJoints[] = {"spine_twist", "arm_l_y", "arm_l_x", "cubitus_l", "arm_r_y",
                                      "arm_r_x",     "cubitus_r", "coxa_l_z", "coxa_l_x", "coxa_l_y",
                                      "genu_l",      "talo_l_y", "talo_l_x", "coxa_r_z", "coxa_r_x",
                                      "coxa_r_y",    "genu_r",   "talo_r_y", "talo_r_x"};

inline std::map<std::string, double> knownAngles(double s) {
  const double deg[] = {15, -40, 25, -60, 30, -20, -45, 10, 12, -35, 50, -15, 8, -12, -10, -20, 35, 10, -6};
  std::map<std::string, double> out;
  for (std::size_t i = 0; i < std::size(kChannelJoints); ++i) out[kChannelJoints[i]] = s * deg[i] * test::kRadPerDeg;
  return out;
}

inline std::string writeMiniBvh(const std::vector<std::map<std::string, double>>& frames, const char* name,
                         const std::string& hierarchy = kMiniBvh) {
  const std::string path = ::testing::TempDir() + "/" + name;
  std::ofstream out(path);
  out << hierarchy << "Frames: " << frames.size() << "\nFrame Time: 0.01\n";
  for (std::size_t k = 0; k < frames.size(); ++k) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.17g 0 0.9 %.17g 0 0", 0.01 * static_cast<double>(k), 10.0 * k);
    out << buf;
    for (const char* j : kChannelJoints) {
      std::snprintf(buf, sizeof buf, " %.17g", frames[k].at(j) / test::kRadPerDeg);
      out << buf;
    }
    out << "\n";
  }
  return path;
}

// The mini humanoid's hierarchy with other limb lengths: every OFFSET "0 0 <from>" (both
// sides) becomes "0 0 <to>".
inline std::string miniBvhWithLimbs(const std::vector<std::pair<std::string, std::string>>& lengths) {
  std::string h = kMiniBvh;
  for (const auto& [from, to] : lengths)
    for (std::size_t at = h.find("OFFSET 0 0 " + from); at != std::string::npos;
         at = h.find("OFFSET 0 0 " + from, at + 1))
      h.replace(at, 11 + from.size(), "OFFSET 0 0 " + to);
  return h;
}

}  // namespace dynfilter::io::testing_io
