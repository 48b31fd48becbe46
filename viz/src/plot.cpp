// Line plots and histograms: VTK charts (vtkChartXY) in a vtkContextView rendered off-screen.
#include "vmsim/viz/plot.hpp"

#include <vtkAxis.h>
#include <vtkChartLegend.h>
#include <vtkChartXY.h>
#include <vtkContextScene.h>
#include <vtkContextView.h>
#include <vtkDoubleArray.h>
#include <vtkPen.h>
#include <vtkPlot.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkSmartPointer.h>
#include <vtkTable.h>
#include <vtkTextProperty.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>

#include "render_output.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/viz/display.hpp"

namespace vmsim::viz {
namespace {

// A qualitative palette (the "tab10" colours), distinguishable in print and by most readers
// with a colour vision deficiency when combined with the line styles.
constexpr std::array<std::array<unsigned char, 3>, 10> kPalette{{{31, 119, 180},
                                                                {255, 127, 14},
                                                                {44, 160, 44},
                                                                {214, 39, 40},
                                                                {148, 103, 189},
                                                                {140, 86, 75},
                                                                {227, 119, 194},
                                                                {127, 127, 127},
                                                                {188, 189, 34},
                                                                {23, 190, 207}}};

unsigned char channel(double value) {
  return static_cast<unsigned char>(std::lround(std::clamp(value, 0.0, 1.0) * 255.0));
}

void check_size(const ImageSize& size) {
  if (size.width_px < 16 || size.height_px < 16 || size.width_px > 8192 ||
      size.height_px > 8192) {
    throw InputError("image size " + std::to_string(size.width_px) + "x" +
                     std::to_string(size.height_px) + " px: each side must be in [16, 8192]");
  }
}

void check_range(const std::optional<Range>& range, const std::string& what) {
  if (range && !(std::isfinite(range->min) && std::isfinite(range->max) &&
                 range->min < range->max)) {
    throw InputError(what + " [" + format_double(range->min) + ", " + format_double(range->max) +
                     "]: needs finite min < max");
  }
}

// A chart in an off-screen view of the given size, white background, titled.
struct ChartView {
  vtkSmartPointer<vtkContextView> view;
  vtkSmartPointer<vtkChartXY> chart;
};

ChartView make_chart(const ImageSize& size, const std::string& title) {
  ChartView result;
  result.view = vtkSmartPointer<vtkContextView>::New();
  vtkRenderWindow* window = result.view->GetRenderWindow();
  window->SetOffScreenRendering(1);
  window->SetSize(size.width_px, size.height_px);
  result.view->GetRenderer()->SetBackground(1.0, 1.0, 1.0);
  result.chart = vtkSmartPointer<vtkChartXY>::New();
  result.view->GetScene()->AddItem(result.chart);
  result.chart->SetTitle(title);
  result.chart->GetTitleProperties()->SetFontSize(18);
  result.chart->GetTitleProperties()->SetBold(true);
  detail::apply_font(result.chart->GetTitleProperties());
  for (int axis : {vtkAxis::LEFT, vtkAxis::BOTTOM, vtkAxis::RIGHT, vtkAxis::TOP}) {
    vtkTextProperty* axis_title = result.chart->GetAxis(axis)->GetTitleProperties();
    axis_title->SetFontSize(15);
    detail::apply_font(axis_title);
    vtkTextProperty* labels = result.chart->GetAxis(axis)->GetLabelProperties();
    labels->SetFontSize(13);
    detail::apply_font(labels);
  }
  result.chart->GetLegend()->GetLabelProperties()->SetFontSize(14);
  detail::apply_font(result.chart->GetLegend()->GetLabelProperties());
  return result;
}

void fix_axis(vtkAxis* axis, const Range& range) {
  axis->SetBehavior(vtkAxis::FIXED);
  axis->SetRange(range.min, range.max);
}

vtkSmartPointer<vtkTable> two_column_table(const std::string& x_name, const std::vector<double>& x,
                                           const std::string& y_name,
                                           const std::vector<double>& y) {
  auto table = vtkSmartPointer<vtkTable>::New();
  auto x_column = vtkSmartPointer<vtkDoubleArray>::New();
  x_column->SetName(x_name.c_str());
  auto y_column = vtkSmartPointer<vtkDoubleArray>::New();
  y_column->SetName(y_name.c_str());
  table->AddColumn(x_column);
  table->AddColumn(y_column);
  table->SetNumberOfRows(static_cast<vtkIdType>(x.size()));
  for (std::size_t i = 0; i < x.size(); ++i) {
    table->SetValue(static_cast<vtkIdType>(i), 0, x[i]);
    table->SetValue(static_cast<vtkIdType>(i), 1, y[i]);
  }
  return table;
}

std::vector<double> scaled(const std::vector<double>& values, double factor) {
  std::vector<double> result(values.size());
  std::transform(values.begin(), values.end(), result.begin(),
                 [factor](double v) { return v * factor; });
  return result;
}

}  // namespace

void validate(const LinePlot& plot) {
  if (plot.series.empty()) throw InputError("line plot '" + plot.title + "': no series to plot");
  bool any_point = false;
  for (std::size_t k = 0; k < plot.series.size(); ++k) {
    const Series& series = plot.series[k];
    const std::string name =
        "line plot '" + plot.title + "', series " +
        (series.name.empty() ? std::to_string(k + 1) : "'" + series.name + "'");
    if (series.x.size() != series.y.size()) {
      throw InputError(name + ": x has " + std::to_string(series.x.size()) + " values, y has " +
                       std::to_string(series.y.size()));
    }
    for (std::size_t i = 0; i < series.x.size(); ++i) {
      if (!std::isfinite(series.x[i]) || !std::isfinite(series.y[i])) {
        throw InputError(name + ": point " + std::to_string(i) + " (" + format_double(series.x[i]) +
                         ", " + format_double(series.y[i]) + ") is not finite");
      }
    }
    if (!(series.line_width_px > 0.0)) {
      throw InputError(name + ": line_width_px " + format_double(series.line_width_px) +
                       " must be > 0");
    }
    any_point = any_point || !series.x.empty();
  }
  if (!any_point) throw InputError("line plot '" + plot.title + "': every series is empty");
  check_range(plot.x_range, "line plot '" + plot.title + "': x_range");
  check_range(plot.y_range, "line plot '" + plot.title + "': y_range");
}

void write_line_plot_png(const std::string& png_path, const LinePlot& plot,
                         const ImageSize& size) {
  validate(plot);
  check_size(size);
  require_display();

  ChartView chart_view = make_chart(size, plot.title);
  vtkChartXY* chart = chart_view.chart;
  chart->GetAxis(vtkAxis::BOTTOM)->SetTitle(plot.x_title);
  chart->GetAxis(vtkAxis::LEFT)->SetTitle(plot.y_title);
  chart->GetAxis(vtkAxis::RIGHT)->SetTitle(plot.y2_title);
  chart->SetShowLegend(plot.legend);
  if (plot.legend_outside) {
    // Beside the plot area, which shrinks to leave it room: never over the data.
    chart->GetLegend()->SetInline(false);
    chart->GetLegend()->SetHorizontalAlignment(vtkChartLegend::RIGHT);
    chart->GetLegend()->SetVerticalAlignment(vtkChartLegend::TOP);
  }

  std::size_t palette_index = 0;
  for (std::size_t k = 0; k < plot.series.size(); ++k) {
    const Series& series = plot.series[k];
    if (series.x.empty()) continue;
    const std::string name = series.name.empty() ? "series " + std::to_string(k + 1) : series.name;
    vtkPlot* line = chart->AddPlot(vtkChart::LINE);
    line->SetInputData(two_column_table("x", series.x, name, series.y), 0, 1);
    if (series.colour) {
      line->SetColor(channel(series.colour->r), channel(series.colour->g),
                     channel(series.colour->b), 255);
    } else {
      const auto& c = kPalette[palette_index++ % kPalette.size()];
      line->SetColor(c[0], c[1], c[2], 255);
    }
    line->SetWidth(static_cast<float>(series.line_width_px));
    switch (series.style) {
      case LineStyle::solid: line->GetPen()->SetLineType(vtkPen::SOLID_LINE); break;
      case LineStyle::dashed: line->GetPen()->SetLineType(vtkPen::DASH_LINE); break;
      case LineStyle::dotted: line->GetPen()->SetLineType(vtkPen::DOT_LINE); break;
    }
    if (series.right_axis) chart->SetPlotCorner(line, 1);  // bottom and right axes
    if (!series.in_legend) line->SetLegendVisibility(false);
  }
  if (!plot.x_markers.empty()) {
    // Across the left axis's range: the data's, or the one given.
    double low = std::numeric_limits<double>::infinity(), high = -low;
    for (const Series& series : plot.series) {
      if (series.right_axis) continue;
      for (double y : series.y) low = std::min(low, y), high = std::max(high, y);
    }
    if (plot.y_range) low = plot.y_range->min, high = plot.y_range->max;
    if (std::isfinite(low) && std::isfinite(high)) {
      for (double x : plot.x_markers) {
        vtkPlot* marker = chart->AddPlot(vtkChart::LINE);
        marker->SetInputData(two_column_table("x", {x, x}, "marks", {low, high}), 0, 1);
        marker->SetColor(90, 90, 90, 255);
        marker->SetWidth(2.0f);
        marker->GetPen()->SetLineType(vtkPen::DOT_LINE);
        marker->SetLabel("marks");
        // One legend entry for all of them.
        if (x != plot.x_markers.front()) marker->SetLegendVisibility(false);
      }
    }
  }
  if (plot.x_range) fix_axis(chart->GetAxis(vtkAxis::BOTTOM), *plot.x_range);
  if (plot.y_range) fix_axis(chart->GetAxis(vtkAxis::LEFT), *plot.y_range);
  if (!plot.axis_numbers) {
    for (int axis : {vtkAxis::LEFT, vtkAxis::BOTTOM}) {
      chart->GetAxis(axis)->SetLabelsVisible(false);
      chart->GetAxis(axis)->SetGridVisible(false);
    }
  }

  detail::write_window_png(chart_view.view->GetRenderWindow(), png_path);
}

void plot_along_path(const std::string& png_path, const AlongPathPlotInput& input, const ImageSize& size) {
  LinePlot plot;
  plot.title = input.title;
  plot.x_title = "path length s [mm]";
  plot.y_title = input.y_title;
  plot.y2_title = input.y2_title;
  for (const Series& series : input.series) {
    Series in_mm = series;
    in_mm.x = scaled(series.x, 1e3);
    plot.series.push_back(std::move(in_mm));
  }
  plot.x_markers = scaled(input.markers_s_m, 1e3);
  write_line_plot_png(png_path, plot, size);
}

Histogram make_histogram(const std::vector<double>& values, int bin_count,
                         const std::optional<Range>& range) {
  return make_walked_histogram([&values](const std::function<void(double)>& visit) {
    for (double v : values) visit(v);
  }, bin_count, range);
}

Histogram make_walked_histogram(const ValueWalk& walk, int bin_count, const std::optional<Range>& range) {
  if (bin_count < 1) {
    throw InputError("histogram: bin count " + std::to_string(bin_count) + " must be >= 1");
  }
  // First walk: count, check, and the range as std::minmax_element gives it (the first
  // smallest, the last largest).
  std::size_t count = 0;
  double low = 0.0, high = 0.0;
  walk([&](double v) {
    if (!std::isfinite(v)) {
      throw InputError("histogram: value " + std::to_string(count) + " (" + format_double(v) + ") is not finite");
    }
    if (count == 0 || v < low) low = v;
    if (count == 0 || !(v < high)) high = v;
    ++count;
  });
  if (count == 0) throw InputError("histogram: no values");
  check_range(range, "histogram: range");
  Range r;
  if (range) {
    r = *range;
  } else {
    r = {low, high};
    if (!(r.min < r.max)) r = {r.min - 0.5, r.max + 0.5};
  }
  Histogram h;
  h.edges.resize(static_cast<std::size_t>(bin_count) + 1);
  const double width = (r.max - r.min) / bin_count;
  for (int i = 0; i <= bin_count; ++i) h.edges[static_cast<std::size_t>(i)] = r.min + i * width;
  h.edges.back() = r.max;
  h.counts.assign(static_cast<std::size_t>(bin_count), 0.0);
  walk([&](double v) {
    if (v < r.min) {
      ++h.below;
    } else if (v > r.max) {
      ++h.above;
    } else {
      const auto bin = std::min(static_cast<std::size_t>((v - r.min) / width),
                                static_cast<std::size_t>(bin_count) - 1);
      h.counts[bin] += 1.0;
    }
  });
  return h;
}

void write_histogram_png(const std::string& png_path, const HistogramPlot& plot,
                         const ImageSize& size) {
  const Histogram& h = plot.histogram;
  if (h.counts.empty() || h.edges.size() != h.counts.size() + 1) {
    throw InputError("histogram plot '" + plot.title + "': needs bin_count >= 1 counts and " +
                     "bin_count + 1 edges, has " + std::to_string(h.counts.size()) + " and " +
                     std::to_string(h.edges.size()));
  }
  for (std::size_t i = 0; i + 1 < h.edges.size(); ++i) {
    if (!(std::isfinite(h.edges[i]) && std::isfinite(h.edges[i + 1]) &&
          h.edges[i] < h.edges[i + 1])) {
      throw InputError("histogram plot '" + plot.title + "': edges " + std::to_string(i) + " and " +
                       std::to_string(i + 1) + " do not increase");
    }
  }
  check_size(size);
  require_display();

  std::vector<double> centres(h.counts.size());
  for (std::size_t i = 0; i < centres.size(); ++i) centres[i] = 0.5 * (h.edges[i] + h.edges[i + 1]);
  ChartView chart_view = make_chart(size, plot.title);
  vtkChartXY* chart = chart_view.chart;
  chart->GetAxis(vtkAxis::BOTTOM)->SetTitle(plot.x_title);
  chart->GetAxis(vtkAxis::LEFT)->SetTitle(plot.y_title);
  chart->SetShowLegend(false);
  chart->SetBarWidthFraction(0.9f);
  vtkPlot* bars = chart->AddPlot(vtkChart::BAR);
  std::vector<double> heights = h.counts;
  if (plot.log_counts) {
    for (double& count : heights) count = std::log10(1.0 + count);
  }
  bars->SetInputData(two_column_table("x", centres, plot.y_title, heights), 0, 1);
  const Rgb colour = plot.colour.value_or(Rgb{31 / 255.0, 119 / 255.0, 180 / 255.0});
  bars->SetColor(channel(colour.r), channel(colour.g), channel(colour.b), 255);
  fix_axis(chart->GetAxis(vtkAxis::BOTTOM), {h.edges.front(), h.edges.back()});
  const double top = *std::max_element(heights.begin(), heights.end());
  fix_axis(chart->GetAxis(vtkAxis::LEFT), {0.0, top > 0.0 ? 1.05 * top : 1.0});

  detail::write_window_png(chart_view.view->GetRenderWindow(), png_path);
}

void plot_feedrate(const std::string& png_path, const FeedratePlotInput& input,
                   const ImageSize& size) {
  constexpr double kMmPerM = 1e3;
  constexpr double kMPerMinPerMPerS = 60.0;
  LinePlot plot;
  plot.title = input.title;
  plot.x_title = "s [mm]";
  plot.y_title = "feedrate [m/min]";
  struct Named {
    const char* name;
    const Curve* curve;
    LineStyle style;
    Rgb colour;
  };
  const Named curves[] = {
      {"programmed", &input.programmed, LineStyle::dashed, {0.3, 0.3, 0.3}},
      {"limit sd_lim", &input.limit, LineStyle::dotted, {214 / 255.0, 39 / 255.0, 40 / 255.0}},
      {"planned", &input.planned, LineStyle::solid, {31 / 255.0, 119 / 255.0, 180 / 255.0}},
      {"actual", &input.actual, LineStyle::solid, {255 / 255.0, 127 / 255.0, 14 / 255.0}},
  };
  for (const Named& named : curves) {
    if (named.curve->x.empty() && named.curve->y.empty()) continue;
    Series series;
    series.name = named.name;
    series.x = scaled(named.curve->x, kMmPerM);
    series.y = scaled(named.curve->y, kMPerMinPerMPerS);
    series.style = named.style;
    series.colour = named.colour;
    plot.series.push_back(std::move(series));
  }
  if (plot.series.empty()) throw InputError("feedrate plot: no curve given");
  write_line_plot_png(png_path, plot, size);
}

void plot_following_error(const std::string& png_path, const std::vector<AxisErrorSeries>& axes,
                          const std::string& title, const ImageSize& size) {
  constexpr double kUmPerM = 1e6;
  constexpr double mdeg_per_rad = 180.0 / std::numbers::pi * 1e3;
  if (axes.empty()) throw InputError("following error plot: no axis given");
  LinePlot plot;
  plot.title = title;
  plot.x_title = "t [s]";
  bool any_linear = false, any_rotary = false;
  for (const AxisErrorSeries& axis : axes) {
    Series series;
    series.name = axis.axis + (axis.rotary ? " [mdeg]" : " [um]");
    series.x = axis.t_s;
    series.y = scaled(axis.error, axis.rotary ? mdeg_per_rad : kUmPerM);
    series.style = axis.rotary ? LineStyle::dashed : LineStyle::solid;
    series.right_axis = axis.rotary;  // undone below when there is no linear axis
    any_linear = any_linear || !axis.rotary;
    any_rotary = any_rotary || axis.rotary;
    plot.series.push_back(std::move(series));
  }
  if (any_linear) {
    plot.y_title = "linear axes: following error [um]";
    if (any_rotary) plot.y2_title = "rotary axes: following error [mdeg]";
  } else {
    plot.y_title = "rotary axes: following error [mdeg]";
  }
  if (!any_linear) {
    for (Series& series : plot.series) series.right_axis = false;
  }
  write_line_plot_png(png_path, plot, size);
}

void plot_residuals(const std::string& png_path, const ResidualPlotInput& input,
                    const ImageSize& size) {
  LinePlot plot;
  plot.title = input.title;
  plot.x_title = input.x_title;
  plot.y_title = input.y_title;
  Series before{.name = "before", .x = input.x, .y = input.before, .colour = Rgb{0.6, 0.6, 0.6}};
  Series after{.name = "after", .x = input.x, .y = input.after,
               .colour = Rgb{31 / 255.0, 119 / 255.0, 180 / 255.0}};
  plot.series = {std::move(before), std::move(after)};
  write_line_plot_png(png_path, plot, size);
}

void plot_deviation_histogram(const std::string& png_path, const std::vector<double>& deviation_m,
                              int bin_count, const std::string& title, const ImageSize& size,
                              bool log_counts) {
  HistogramPlot plot;
  plot.title = title;
  plot.x_title = "deviation [um]";
  plot.log_counts = log_counts;
  if (log_counts) plot.y_title = "lines, log10(1 + count)";
  plot.histogram = make_histogram(scaled(deviation_m, 1e6), bin_count);
  write_histogram_png(png_path, plot, size);
}

void plot_walked_deviation_histogram(const std::string& png_path, const ValueWalk& deviation_m, int bin_count,
                              const std::string& title, const ImageSize& size, bool log_counts) {
  HistogramPlot plot;
  plot.title = title;
  plot.x_title = "deviation [um]";
  plot.log_counts = log_counts;
  if (log_counts) plot.y_title = "lines, log10(1 + count)";
  plot.histogram = make_walked_histogram([&deviation_m](const std::function<void(double)>& visit) {
    deviation_m([&visit](double d) { visit(d * 1e6); });
  }, bin_count);
  write_histogram_png(png_path, plot, size);
}

double polar_division_m(double largest_deviation_m) {
  const double largest_um = std::abs(largest_deviation_m) * 1e6;
  for (int exponent = -2; exponent < 9; ++exponent) {
    for (double mantissa : {1.0, 2.0, 5.0}) {
      const double division_um = mantissa * std::pow(10.0, exponent);
      if (4.0 * division_um >= largest_um) return division_um * 1e-6;
    }
  }
  return 1e3;  // 1 m a ring: deviations beyond any circle test
}

void plot_polar_deviation(const std::string& png_path, const PolarDeviationPlotInput& input,
                          const ImageSize& size) {
  double largest = 0.0;
  bool any_point = false;
  for (std::size_t k = 0; k < input.curves.size(); ++k) {
    const PolarCurve& curve = input.curves[k];
    if (curve.angle_rad.size() != curve.deviation_m.size()) {
      throw InputError("polar plot '" + input.title + "', curve '" + curve.name + "': " +
                       std::to_string(curve.angle_rad.size()) + " angles, " +
                       std::to_string(curve.deviation_m.size()) + " deviations");
    }
    for (std::size_t i = 0; i < curve.deviation_m.size(); ++i) {
      if (!std::isfinite(curve.deviation_m[i]) || !std::isfinite(curve.angle_rad[i])) {
        throw InputError("polar plot '" + input.title + "', curve '" + curve.name + "': point " +
                         std::to_string(i) + " is not finite");
      }
      largest = std::max(largest, std::abs(curve.deviation_m[i]));
    }
    any_point = any_point || !curve.angle_rad.empty();
  }
  if (!any_point) throw InputError("polar plot '" + input.title + "': no curve with points");
  const double division = input.division_m > 0.0 ? input.division_m : polar_division_m(largest);
  // In ring units: the nominal circle at 8, rings 4 ... 12; a deviation beyond 7.5 rings inwards
  // is drawn at 0.5 (the centre region stays readable).
  constexpr double kNominal = 8.0;
  LinePlot plot;
  plot.title = input.title;
  plot.axis_numbers = false;
  plot.legend_outside = false;  // in a corner the circle leaves free: the plot area stays square
  plot.x_range = Range{-13.5, 13.5};
  plot.y_range = Range{-13.5, 13.5};
  const auto circle = [](double radius, std::vector<double>& x, std::vector<double>& y) {
    for (int i = 0; i <= 360; ++i) {
      const double t = i * std::numbers::pi / 180.0;
      x.push_back(radius * std::cos(t));
      y.push_back(radius * std::sin(t));
    }
  };
  for (int ring = -4; ring <= 4; ++ring) {
    Series series;
    circle(kNominal + ring, series.x, series.y);
    series.colour = ring == 0 ? Rgb{0.0, 0.0, 0.0} : Rgb{0.75, 0.75, 0.75};
    series.style = ring == 0 ? LineStyle::dashed : LineStyle::dotted;
    series.line_width_px = ring == 0 ? 1.5 : 1.0;
    series.name = "nominal circle";
    series.in_legend = ring == 0;
    plot.series.push_back(std::move(series));
  }
  for (int spoke = 0; spoke < 4; ++spoke) {
    Series series;
    const double t = spoke * std::numbers::pi / 2.0;
    series.x = {0.0, (kNominal + 4.5) * std::cos(t)};
    series.y = {0.0, (kNominal + 4.5) * std::sin(t)};
    series.colour = Rgb{0.75, 0.75, 0.75};
    series.style = LineStyle::dotted;
    series.line_width_px = 1.0;
    series.name = "axes";
    series.in_legend = false;
    plot.series.push_back(std::move(series));
  }
  for (const PolarCurve& curve : input.curves) {
    if (curve.angle_rad.empty()) continue;
    Series series;
    series.name = curve.name;
    series.style = curve.style;
    series.colour = curve.colour;
    for (std::size_t i = 0; i <= curve.angle_rad.size(); ++i) {
      const std::size_t k = i % curve.angle_rad.size();  // closed: back to the first point
      const double radius = std::max(0.5, kNominal + curve.deviation_m[k] / division);
      series.x.push_back(radius * std::cos(curve.angle_rad[k]));
      series.y.push_back(radius * std::sin(curve.angle_rad[k]));
    }
    plot.series.push_back(std::move(series));
  }
  const std::string scale = format_double(std::round(division * 1e8) / 1e2) + " um per ring";
  plot.x_title = "+" + input.u_name + " ->   radial deviation magnified: " + scale +
                 " (nominal circle R " + format_double(std::round(input.nominal_radius_m * 1e6) / 1e3) +
                 " mm dashed)";
  plot.y_title = "+" + input.v_name + " ->";
  write_line_plot_png(png_path, plot, size);
}

}  // namespace vmsim::viz
