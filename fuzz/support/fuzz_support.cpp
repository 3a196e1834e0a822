#include "fuzz_support.hpp"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <typeinfo>
#include <utility>

#include "dynfilter/urdf/robot_description.hpp"
#include "dynfilter/urdf/urdf_loader.hpp"

namespace dynfilter::fuzz {
namespace {

struct TempFiles {
  std::map<std::string, std::string> by_suffix;
  ~TempFiles() {
    for (const auto& entry : by_suffix) std::remove(entry.second.c_str());
  }
};

TempFiles& tempFiles() {
  static TempFiles files;
  return files;
}

std::string tempDirectory() {
  if (access("/dev/shm", W_OK) == 0) return "/dev/shm";
  const char* tmp = std::getenv("TMPDIR");
  return tmp != nullptr && *tmp != '\0' ? tmp : "/tmp";
}

}  // namespace

const std::string& writeTempFile(const std::uint8_t* data, std::size_t size,
                                 const std::string& suffix) {
  auto& files = tempFiles().by_suffix;
  auto it = files.find(suffix);
  if (it == files.end()) {
    const std::string path = tempDirectory() + "/dynfilter-fuzz-" +
                             std::to_string(static_cast<long>(getpid())) + suffix;
    it = files.emplace(suffix, path).first;
  }
  std::ofstream out(it->second, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  out.close();
  if (!out) {
    std::fprintf(stderr, "fuzz: cannot write %s\n", it->second.c_str());
    std::abort();
  }
  return it->second;
}

const ModelInfo& modelInfo(const std::string& relative_path, bool floating_base) {
  static std::map<std::pair<std::string, bool>, std::unique_ptr<ModelInfo>> cache;
  auto& slot = cache[{relative_path, floating_base}];
  if (!slot) {
    const urdf::RobotDescription robot =
        urdf::loadUrdfFile(std::string(DYNFILTER_SOURCE_DIR) + "/" + relative_path);
    urdf::validateForDynamics(robot, floating_base);
    slot = std::make_unique<ModelInfo>(urdf::makeModelInfo(robot, floating_base));
  }
  return *slot;
}

void unexpectedException(const char* target) {
  try {
    throw;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "\n%s: undocumented exception %s: %s\n", target, typeid(e).name(),
                 e.what());
  } catch (...) {
    std::fprintf(stderr, "\n%s: undocumented exception of a type not from std::exception\n",
                 target);
  }
  std::fflush(stderr);
  std::abort();
}

void violated(const char* target, const std::string& what) {
  std::fprintf(stderr, "\n%s: post-condition violated: %s\n", target, what.c_str());
  std::fflush(stderr);
  std::abort();
}

}  // namespace dynfilter::fuzz
