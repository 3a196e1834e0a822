#include "csv.hpp"

#include <charconv>
#include <cmath>
#include <system_error>

namespace dynfilter::io::detail {
namespace {
bool isBlank(char c) { return c == ' ' || c == '\t'; }
}  // namespace

std::string_view trim(std::string_view s) {
  std::size_t b = 0, e = s.size();
  while (b < e && isBlank(s[b])) ++b;
  while (e > b && isBlank(s[e - 1])) --e;
  return s.substr(b, e - b);
}

bool splitCsvLine(std::string_view line, std::vector<std::string>& fields, std::size_t& count,
                  std::size_t& bad_field) {
  count = 0;
  std::size_t i = 0;
  const std::size_t n = line.size();
  while (true) {
    if (fields.size() <= count) fields.emplace_back();
    std::string& field = fields[count];
    field.clear();
    std::size_t j = i;
    while (j < n && isBlank(line[j])) ++j;
    if (j < n && line[j] == '"') {
      ++j;
      bool closed = false;
      while (j < n) {
        if (line[j] == '"') {
          if (j + 1 < n && line[j + 1] == '"') {
            field.push_back('"');
            j += 2;
          } else {
            ++j;
            closed = true;
            break;
          }
        } else {
          field.push_back(line[j++]);
        }
      }
      while (j < n && isBlank(line[j])) ++j;
      if (!closed || (j < n && line[j] != ',')) {
        bad_field = count;
        return false;
      }
      i = j;
    } else {
      std::size_t e = i;
      while (e < n && line[e] != ',') ++e;
      if (line.substr(i, e - i).find('"') != std::string_view::npos) {
        bad_field = count;
        return false;
      }
      field.assign(trim(line.substr(i, e - i)));
      i = e;
    }
    ++count;
    if (i >= n) return true;
    ++i;  // the comma
  }
}

const char* describe(NumberStatus status) {
  switch (status) {
    case NumberStatus::kNotFinite: return "not a finite number";
    case NumberStatus::kOutOfRange: return "number out of range";
    default: return "not a number";
  }
}

std::string quoted(std::string_view s) { return "\"" + std::string(s) + "\""; }

NumberStatus parseDouble(std::string_view text, double& value) {
  text = trim(text);
  if (!text.empty() && text.front() == '+') {
    text.remove_prefix(1);
    if (!text.empty() && (text.front() == '+' || text.front() == '-'))
      return NumberStatus::kNotANumber;
  }
  if (text.empty()) return NumberStatus::kNotANumber;
  const char* first = text.data();
  const char* last = text.data() + text.size();
  const auto result = std::from_chars(first, last, value, std::chars_format::general);
  if (result.ptr != last) return NumberStatus::kNotANumber;
  if (result.ec == std::errc::result_out_of_range) return NumberStatus::kOutOfRange;
  if (result.ec != std::errc()) return NumberStatus::kNotANumber;
  if (!std::isfinite(value)) return NumberStatus::kNotFinite;
  return NumberStatus::kOk;
}

void appendDouble(std::string& out, double x) {
  if (std::isnan(x)) {
    out += "nan";
    return;
  }
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, x);
  out.append(buffer, result.ptr);
}

void appendInteger(std::string& out, long long x) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, x);
  out.append(buffer, result.ptr);
}

void appendCsvField(std::string& out, std::string_view text) {
  const bool quote = text.find_first_of(",\"\r\n") != std::string_view::npos ||
                     (!text.empty() && (isBlank(text.front()) || isBlank(text.back()) ||
                                        text.front() == '#'));
  if (!quote) {
    out += text;
    return;
  }
  out += '"';
  for (char c : text) {
    if (c == '"') out += '"';
    out += c;
  }
  out += '"';
}

}  // namespace dynfilter::io::detail
