#include "dynfilter/io/filtered_motion_reader.hpp"

#include <array>
#include <fstream>
#include <map>

#include "csv.hpp"
#include "dynfilter/io/filtered_motion.hpp"
#include "dynfilter/io/reference_motion.hpp"

namespace dynfilter::io {
namespace {

// Data lines of a CSV file as (line number, fields); the first is the header.
struct CsvTable {
  std::vector<std::string> header;
  std::vector<std::pair<int, std::vector<std::string>>> rows;
};

CsvTable readTable(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, 0, "cannot open the file");
  CsvTable table;
  std::string line;
  std::vector<std::string> fields;
  std::size_t count = 0, bad = 0;
  for (int n = 1; std::getline(in, line); ++n) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::string_view trimmed = detail::trim(line);
    if (trimmed.empty() || trimmed.front() == '#') continue;
    if (!detail::splitCsvLine(line, fields, count, bad))
      throw InputError(path, n, static_cast<int>(bad) + 1, "malformed quoted field");
    std::vector<std::string> row(fields.begin(), fields.begin() + static_cast<std::ptrdiff_t>(count));
    if (table.header.empty()) {
      table.header = std::move(row);
      continue;
    }
    if (row.size() != table.header.size())
      throw InputError(path, n, 0,
                       "expected " + std::to_string(table.header.size()) + " fields, found " +
                           std::to_string(row.size()));
    table.rows.emplace_back(n, std::move(row));
  }
  if (table.header.empty()) throw InputError(path, 0, 0, "the file is empty");
  return table;
}

int columnOf(const CsvTable& t, const std::string& path, const std::string& name) {
  for (std::size_t i = 0; i < t.header.size(); ++i)
    if (t.header[i] == name) return static_cast<int>(i);
  throw InputError(path, 1, 0, "missing column \"" + name + "\"");
}

double number(const std::string& path, int line, int column, const std::string& text) {
  double value = 0.0;
  if (detail::parseDouble(text, value) != detail::NumberStatus::kOk)
    throw InputError(path, line, column + 1, "not a finite number: \"" + text + "\"");
  return value;
}

}  // namespace

std::vector<FilteredFrame> readFilteredMotion(const std::string& path, const ModelInfo& info) {
  ReferenceReadOptions options;
  options.allow_extra_columns = true;
  const ReferenceMotion motion = readReferenceMotion(path, info, options);
  if (!motion.had_velocities || !motion.had_accelerations)
    throw InputError(path, 1, 0, "a filtered motion needs velocity and acceleration columns");

  const CsvTable main = readTable(path);
  std::vector<int> tau_columns;
  for (const std::string& joint : info.joint_names)
    tau_columns.push_back(columnOf(main, path, joint + detail::kTorqueSuffix));
  std::vector<FilteredFrame> frames(motion.frames.size());
  std::map<std::string, std::size_t> frame_of_time;  // exact text of the time field
  const int time_column = columnOf(main, path, detail::kTimeColumn);
  for (std::size_t r = 0; r < main.rows.size(); ++r) {
    const auto& [line, fields] = main.rows[r];
    FilteredFrame& f = frames[r];
    f.state = motion.frames[r];
    f.tau_J.resize(info.nj);
    for (int j = 0; j < info.nj; ++j) {
      const int c = tau_columns[static_cast<std::size_t>(j)];
      f.tau_J[j] = number(path, line, c, fields[static_cast<std::size_t>(c)]);
    }
    frame_of_time[fields[static_cast<std::size_t>(time_column)]] = r;
  }

  const std::string contacts_path = FilteredMotionWriter::contactsPathFor(path);
  const CsvTable contacts = readTable(contacts_path);
  const int time_c = columnOf(contacts, contacts_path, "time");
  const int body_c = columnOf(contacts, contacts_path, "body");
  std::array<int, 3> p{};
  std::array<int, 6> w{};
  const char* p_names[] = {"px", "py", "pz"};
  const char* w_names[] = {"fx", "fy", "fz", "mx", "my", "mz"};
  for (int i = 0; i < 3; ++i) p[static_cast<std::size_t>(i)] = columnOf(contacts, contacts_path, p_names[i]);
  for (int i = 0; i < 6; ++i) w[static_cast<std::size_t>(i)] = columnOf(contacts, contacts_path, w_names[i]);
  for (const auto& [line, fields] : contacts.rows) {
    const auto frame = frame_of_time.find(fields[static_cast<std::size_t>(time_c)]);
    if (frame == frame_of_time.end())
      throw InputError(contacts_path, line, time_c + 1,
                       "time " + fields[static_cast<std::size_t>(time_c)] + " is not a row of " + path);
    ContactWrench c;
    c.body = info.findBody(fields[static_cast<std::size_t>(body_c)]);
    if (c.body < 0)
      throw InputError(contacts_path, line, body_c + 1,
                       "unknown body \"" + fields[static_cast<std::size_t>(body_c)] + "\"");
    for (int i = 0; i < 3; ++i)
      c.p_WC[i] = number(contacts_path, line, p[static_cast<std::size_t>(i)],
                         fields[static_cast<std::size_t>(p[static_cast<std::size_t>(i)])]);
    for (int i = 0; i < 6; ++i)
      c.wrench_W[i] = number(contacts_path, line, w[static_cast<std::size_t>(i)],
                             fields[static_cast<std::size_t>(w[static_cast<std::size_t>(i)])]);
    frames[frame->second].contacts.push_back(c);
  }
  return frames;
}

}  // namespace dynfilter::io
