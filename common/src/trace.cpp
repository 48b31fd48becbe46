#include "vmsim/common/trace.hpp"

#include <charconv>
#include <cmath>
#include <map>
#include <stdexcept>

#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"

namespace vmsim {

std::optional<std::size_t> Trace::column_index(const std::string& name) const {
  for (std::size_t i = 0; i < columns.size(); ++i) {
    if (columns[i] == name) return i;
  }
  return std::nullopt;
}

const std::vector<double>& Trace::column(const std::string& name) const {
  const auto index = column_index(name);
  if (!index) throw std::out_of_range("trace has no column '" + name + "'");
  return values[*index];
}

void Trace::add_column(const std::string& name, std::vector<double> column_values) {
  if (!values.empty() && column_values.size() != sample_count()) {
    throw std::invalid_argument("column '" + name + "' has " +
                                std::to_string(column_values.size()) + " samples, the trace " +
                                std::to_string(sample_count()));
  }
  if (column_index(name)) throw std::invalid_argument("trace already has a column '" + name + "'");
  columns.push_back(name);
  values.push_back(std::move(column_values));
}

std::optional<std::string> Trace::metadata_value(const std::string& key) const {
  for (const auto& [k, v] : metadata) {
    if (k == key) return v;
  }
  return std::nullopt;
}

const std::set<std::string>& known_trace_signals() {
  static const std::set<std::string> signals = {"cmd", "pos",    "pos2", "pos_motor",
                                                "vel", "cur",    "torque", "force"};
  return signals;
}

namespace {

std::string trim(const std::string& text) {
  const auto first = text.find_first_not_of(" \t\r");
  if (first == std::string::npos) return "";
  const auto last = text.find_last_not_of(" \t\r");
  return text.substr(first, last - first + 1);
}

std::vector<std::string> split_fields(const std::string& line) {
  std::vector<std::string> fields;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    fields.push_back(trim(line.substr(start, comma == std::string::npos ? std::string::npos
                                                                        : comma - start)));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return fields;
}

}  // namespace

Trace parse_trace(const std::string& text, const std::string& file, const TraceReadOptions& options) {
  Trace trace;
  bool have_header = false;
  std::size_t t_column = 0;
  int line_number = 0;
  // A byte-order mark at the very start is skipped (the spec: spreadsheets write one).
  std::size_t position = text.size() - strip_utf8_bom(text).size();
  while (position <= text.size()) {
    std::size_t end = text.find('\n', position);
    if (end == std::string::npos) end = text.size();
    std::string line = text.substr(position, end - position);
    position = end + 1;
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (trim(line).empty()) {
      if (position > text.size()) break;
      continue;  // blank lines carry nothing; they are not rows
    }
    if (!have_header) {
      if (line[0] == '#') {
        const std::string body = trim(line.substr(1));
        const std::size_t colon = body.find(':');
        if (colon != std::string::npos && colon > 0 &&
            body.find(' ') >= colon) {  // `# key: value` with a one-word key
          trace.metadata.emplace_back(trim(body.substr(0, colon)), trim(body.substr(colon + 1)));
        }
        continue;
      }
      trace.columns = split_fields(line);
      std::map<std::string, int> seen;
      for (std::size_t i = 0; i < trace.columns.size(); ++i) {
        const std::string& name = trace.columns[i];
        if (name.empty()) {
          throw InputError(located_message(file, line_number, 0,
                                           "header column " + std::to_string(i + 1) + " is empty"));
        }
        if (seen.count(name)) {
          throw InputError(located_message(file, line_number, 0,
                                           "header column '" + name + "' appears twice"));
        }
        seen[name] = 1;
        const std::size_t dot = name.find('.');
        if (dot != std::string::npos) {
          const std::string axis = name.substr(0, dot);
          const std::string signal = name.substr(dot + 1);
          if (!known_trace_signals().count(signal)) {
            throw InputError(located_message(
                file, line_number, 0,
                "column '" + name + "': unknown signal '" + signal +
                    "' (known: cmd, pos, pos2, pos_motor, vel, cur, torque, force)"));
          }
          if (options.known_axes && !options.known_axes->count(axis)) {
            throw InputError(located_message(
                file, line_number, 0,
                "column '" + name + "': the machine description has no axis '" + axis + "'"));
          }
        }
      }
      const auto t_index = trace.column_index("t");
      if (!t_index) {
        throw InputError(located_message(file, line_number, 0, "the header has no column 't'"));
      }
      t_column = *t_index;
      trace.values.assign(trace.columns.size(), {});
      have_header = true;
      continue;
    }
    const std::vector<std::string> fields = split_fields(line);
    if (fields.size() != trace.columns.size()) {
      throw InputError(located_message(file, line_number, 0,
                                       "row has " + std::to_string(fields.size()) +
                                           " fields, the header " +
                                           std::to_string(trace.columns.size())));
    }
    for (std::size_t i = 0; i < fields.size(); ++i) {
      double value = 0.0;
      const char* begin = fields[i].data();
      const char* finish = begin + fields[i].size();
      if (!fields[i].empty() && *begin == '+') ++begin;
      const auto result = std::from_chars(begin, finish, value);
      if (fields[i].empty() || result.ec != std::errc() || result.ptr != finish ||
          !std::isfinite(value)) {
        throw InputError(located_message(file, line_number, 0,
                                         "column '" + trace.columns[i] + "': '" + fields[i] +
                                             "' is not a finite number"));
      }
      trace.values[i].push_back(value);
    }
    const std::vector<double>& t = trace.values[t_column];
    if (t.size() >= 2 && !(t.back() > t[t.size() - 2])) {
      throw InputError(located_message(file, line_number, 0,
                                       "t = " + fields[t_column] +
                                           " does not increase (previous row: " +
                                           format_double(t[t.size() - 2]) + ")"));
    }
  }
  if (!have_header) throw InputError(located_message(file, 0, 0, "the trace is empty (no header)"));
  if (trace.sample_count() == 0) {
    throw InputError(located_message(file, 0, 0, "the trace has a header but no samples"));
  }
  return trace;
}

Trace read_trace(const std::string& path, const TraceReadOptions& options) {
  return parse_trace(read_file(path), path, options);
}

std::string format_trace(const Trace& trace) {
  std::string out;
  for (const auto& [key, value] : trace.metadata) out += "# " + key + ": " + value + "\n";
  for (std::size_t i = 0; i < trace.columns.size(); ++i) {
    out += (i ? "," : "") + trace.columns[i];
  }
  out += "\n";
  for (std::size_t row = 0; row < trace.sample_count(); ++row) {
    for (std::size_t i = 0; i < trace.columns.size(); ++i) {
      if (i) out += ',';
      out += format_double(trace.values[i][row]);
    }
    out += '\n';
  }
  return out;
}

void write_trace(const std::string& path, const Trace& trace) {
  write_file_atomically(path, format_trace(trace));
}

bool uniform_period(const std::vector<double>& t, double relative_tolerance, double& period_s) {
  if (t.size() < 2) return false;
  period_s = (t.back() - t.front()) / static_cast<double>(t.size() - 1);
  for (std::size_t i = 1; i < t.size(); ++i) {
    if (std::abs((t[i] - t[i - 1]) - period_s) > relative_tolerance * period_s) return false;
  }
  return true;
}

}  // namespace vmsim
