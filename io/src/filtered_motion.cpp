#include "dynfilter/io/filtered_motion.hpp"

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>
#include <stdexcept>
#include <utility>

#include <fcntl.h>
#include <unistd.h>

#include "csv.hpp"

namespace dynfilter::io {
namespace {

std::string errnoText(int err) { return err != 0 ? std::strerror(err) : "unknown error"; }

const char* kindName(ContactKind kind) {
  switch (kind) {
    case ContactKind::kPoint: return "point";
    case ContactKind::kEdge: return "edge";
    case ContactKind::kFace: return "face";
  }
  return "unknown";
}

}  // namespace

// Named, not anonymous: a member of FilteredMotionWriter::Impl (gcc warns on a member
// of a type with internal linkage once this file is part of a unity batch).
namespace detail {

// A file being written at a temporary name next to its final path.
class TempFile {
 public:
  TempFile() = default;
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  ~TempFile() { discard(); }

  void open(const std::string& final_path) {
    final_path_ = final_path;
    static std::atomic<unsigned> counter{0};
    std::random_device random;
    for (int attempt = 0; attempt < 100; ++attempt) {
      temp_path_ = final_path + ".tmp." + std::to_string(::getpid()) + "." +
                   std::to_string(counter++) + "." + std::to_string(random() % 1000000u);
      errno = 0;
      file_ = std::fopen(temp_path_.c_str(), "wbx");  // x: never clobber an existing file
      if (file_ != nullptr) {
        std::setvbuf(file_, nullptr, _IOFBF, 1 << 20);
        return;
      }
      if (errno != EEXIST) break;
    }
    const int err = errno;
    temp_path_.clear();
    throw InputError(final_path, 0, "cannot create temporary file: " + errnoText(err));
  }

  void write(const std::string& text) {
    if (std::fwrite(text.data(), 1, text.size(), file_) != text.size()) {
      const int err = errno;
      throw InputError(final_path_, 0, "write failed: " + errnoText(err));
    }
  }

  // Flush, fsync and close; throws on failure (the temporary stays for discard()).
  void finish() {
    errno = 0;
    bool ok = std::fflush(file_) == 0 && std::ferror(file_) == 0;
    ok = ok && ::fsync(::fileno(file_)) == 0;
    int err = errno;
    if (std::fclose(file_) != 0 && ok) {
      ok = false;
      err = errno;
    }
    file_ = nullptr;
    if (!ok) throw InputError(final_path_, 0, "write failed: " + errnoText(err));
  }

  void rename() {
    if (std::rename(temp_path_.c_str(), final_path_.c_str()) != 0) {
      const int err = errno;
      throw InputError(final_path_, 0, "cannot rename " + temp_path_ + ": " + errnoText(err));
    }
    temp_path_.clear();
  }

  // Closes and removes the temporary, if any. Never throws.
  void discard() noexcept {
    if (file_ != nullptr) {
      std::fclose(file_);
      file_ = nullptr;
    }
    if (!temp_path_.empty()) {
      std::remove(temp_path_.c_str());
      temp_path_.clear();
    }
  }

 private:
  std::string final_path_;
  std::string temp_path_;
  std::FILE* file_ = nullptr;
};

}  // namespace detail

namespace {

void appendHeader(std::string& out, const std::vector<std::string>& names) {
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (i > 0) out += ',';
    detail::appendCsvField(out, names[i]);
  }
  out += '\n';
}

void appendValues(std::string& out, const Eigen::Ref<const Eigen::VectorXd>& x) {
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    out += ',';
    detail::appendDouble(out, x[i]);
  }
}

void appendValue(std::string& out, double x) {
  out += ',';
  detail::appendDouble(out, x);
}

void requireSize(const Eigen::VectorXd& x, int size, const char* name) {
  if (x.size() != size)
    throw std::invalid_argument(std::string("FilteredMotionWriter::append: ") + name +
                                " has dimension " + std::to_string(x.size()) + ", expected " +
                                std::to_string(size));
}

// fsync of the directory holding @p path, so that the renames survive a crash. Best effort.
void syncDirectoryOf(const std::string& path) {
  std::filesystem::path dir = std::filesystem::path(path).parent_path();
  if (dir.empty()) dir = ".";
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
  if (fd >= 0) {
    (void)::fsync(fd);
    ::close(fd);
  }
}

}  // namespace

struct FilteredMotionWriter::Impl {
  std::string path;
  std::string contacts_path;
  ModelInfo info;
  std::vector<std::string> body_names;
  detail::TempFile main_file;
  detail::TempFile contacts_file;
  std::string row;
  std::size_t rows = 0;
  bool committed = false;
};

FilteredMotionWriter::FilteredMotionWriter(std::string path, const ModelInfo& info)
    : FilteredMotionWriter(std::move(path), info, info.body_names) {}

FilteredMotionWriter::FilteredMotionWriter(std::string path, const ModelInfo& info,
                                           std::vector<std::string> body_names)
    : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  s.path = std::move(path);
  s.contacts_path = contactsPathFor(s.path);
  s.info = info;
  s.body_names = std::move(body_names);
  s.main_file.open(s.path);
  s.contacts_file.open(s.contacts_path);
  s.row.clear();
  appendHeader(s.row, mainColumns(info));
  s.main_file.write(s.row);
  s.row.clear();
  appendHeader(s.row, contactColumns());
  s.contacts_file.write(s.row);
}

FilteredMotionWriter::~FilteredMotionWriter() = default;
FilteredMotionWriter::FilteredMotionWriter(FilteredMotionWriter&&) noexcept = default;
FilteredMotionWriter& FilteredMotionWriter::operator=(FilteredMotionWriter&&) noexcept = default;

const std::string& FilteredMotionWriter::path() const { return impl_->path; }
const std::string& FilteredMotionWriter::contactsPath() const { return impl_->contacts_path; }
std::size_t FilteredMotionWriter::rows() const { return impl_->rows; }

std::string FilteredMotionWriter::contactsPathFor(const std::string& path) {
  const std::filesystem::path p(path);
  return (p.parent_path() / (p.stem().string() + ".contacts.csv")).string();
}

std::vector<std::string> FilteredMotionWriter::mainColumns(const ModelInfo& info) {
  std::vector<std::string> c{detail::kTimeColumn, "status"};
  if (info.floating_base) {
    for (const char* name : detail::kBasePositionColumns) c.emplace_back(name);
    for (const char* name : detail::kBaseQuaternionColumns) c.emplace_back(name);
  }
  for (const std::string& j : info.joint_names) c.push_back(j);
  if (info.floating_base)
    for (const char* name : detail::kBaseVelocityColumns) c.emplace_back(name);
  for (const std::string& j : info.joint_names) c.push_back(j + detail::kVelocitySuffix);
  if (info.floating_base)
    for (const char* name : detail::kBaseAccelerationColumns) c.emplace_back(name);
  for (const std::string& j : info.joint_names) c.push_back(j + detail::kAccelerationSuffix);
  for (const std::string& j : info.joint_names) c.push_back(j + detail::kTorqueSuffix);
  if (info.floating_base)
    for (const char* name : {"err.base_x", "err.base_y", "err.base_z", "err.base_rx",
                             "err.base_ry", "err.base_rz"})
      c.emplace_back(name);
  for (const std::string& j : info.joint_names) c.push_back("err." + j);
  for (const char* name : {"task_err.x", "task_err.y", "task_err.z", "task_err.rx",
                           "task_err.ry", "task_err.rz", "eq12_residual", "base_residual_n",
                           "max_penetration_m", "num_contacts", "solve_time_s", "tick_time_s"})
    c.emplace_back(name);
  return c;
}

std::vector<std::string> FilteredMotionWriter::contactColumns() {
  return {"time", "index", "body", "object", "kind", "px", "py", "pz", "nx", "ny", "nz", "fx",
          "fy", "fz", "mx", "my", "mz", "normal_force_n", "cop_x", "cop_y",
          "support_x_min", "support_x_max", "support_y_min", "support_y_max", "pivot",
          "slide_x", "slide_y", "slide_z"};
}

void FilteredMotionWriter::append(const FilterOutput& out) { append(out, out.status); }

void FilteredMotionWriter::append(const FilterOutput& out, std::uint32_t row_status) {
  if (!impl_) throw std::logic_error("FilteredMotionWriter::append on a moved-from writer");
  Impl& s = *impl_;
  if (s.committed) throw std::logic_error("FilteredMotionWriter::append after commit()");
  const ModelInfo& info = s.info;
  requireSize(out.q, info.nq, "q");
  requireSize(out.v, info.nv, "v");
  requireSize(out.vdot, info.nv, "vdot");
  requireSize(out.tau_J, info.nj, "tau_J");
  requireSize(out.tracking_error, info.nv, "tracking_error");
  if (out.num_contacts < 0 || static_cast<std::size_t>(out.num_contacts) > out.contacts.size())
    throw std::invalid_argument("FilteredMotionWriter::append: num_contacts " +
                                std::to_string(out.num_contacts) + " outside [0, " +
                                std::to_string(out.contacts.size()) + "]");
  for (int i = 0; i < out.num_contacts; ++i) {
    const int body = out.contacts[static_cast<std::size_t>(i)].body;
    if (body < 0 || static_cast<std::size_t>(body) >= s.body_names.size())
      throw std::invalid_argument("FilteredMotionWriter::append: contact " + std::to_string(i) +
                                  " has body index " + std::to_string(body) + ", outside [0, " +
                                  std::to_string(s.body_names.size()) + ")");
  }

  std::string& r = s.row;
  r.clear();
  detail::appendDouble(r, out.time_s);
  r += ',';
  detail::appendInteger(r, static_cast<long long>(row_status));
  appendValues(r, out.q);
  appendValues(r, out.v);
  appendValues(r, out.vdot);
  appendValues(r, out.tau_J);
  appendValues(r, out.tracking_error);
  appendValues(r, out.task_error);
  appendValue(r, out.eq12_residual);
  appendValue(r, out.base_residual_n);
  appendValue(r, out.max_penetration_m);
  r += ',';
  detail::appendInteger(r, out.num_contacts);
  appendValue(r, out.solve_time_s);
  appendValue(r, out.tick_time_s);
  r += '\n';
  s.main_file.write(r);

  if (out.num_contacts > 0) {
    r.clear();
    for (int i = 0; i < out.num_contacts; ++i) {
      const ContactOutput& c = out.contacts[static_cast<std::size_t>(i)];
      detail::appendDouble(r, out.time_s);
      r += ',';
      detail::appendInteger(r, i);
      r += ',';
      detail::appendCsvField(r, s.body_names[static_cast<std::size_t>(c.body)]);
      r += ',';
      detail::appendInteger(r, c.object);
      r += ',';
      r += kindName(c.kind);
      appendValues(r, c.p_WC);
      appendValues(r, c.n_W);
      appendValues(r, c.wrench_W);
      appendValue(r, c.normal_force_n);
      appendValues(r, c.cop_A);
      appendValue(r, c.support_min_A.x());
      appendValue(r, c.support_max_A.x());
      appendValue(r, c.support_min_A.y());
      appendValue(r, c.support_max_A.y());
      r += ',';
      detail::appendInteger(r, c.pivot);
      appendValues(r, c.slide_W);
      r += '\n';
    }
    s.contacts_file.write(r);
  }
  ++s.rows;
}

void FilteredMotionWriter::commit() {
  if (!impl_) throw std::logic_error("FilteredMotionWriter::commit on a moved-from writer");
  Impl& s = *impl_;
  if (s.committed) throw std::logic_error("FilteredMotionWriter::commit called twice");
  s.committed = true;
  try {
    s.contacts_file.finish();
    s.main_file.finish();
    s.contacts_file.rename();
    s.main_file.rename();
  } catch (...) {
    s.contacts_file.discard();
    s.main_file.discard();
    throw;
  }
  syncDirectoryOf(s.path);  // the contacts file is in the same directory
}

}  // namespace dynfilter::io
