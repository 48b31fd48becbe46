#pragma once
// A machined surface as a height field on a regular grid: off-screen renders (PNG) coloured by a
// scalar such as the deviation, with a colour bar, outlines of marked regions, camera presets;
// and files for other viewers (.vtp for ParaView, binary .stl).
//
// Errors: bad data throws vmsim::InputError naming the field and the value; a render without an
// X display throws NoDisplayError (display.hpp) before any window is created; an output that
// cannot be written throws vmsim::InputError naming the path. Files appear complete or not at all.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "vmsim/viz/plot.hpp"

namespace vmsim::viz {

/// Heights z(x, y) on a regular grid in the workpiece frame W, SI units. Node (i, j), i along x
/// in [0, nx), j along y in [0, ny), is at x = origin_x_m + i spacing_x_m, y = origin_y_m + j
/// spacing_y_m; its values are at index i + nx j (x fastest) of each per-node vector.
struct HeightField {
  double origin_x_m = 0.0;
  double origin_y_m = 0.0;
  double spacing_x_m = 1e-3;  ///< > 0
  double spacing_y_m = 1e-3;  ///< > 0
  int nx = 0;                 ///< >= 2
  int ny = 0;                 ///< >= 2
  std::vector<double> height_m;     ///< nx ny values, finite
  std::vector<double> deviation_m;  ///< empty, or nx ny values (e.g. simulated minus reference)

  std::size_t node_count() const { return static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny); }
  std::size_t index(int i, int j) const {
    return static_cast<std::size_t>(i) + static_cast<std::size_t>(nx) * static_cast<std::size_t>(j);
  }
};

/// Checks sizes, spacings and finiteness; throws vmsim::InputError naming the field.
void validate(const HeightField& field);

/// A polyline in the xy plane of W [m], draped on the surface (its z is the surface height,
/// interpolated bilinearly; points outside the grid are clamped to its border).
struct Outline {
  std::vector<double> x_m;
  std::vector<double> y_m;  ///< same length as x_m, >= 2 points
  bool closed = true;
};

/// A box in the xy plane of W [m] (min < max).
struct BoxXY {
  double x_min_m = 0.0;
  double x_max_m = 0.0;
  double y_min_m = 0.0;
  double y_max_m = 0.0;
};

/// A text label at a point of the surface (x, y in W [m]; drawn at the surface's height there),
/// e.g. a mark's number. Labels are placed so that none overlaps another (label_placement.hpp):
/// one that cannot sit at its point gets a leader line, one with no room is left out.
struct SurfaceLabel {
  double x_m = 0.0;
  double y_m = 0.0;
  std::string text;
};

enum class CameraPreset {
  overall,   ///< the whole surface, oblique view (view_azimuth_deg, view_elevation_deg)
  top,       ///< the whole surface seen from +z, x to the right
  close_up,  ///< the part of the surface in close_up_box, oblique view
};

struct SurfaceRenderOptions {
  std::string title;
  ImageSize size{1000, 800};
  /// What colours the surface: the deviation when the field has one (shown in um, diverging map
  /// blue-white-red), otherwise the height (sequential map, viridis; shown in mm, or in um when
  /// the colour range is under 0.1 mm).
  /// Colour range in m: default symmetric about 0 for the deviation (+- the largest |deviation|
  /// of the nodes in view), [min, max] of the heights for the height.
  std::optional<Range> colour_range_m;
  /// Regions to outline: a per-node mask (empty, or nx ny values; nonzero = marked) whose
  /// boundary is drawn as a line on the surface, and/or polylines.
  std::vector<std::uint8_t> region_mask;
  std::vector<Outline> outlines;
  Rgb outline_colour{0.0, 0.0, 0.0};
  double outline_width_px = 3.0;
  CameraPreset camera = CameraPreset::overall;
  std::optional<BoxXY> close_up_box;  ///< required for CameraPreset::close_up
  double view_azimuth_deg = -35.0;    ///< oblique views: direction from the centre to the eye,
  double view_elevation_deg = 40.0;   ///< azimuth from -y towards +x, elevation above the xy plane
  /// Vertical exaggeration of the heights in the image (machined marks are um on mm): 1 = true.
  double height_scale = 1.0;
  bool colour_bar = true;
  /// Labels in order of importance (the first are placed first); see SurfaceLabel.
  std::vector<SurfaceLabel> labels;
};

/// What a render could not show: the indices into options.labels of the labels left out (no
/// room without overlapping another, or their point out of the image), for a caption.
struct SurfaceRenderResult {
  std::vector<std::size_t> labels_left_out;
};

/// Renders the surface off-screen and writes a PNG of options.size to `png_path`.
SurfaceRenderResult render_surface_png(const std::string& png_path, const HeightField& field,
                        const SurfaceRenderOptions& options = {});

/// Writes the surface as VTK XML PolyData (.vtp, binary appended, zlib): points in m (true
/// heights), triangles, point data "height_m" and, when present, "deviation_m". Needs no display.
void write_surface_vtp(const std::string& vtp_path, const HeightField& field);

/// Writes the surface as binary STL (two triangles per grid cell), coordinates in mm (the usual
/// unit of STL files in machining). Needs no display.
void write_surface_stl(const std::string& stl_path, const HeightField& field);

}  // namespace vmsim::viz
