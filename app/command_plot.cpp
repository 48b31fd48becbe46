// vmsim plot: columns of any CSV file with a header drawn as a line plot (PNG), off-screen.
#include <cstdlib>
#include <memory>
#include <sstream>
#include <vector>

#include "commands.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/common/output_folder.hpp"
#include "vmsim/viz/plot.hpp"

namespace vmsim::app {
namespace {

struct PlotOptions {
  std::string csv_path;
  std::string x_column;
  std::vector<std::string> y_columns;
  std::string out_path;
  std::string title;
  std::string x_title;
  std::string y_title;
  int width_px = 1000;
  int height_px = 600;
};

struct Table {
  std::vector<std::string> columns;
  std::vector<std::vector<double>> values;  ///< one vector per column
};

std::string trimmed(const std::string& text) {
  const auto first = text.find_first_not_of(" \t\r");
  if (first == std::string::npos) return {};
  const auto last = text.find_last_not_of(" \t\r");
  return text.substr(first, last - first + 1);
}

std::vector<std::string> split_fields(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, ',')) fields.push_back(trimmed(field));
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  return fields;
}

// A CSV file: lines starting with '#' and blank lines are skipped; the first other line is the
// header; every data field must be a number ("nan", "inf" are accepted as numbers and rejected
// by the plot with the series and index named).
Table read_csv(const std::string& path) {
  const std::string text = read_file(path);
  Table table;
  std::istringstream in(text);
  std::string line;
  int line_number = 0;
  bool header_seen = false;
  while (std::getline(in, line)) {
    ++line_number;
    const std::string content = trimmed(line);
    if (content.empty() || content.front() == '#') continue;
    const std::vector<std::string> fields = split_fields(content);
    if (!header_seen) {
      header_seen = true;
      table.columns = fields;
      for (std::size_t k = 0; k < fields.size(); ++k) {
        if (fields[k].empty()) {
          throw InputError(located_message(path, line_number, 0,
                                           "header: column " + std::to_string(k + 1) +
                                               " has no name"));
        }
      }
      table.values.resize(fields.size());
      continue;
    }
    if (fields.size() != table.columns.size()) {
      throw InputError(located_message(path, line_number, 0,
                                       std::to_string(fields.size()) + " fields, the header has " +
                                           std::to_string(table.columns.size())));
    }
    for (std::size_t k = 0; k < fields.size(); ++k) {
      const std::string& field = fields[k];
      char* end = nullptr;
      const double value = std::strtod(field.c_str(), &end);
      if (field.empty() || end != field.c_str() + field.size()) {
        throw InputError(located_message(path, line_number, 0,
                                         "column '" + table.columns[k] + "': '" + field +
                                             "' is not a number"));
      }
      table.values[k].push_back(value);
    }
  }
  if (!header_seen) throw InputError(path + ": no header line (the file is empty or all comments)");
  if (table.values.front().empty()) throw InputError(path + ": no data rows after the header");
  return table;
}

const std::vector<double>& column(const Table& table, const std::string& name,
                                  const std::string& path) {
  for (std::size_t k = 0; k < table.columns.size(); ++k) {
    if (table.columns[k] == name) return table.values[k];
  }
  std::string known;
  for (const auto& c : table.columns) known += (known.empty() ? "" : ", ") + c;
  throw InputError(path + ": no column '" + name + "' (columns: " + known + ")");
}

int run_plot(const PlotOptions& options, const CommandContext& context) {
  check_output_file(options.out_path, {options.csv_path});  // before the work: never the input
  const Table table = read_csv(options.csv_path);
  viz::LinePlot plot;
  plot.title = options.title;
  plot.x_title = options.x_title.empty() ? options.x_column : options.x_title;
  plot.y_title = options.y_title;
  if (plot.y_title.empty()) {
    for (const auto& y : options.y_columns) plot.y_title += (plot.y_title.empty() ? "" : ", ") + y;
  }
  const std::vector<double>& x = column(table, options.x_column, options.csv_path);
  for (const auto& y : options.y_columns) {
    viz::Series series;
    series.name = y;
    series.x = x;
    series.y = column(table, y, options.csv_path);
    plot.series.push_back(std::move(series));
  }
  viz::write_line_plot_png(options.out_path, plot, {options.width_px, options.height_px});
  context.say("wrote " + options.out_path + ": " + std::to_string(options.y_columns.size()) +
              " series, " + std::to_string(x.size()) + " points each");
  return 0;
}

}  // namespace

void add_plot_command(CLI::App& app, CommandContext& context) {
  auto options = std::make_shared<PlotOptions>();
  CLI::App* command = app.add_subcommand(
      "plot",
      "line plot (PNG) of columns of a CSV file with a header ('#' comment lines skipped), "
      "rendered off-screen: needs an X display (run under xvfb-run -a on a headless machine)");
  command->add_option("--csv", options->csv_path, "input CSV file with a header line")
      ->required()
      ->check(CLI::ExistingFile);
  command->add_option("--x", options->x_column, "column for the x axis")->required();
  command->add_option("--y", options->y_columns, "column(s) for the y axis, comma-separated")
      ->required()
      ->delimiter(',');
  command->add_option("--out", options->out_path, "output image (PNG)")->required();
  command->add_option("--title", options->title, "title of the plot");
  command->add_option("--x-title", options->x_title, "x axis title (default: the column name)");
  command->add_option("--y-title", options->y_title, "y axis title (default: the column names)");
  command->add_option("--width-px", options->width_px, "image width [px]")
      ->check(CLI::Range(16, 8192));
  command->add_option("--height-px", options->height_px, "image height [px]")
      ->check(CLI::Range(16, 8192));
  command->callback([options, &context] { context.result = run_plot(*options, context); });
}

}  // namespace vmsim::app
