#pragma once
/// @file
/// The one exception type of dynfilter::io: a file that cannot be read, parsed or written.

#include <stdexcept>
#include <string>

namespace dynfilter::io {

/// A bad input file (reference motion CSV, YAML configuration) or a failed output file.
///
/// what() reads `<file>:<line>:<column>: <reason>` so that editors can jump to the spot.
/// The column is the 1-based CSV column index (CSV files) or the 1-based character column
/// (YAML files); it is omitted where it is not meaningful (`<file>:<line>: <reason>`), and
/// the line is omitted too when the error concerns the whole file (`<file>: <reason>`,
/// e.g. a file that cannot be opened).
class InputError : public std::runtime_error {
 public:
  /// @param file   path or label of the file, as given by the caller
  /// @param line   1-based line, 0 when the error concerns the whole file
  /// @param column 1-based column, 0 when not meaningful
  /// @param reason what is wrong, in plain words
  InputError(std::string file, int line, int column, std::string reason);
  /// Same with no column.
  InputError(std::string file, int line, std::string reason);

  const std::string& file() const { return file_; }
  /// 1-based line, 0 when not applicable.
  int line() const { return line_; }
  /// 1-based column, 0 when not applicable.
  int column() const { return column_; }
  /// The message without the location prefix.
  const std::string& reason() const { return reason_; }

 private:
  std::string file_;
  int line_;
  int column_;
  std::string reason_;
};

}  // namespace dynfilter::io
