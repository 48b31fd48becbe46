#pragma once
// Line plots and histograms written as PNG images, rendered off-screen (VTK charts).
//
// The generic plots (LinePlot, HistogramPlot) draw numbers as given: the caller puts the display
// unit in the axis titles ("s [mm]"). The helpers below them (plot_feedrate, ...) take SI values
// and convert once, to the display units their documentation names.
//
// Every function that writes a PNG first checks for an X display and throws NoDisplayError
// (display.hpp) when there is none; bad data (vectors of different lengths, non-finite values,
// nothing to plot) throws vmsim::InputError naming the series and the index; an output that
// cannot be written throws vmsim::InputError naming the path. The PNG appears complete or not at
// all (written to a temporary name, then renamed).
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace vmsim::viz {

/// Size of an image in pixels.
struct ImageSize {
  int width_px = 1000;
  int height_px = 600;
};

/// A colour, each channel in [0, 1].
struct Rgb {
  double r = 0.0;
  double g = 0.0;
  double b = 0.0;
};

/// A closed interval [min, max] with min < max, in the unit of the axis it is used for.
struct Range {
  double min = 0.0;
  double max = 1.0;
};

enum class LineStyle { solid, dashed, dotted };

/// One named curve of a line plot: the points (x[i], y[i]), in the units of the plot's axes.
struct Series {
  std::string name{};  ///< shown in the legend
  std::vector<double> x{};
  std::vector<double> y{};  ///< same length as x; every value finite
  LineStyle style = LineStyle::solid;
  std::optional<Rgb> colour{};  ///< default: the next colour of a fixed palette
  double line_width_px = 2.0;
  bool right_axis = false;  ///< plotted against the right y axis (LinePlot::y2_title)
  bool in_legend = true;    ///< false: drawn, but not listed in the legend (grid rings, spokes)
};

struct LinePlot {
  std::string title;
  std::string x_title;   ///< with its unit, e.g. "s [mm]"
  std::string y_title;   ///< left axis, with its unit
  std::string y2_title;  ///< right axis (used when a series has right_axis)
  std::vector<Series> series;  ///< at least one series with at least one point
  std::optional<Range> x_range;  ///< default: fitted to the data
  std::optional<Range> y_range;  ///< left axis; default: fitted to the data
  bool legend = true;
  /// The legend beside the plot area (right, top), never over the data; false: inside it.
  bool legend_outside = true;
  /// Vertical dotted lines across the plot (e.g. where the marks are), at these x values.
  std::vector<double> x_markers;
  /// false: no tick numbers and no grid on the axes (a drawing whose coordinates mean nothing
  /// by themselves, such as a magnified polar plot whose scale is stated in the titles).
  bool axis_numbers = true;
};

/// Checks the plot's data; throws vmsim::InputError naming the series, the field and the index.
void validate(const LinePlot& plot);

/// Renders `plot` off-screen and writes it as a PNG of `size` to `png_path`.
void write_line_plot_png(const std::string& png_path, const LinePlot& plot,
                         const ImageSize& size = {});

/// Counts of values in equal bins: bin i is [edges[i], edges[i+1]), the last bin is closed.
struct Histogram {
  std::vector<double> edges;   ///< bin_count + 1 increasing values
  std::vector<double> counts;  ///< bin_count values
  std::size_t below = 0;       ///< values below edges.front() (not counted in a bin)
  std::size_t above = 0;       ///< values above edges.back() (not counted in a bin)
};

/// Bins `values` into `bin_count` equal bins over `range` (default: [min, max] of the values,
/// widened by half a unit around a single repeated value). Non-finite values are an error.
/// Throws vmsim::InputError for bin_count < 1, no values, a bad range or a non-finite value.
Histogram make_histogram(const std::vector<double>& values, int bin_count,
                         const std::optional<Range>& range = std::nullopt);

/// Calls its argument with each value, in the same order every time.
using ValueWalk = std::function<void(const std::function<void(double)>& visit)>;

/// The same for values too many to hold (a view's lines): `walk` is called twice (the range,
/// then the counts). Same result as make_histogram of the values walked.
Histogram make_walked_histogram(const ValueWalk& walk, int bin_count, const std::optional<Range>& range = std::nullopt);

struct HistogramPlot {
  std::string title;
  std::string x_title;  ///< with its unit, the unit of the histogram's edges
  std::string y_title = "count";
  Histogram histogram;
  std::optional<Rgb> colour;
  /// Bars of log10(1 + count) (y_title should say so): the few lines of a mark's tail stay
  /// visible next to the millions of lines at zero deviation.
  bool log_counts = false;
};

/// Renders `plot` as bars off-screen and writes it as a PNG of `size` to `png_path`.
void write_histogram_png(const std::string& png_path, const HistogramPlot& plot,
                         const ImageSize& size = {});

// ---- Plots of the simulation chain (SI in, display units out) --------------------------------

/// A curve in SI: x and y in the units the function using it names.
struct Curve {
  std::vector<double> x{};
  std::vector<double> y{};
};

/// The feedrate along the path. Each curve: x = arc length s of the tool tip [m], y = feedrate
/// [m/s]. An empty curve is left out; at least one must be given.
struct FeedratePlotInput {
  std::string title = "Feedrate along the path";
  Curve programmed;  ///< the programmed feed (dashed)
  Curve limit;       ///< the feed limit sd_lim from the drive limits (dotted)
  Curve planned;     ///< the planned (interpolated) feed
  Curve actual;      ///< the feed of the simulated tool trajectory
};

/// Plots the feedrate curves: s in mm, feedrate in m/min (the papers' unit).
void plot_feedrate(const std::string& png_path, const FeedratePlotInput& input,
                   const ImageSize& size = {});

/// One axis's following error (set point minus actual position) over time.
struct AxisErrorSeries {
  std::string axis;        ///< axis name, e.g. "X", "A"
  bool rotary = false;     ///< true: error in rad; false: error in m
  std::vector<double> t_s;
  std::vector<double> error;  ///< [m] for a linear axis, [rad] for a rotary axis
};

/// Plots each axis's following error over time [s]: linear axes in um on the left axis, rotary
/// axes in mdeg (1e-3 deg) on the right axis. At least one axis.
void plot_following_error(const std::string& png_path, const std::vector<AxisErrorSeries>& axes,
                          const std::string& title = "Following error",
                          const ImageSize& size = {});

/// Values along the tool path: x = path length s of the tool tip [m], one curve per named
/// quantity in the display unit `y_title` names (the caller converts), markers at given s [m].
struct AlongPathPlotInput {
  std::string title;
  std::string y_title;   ///< left axis, with its unit
  std::string y2_title;  ///< right axis, with its unit (for series with right_axis)
  std::vector<Series> series;   ///< x in m (converted to mm here), y as displayed
  std::vector<double> markers_s_m;  ///< e.g. the marks' places
};

/// Plots `input` against s in mm.
void plot_along_path(const std::string& png_path, const AlongPathPlotInput& input, const ImageSize& size = {});

/// A residual before and after a correction (identification, compensation), on a common x.
/// Values are plotted as given: the caller chooses the display unit and names it in the titles.
struct ResidualPlotInput {
  std::string title = "Residual before and after";
  std::string x_title;  ///< with its unit
  std::string y_title;  ///< with its unit
  std::vector<double> x;
  std::vector<double> before;  ///< same length as x
  std::vector<double> after;   ///< same length as x
};

void plot_residuals(const std::string& png_path, const ResidualPlotInput& input,
                    const ImageSize& size = {});

/// Histogram of surface deviations given in m, plotted in um over `bin_count` bins (default
/// range: the data's).
void plot_deviation_histogram(const std::string& png_path, const std::vector<double>& deviation_m,
                              int bin_count = 50, const std::string& title = "Deviation",
                              const ImageSize& size = {}, bool log_counts = false);

/// The same, the deviations [m] walked (twice) rather than held.
void plot_walked_deviation_histogram(const std::string& png_path, const ValueWalk& deviation_m, int bin_count,
                              const std::string& title, const ImageSize& size = {}, bool log_counts = false);

/// One curve of a polar deviation plot: the radial deviation [m] at polar angles [rad].
struct PolarCurve {
  std::string name;
  std::vector<double> angle_rad;
  std::vector<double> deviation_m;  ///< same length as angle_rad
  LineStyle style = LineStyle::solid;
  std::optional<Rgb> colour{};
};

/// The picture of a circular test as ballbar software draws it: the radial deviation magnified
/// about the nominal circle (drawn dashed), with rings every `division_m` of deviation (four
/// inside, four outside) and spokes along the axes; the scale is printed in the axis titles.
struct PolarDeviationPlotInput {
  std::string title;
  std::string u_name = "X";  ///< the horizontal axis (polar angle 0)
  std::string v_name = "Y";  ///< the vertical axis (polar angle 90 degrees)
  double nominal_radius_m = 0.0;  ///< for the caption
  std::vector<PolarCurve> curves;  ///< at least one with points
  /// Deviation per ring [m]; 0 = the smallest of 1, 2, 5 x 10^k um that fits the largest
  /// deviation within four rings (polar_division_m).
  double division_m = 0.0;
};

/// The ring spacing for deviations up to `largest_deviation_m` [m]: the smallest of 1, 2, 5 x
/// 10^k um (k from -2 up) with 4 rings >= the deviation.
double polar_division_m(double largest_deviation_m);

/// Draws `input` (polar radius = 8 rings + deviation / division_m, in ring units) and writes a
/// PNG. Throws NoDisplayError without a display, vmsim::InputError for bad data (naming the
/// curve and the index).
void plot_polar_deviation(const std::string& png_path, const PolarDeviationPlotInput& input,
                          const ImageSize& size = {900, 820});

}  // namespace vmsim::viz
