#pragma once
// Axis traces: the one CSV format for set points, simulated and measured drive signals
// (shared/spec/trace-format.md). Columns `t` [s], `<AXIS>.cmd|pos|pos2|pos_motor` [mm or deg],
// `<AXIS>.vel` [mm/s or deg/s], `<AXIS>.cur` [A], `<AXIS>.torque` [N m], `<AXIS>.force` [N].
// Values are kept in the file's units here: callers convert at their boundary.
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace vmsim {

struct Trace {
  /// `# key: value` comment lines before the header, in file order.
  std::vector<std::pair<std::string, std::string>> metadata;
  std::vector<std::string> columns;
  /// One vector per column, all of the same length (the number of samples).
  std::vector<std::vector<double>> values;

  std::size_t sample_count() const { return values.empty() ? 0 : values.front().size(); }
  /// Index of a column, or nullopt.
  std::optional<std::size_t> column_index(const std::string& name) const;
  /// The column's values; throws std::out_of_range naming the column when absent.
  const std::vector<double>& column(const std::string& name) const;
  /// Adds a column (its length must match the others).
  void add_column(const std::string& name, std::vector<double> column_values);
  /// The value of a metadata key, or nullopt.
  std::optional<std::string> metadata_value(const std::string& key) const;
};

/// Signals the format knows, for `<AXIS>.<signal>` columns.
const std::set<std::string>& known_trace_signals();

struct TraceReadOptions {
  /// When set, an `<AXIS>.<signal>` column whose axis is not in this set is an error.
  std::optional<std::set<std::string>> known_axes;
};

/// Reads and checks a trace. Throws vmsim::InputError naming the file and line for each kind
/// of bad input of the spec (missing/duplicated column, wrong field count, a value that is not
/// a finite number, a t that does not increase, an unknown axis or signal, an empty file).
Trace read_trace(const std::string& path, const TraceReadOptions& options = {});
Trace parse_trace(const std::string& text, const std::string& file_name_for_messages,
                  const TraceReadOptions& options = {});

/// Writes a trace; numbers in the shortest form that reads back exactly. The file appears
/// complete or not at all (written to a temporary name, then renamed).
void write_trace(const std::string& path, const Trace& trace);
std::string format_trace(const Trace& trace);

/// True when t is uniformly sampled within a relative tolerance; the period in `period_s`.
bool uniform_period(const std::vector<double>& t, double relative_tolerance, double& period_s);

}  // namespace vmsim
