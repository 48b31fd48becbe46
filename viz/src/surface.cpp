// Height-field surfaces: polydata built directly from the grid, rendered off-screen with a
// scalar bar, outlines and a camera preset; written as .vtp (VTK) or binary .stl (by hand).
#include "vmsim/viz/surface.hpp"

#include <vtkActor.h>
#include <vtkActor2D.h>
#include <vtkCamera.h>
#include <vtkCellArray.h>
#include <vtkColorTransferFunction.h>
#include <vtkContourFilter.h>
#include <vtkCoordinate.h>
#include <vtkDoubleArray.h>
#include <vtkImageData.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkPolyDataMapper2D.h>
#include <vtkPolyDataNormals.h>
#include <vtkProperty.h>
#include <vtkProperty2D.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkScalarBarActor.h>
#include <vtkSmartPointer.h>
#include <vtkTextActor.h>
#include <vtkTextProperty.h>
#include <vtkTextRenderer.h>
#include <vtkMatrix4x4.h>
#include <vtkXMLPolyDataWriter.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>

#include "render_output.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/viz/display.hpp"
#include "vmsim/viz/label_placement.hpp"

namespace vmsim::viz {
namespace {

constexpr double kUmPerM = 1e6;
constexpr double kMmPerM = 1e3;

double radians(double degrees) { return degrees * std::numbers::pi / 180.0; }

vtkSmartPointer<vtkDoubleArray> point_array(const char* name, const std::vector<double>& values,
                                            double factor) {
  auto array = vtkSmartPointer<vtkDoubleArray>::New();
  array->SetName(name);
  array->SetNumberOfValues(static_cast<vtkIdType>(values.size()));
  for (std::size_t k = 0; k < values.size(); ++k) {
    array->SetValue(static_cast<vtkIdType>(k), values[k] * factor);
  }
  return array;
}

// Points (z multiplied by z_scale) and two triangles per grid cell; no point data.
vtkSmartPointer<vtkPolyData> grid_polydata(const HeightField& field, double z_scale) {
  auto points = vtkSmartPointer<vtkPoints>::New();
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(static_cast<vtkIdType>(field.node_count()));
  for (int j = 0; j < field.ny; ++j) {
    for (int i = 0; i < field.nx; ++i) {
      const std::size_t k = field.index(i, j);
      points->SetPoint(static_cast<vtkIdType>(k), field.origin_x_m + i * field.spacing_x_m,
                       field.origin_y_m + j * field.spacing_y_m, field.height_m[k] * z_scale);
    }
  }
  auto triangles = vtkSmartPointer<vtkCellArray>::New();
  triangles->AllocateExact(2 * static_cast<vtkIdType>(field.nx - 1) * (field.ny - 1), 6);
  for (int j = 0; j + 1 < field.ny; ++j) {
    for (int i = 0; i + 1 < field.nx; ++i) {
      const auto a = static_cast<vtkIdType>(field.index(i, j));
      const auto b = static_cast<vtkIdType>(field.index(i + 1, j));
      const auto c = static_cast<vtkIdType>(field.index(i + 1, j + 1));
      const auto d = static_cast<vtkIdType>(field.index(i, j + 1));
      const vtkIdType first[3] = {a, b, c};
      const vtkIdType second[3] = {a, c, d};
      triangles->InsertNextCell(3, first);
      triangles->InsertNextCell(3, second);
    }
  }
  auto polydata = vtkSmartPointer<vtkPolyData>::New();
  polydata->SetPoints(points);
  polydata->SetPolys(triangles);
  return polydata;
}

// Bilinear height at (x, y) [m], clamped to the grid.
double height_at(const HeightField& field, double x_m, double y_m) {
  const double u = std::clamp((x_m - field.origin_x_m) / field.spacing_x_m, 0.0,
                              static_cast<double>(field.nx - 1));
  const double v = std::clamp((y_m - field.origin_y_m) / field.spacing_y_m, 0.0,
                              static_cast<double>(field.ny - 1));
  const int i = std::min(static_cast<int>(u), field.nx - 2);
  const int j = std::min(static_cast<int>(v), field.ny - 2);
  const double fu = u - i, fv = v - j;
  const auto& h = field.height_m;
  return (1 - fu) * (1 - fv) * h[field.index(i, j)] + fu * (1 - fv) * h[field.index(i + 1, j)] +
         fu * fv * h[field.index(i + 1, j + 1)] + (1 - fu) * fv * h[field.index(i, j + 1)];
}

// The outlines draped on the surface: each segment cut into steps of at most half a grid
// spacing, so that the line follows the surface between its points.
vtkSmartPointer<vtkPolyData> draped_outlines(const HeightField& field,
                                             const std::vector<Outline>& outlines,
                                             double z_scale, double lift) {
  auto points = vtkSmartPointer<vtkPoints>::New();
  points->SetDataTypeToDouble();
  auto lines = vtkSmartPointer<vtkCellArray>::New();
  const double step = 0.5 * std::min(field.spacing_x_m, field.spacing_y_m);
  for (const Outline& outline : outlines) {
    std::vector<std::array<double, 2>> corners;
    for (std::size_t k = 0; k < outline.x_m.size(); ++k) {
      corners.push_back({outline.x_m[k], outline.y_m[k]});
    }
    if (outline.closed) corners.push_back(corners.front());
    std::vector<vtkIdType> ids;
    for (std::size_t k = 0; k + 1 < corners.size(); ++k) {
      const double dx = corners[k + 1][0] - corners[k][0];
      const double dy = corners[k + 1][1] - corners[k][1];
      const int pieces = std::max(1, static_cast<int>(std::ceil(std::hypot(dx, dy) / step)));
      for (int p = 0; p < pieces; ++p) {
        const double x = corners[k][0] + dx * p / pieces;
        const double y = corners[k][1] + dy * p / pieces;
        ids.push_back(points->InsertNextPoint(x, y, height_at(field, x, y) * z_scale + lift));
      }
    }
    const auto& last = corners.back();
    ids.push_back(points->InsertNextPoint(last[0], last[1],
                                          height_at(field, last[0], last[1]) * z_scale + lift));
    lines->InsertNextCell(static_cast<vtkIdType>(ids.size()), ids.data());
  }
  auto polydata = vtkSmartPointer<vtkPolyData>::New();
  polydata->SetPoints(points);
  polydata->SetLines(lines);
  return polydata;
}

// The boundary of the marked nodes: the 0.5 level of the mask on the grid (marching squares),
// draped on the surface and lifted by `lift` (display units).
vtkSmartPointer<vtkPolyData> mask_outline(const HeightField& field,
                                          const std::vector<std::uint8_t>& region_mask,
                                          double z_scale, double lift) {
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetDimensions(field.nx, field.ny, 1);
  image->SetOrigin(field.origin_x_m, field.origin_y_m, 0.0);
  image->SetSpacing(field.spacing_x_m, field.spacing_y_m, 1.0);
  std::vector<double> mask(region_mask.size());
  for (std::size_t k = 0; k < mask.size(); ++k) mask[k] = region_mask[k] != 0 ? 1.0 : 0.0;
  image->GetPointData()->SetScalars(point_array("mask", mask, 1.0));
  auto contour = vtkSmartPointer<vtkContourFilter>::New();
  contour->SetInputData(image);
  contour->SetValue(0, 0.5);
  contour->Update();
  vtkSmartPointer<vtkPolyData> lines = contour->GetOutput();
  vtkPoints* points = lines->GetPoints();
  for (vtkIdType k = 0; points != nullptr && k < points->GetNumberOfPoints(); ++k) {
    double p[3];
    points->GetPoint(k, p);
    points->SetPoint(k, p[0], p[1], height_at(field, p[0], p[1]) * z_scale + lift);
  }
  return lines;
}

vtkSmartPointer<vtkColorTransferFunction> diverging_map(double half_range) {
  // Moreland's cool-warm map: blue (negative) - light grey (zero) - red (positive).
  auto map = vtkSmartPointer<vtkColorTransferFunction>::New();
  map->SetColorSpaceToDiverging();
  map->AddRGBPoint(-half_range, 0.230, 0.299, 0.754);
  map->AddRGBPoint(half_range, 0.706, 0.016, 0.150);
  return map;
}

vtkSmartPointer<vtkColorTransferFunction> sequential_map(double low, double high) {
  // Viridis, sampled at five points and interpolated in Lab.
  static constexpr double kViridis[5][3] = {{0.267, 0.005, 0.329},
                                            {0.229, 0.322, 0.546},
                                            {0.128, 0.567, 0.551},
                                            {0.369, 0.789, 0.383},
                                            {0.993, 0.906, 0.144}};
  auto map = vtkSmartPointer<vtkColorTransferFunction>::New();
  map->SetColorSpaceToLab();
  for (int k = 0; k < 5; ++k) {
    map->AddRGBPoint(low + (high - low) * k / 4.0, kViridis[k][0], kViridis[k][1], kViridis[k][2]);
  }
  return map;
}

bool in_box(const BoxXY& box, double x, double y) {
  return x >= box.x_min_m && x <= box.x_max_m && y >= box.y_min_m && y <= box.y_max_m;
}

void check_options(const HeightField& field, const SurfaceRenderOptions& options) {
  if (options.size.width_px < 16 || options.size.height_px < 16 || options.size.width_px > 8192 ||
      options.size.height_px > 8192) {
    throw InputError("surface render: image size " + std::to_string(options.size.width_px) + "x" +
                     std::to_string(options.size.height_px) + " px: each side must be in [16, 8192]");
  }
  if (!options.region_mask.empty() && options.region_mask.size() != field.node_count()) {
    throw InputError("surface render: region_mask has " +
                     std::to_string(options.region_mask.size()) + " values, the grid " +
                     std::to_string(field.node_count()) + " nodes");
  }
  for (std::size_t k = 0; k < options.outlines.size(); ++k) {
    const Outline& outline = options.outlines[k];
    if (outline.x_m.size() != outline.y_m.size() || outline.x_m.size() < 2) {
      throw InputError("surface render: outline " + std::to_string(k) + " has " +
                       std::to_string(outline.x_m.size()) + " x and " +
                       std::to_string(outline.y_m.size()) +
                       " y values: needs the same number, at least 2");
    }
    for (std::size_t i = 0; i < outline.x_m.size(); ++i) {
      if (!std::isfinite(outline.x_m[i]) || !std::isfinite(outline.y_m[i])) {
        throw InputError("surface render: outline " + std::to_string(k) + ", point " +
                         std::to_string(i) + " is not finite");
      }
    }
  }
  if (options.colour_range_m &&
      !(std::isfinite(options.colour_range_m->min) && std::isfinite(options.colour_range_m->max) &&
        options.colour_range_m->min < options.colour_range_m->max)) {
    throw InputError("surface render: colour_range_m [" +
                     format_double(options.colour_range_m->min) + ", " +
                     format_double(options.colour_range_m->max) + "] needs finite min < max");
  }
  if (!(options.height_scale > 0.0) || !std::isfinite(options.height_scale)) {
    throw InputError("surface render: height_scale " + format_double(options.height_scale) +
                     " must be > 0");
  }
  if (!(options.outline_width_px > 0.0)) {
    throw InputError("surface render: outline_width_px " +
                     format_double(options.outline_width_px) + " must be > 0");
  }
  if (!std::isfinite(options.view_azimuth_deg) || !std::isfinite(options.view_elevation_deg) ||
      std::abs(options.view_elevation_deg) >= 90.0) {
    throw InputError("surface render: view_elevation_deg " +
                     format_double(options.view_elevation_deg) +
                     " must be in (-90, 90) (use CameraPreset::top for a view from above)");
  }
  if (options.camera == CameraPreset::close_up) {
    if (!options.close_up_box) {
      throw InputError("surface render: CameraPreset::close_up needs close_up_box");
    }
    const BoxXY& box = *options.close_up_box;
    if (!(box.x_min_m < box.x_max_m && box.y_min_m < box.y_max_m)) {
      throw InputError("surface render: close_up_box x [" + format_double(box.x_min_m) + ", " +
                       format_double(box.x_max_m) + "] y [" + format_double(box.y_min_m) + ", " +
                       format_double(box.y_max_m) + "] m needs min < max");
    }
  }
}

// The width in pixels of `text` drawn with `property` (a window's default 72 dpi).
double text_width_px(vtkTextProperty* property, const std::string& text) {
  int box[4] = {0, 0, 0, 0};
  vtkTextRenderer* renderer = vtkTextRenderer::GetInstance();
  if (renderer == nullptr || !renderer->GetBoundingBox(property, text, box, 72)) {
    return 0.62 * property->GetFontSize() * static_cast<double>(text.size());  // about a bold glyph's
  }
  return box[1] - box[0] + 1;
}

// A rectangle of the image in normalised device coordinates ([-1, 1] across and up).
struct NormalizedArea {
  double x_min, x_max, y_min, y_max;
};

// Makes every point of `points` fall in `area` of the image (aspect = width / height): a camera
// that already shows them all there is left as it is; otherwise it is zoomed out as far as
// needed (never in) and its window centre shifted so that the points are centred in the area.
// vtkRenderer::ResetCamera fits the bounds' sphere to the whole window, which a tall surface
// (a cylinder's unrolled view) overflows, under the title.
void fit_into_area(vtkCamera* camera, vtkPoints* points, double aspect, const NormalizedArea& area) {
  auto extent = [&]() {
    vtkMatrix4x4* to_ndc = camera->GetCompositeProjectionTransformMatrix(aspect, -1.0, 1.0);
    NormalizedArea e{1e300, -1e300, 1e300, -1e300};
    double p[3];
    for (vtkIdType k = 0; k < points->GetNumberOfPoints(); ++k) {
      points->GetPoint(k, p);
      const double in[4] = {p[0], p[1], p[2], 1.0};
      double out[4];
      to_ndc->MultiplyPoint(in, out);
      if (!(out[3] > 0.0)) continue;  // behind the eye: cannot happen for a camera outside the bounds
      e.x_min = std::min(e.x_min, out[0] / out[3]);
      e.x_max = std::max(e.x_max, out[0] / out[3]);
      e.y_min = std::min(e.y_min, out[1] / out[3]);
      e.y_max = std::max(e.y_max, out[1] / out[3]);
    }
    return e;
  };
  NormalizedArea e = extent();
  if (e.x_min > e.x_max) return;
  auto inside = [&](const NormalizedArea& r) {
    return r.x_min >= area.x_min && r.x_max <= area.x_max && r.y_min >= area.y_min && r.y_max <= area.y_max;
  };
  if (inside(e)) return;
  // Zooming scales the points' coordinates about the window centre's (exactly for a parallel
  // projection, nearly for a perspective one: hence a few rounds).
  for (int round = 0; round < 4; ++round) {
    const double shrink = std::max((e.x_max - e.x_min) / (area.x_max - area.x_min),
                                   (e.y_max - e.y_min) / (area.y_max - area.y_min));
    if (shrink > 1.0) {
      if (camera->GetParallelProjection()) {
        camera->SetParallelScale(camera->GetParallelScale() * shrink * 1.005);
      } else {
        camera->Zoom(1.0 / (shrink * 1.005));
      }
      e = extent();
    }
    // The window centre shifts the image by exactly minus itself.
    double centre[2];
    camera->GetWindowCenter(centre);
    camera->SetWindowCenter(centre[0] + 0.5 * (e.x_min + e.x_max) - 0.5 * (area.x_min + area.x_max),
                            centre[1] + 0.5 * (e.y_min + e.y_max) - 0.5 * (area.y_min + area.y_max));
    e = extent();
    if (inside(e)) return;
  }
}

}  // namespace

void validate(const HeightField& field) {
  if (field.nx < 2 || field.ny < 2) {
    throw InputError("height field: nx " + std::to_string(field.nx) + ", ny " +
                     std::to_string(field.ny) + ": each must be >= 2");
  }
  if (!(field.spacing_x_m > 0.0) || !(field.spacing_y_m > 0.0) ||
      !std::isfinite(field.spacing_x_m) || !std::isfinite(field.spacing_y_m)) {
    throw InputError("height field: spacing_x_m " + format_double(field.spacing_x_m) +
                     ", spacing_y_m " + format_double(field.spacing_y_m) + ": each must be > 0");
  }
  if (!std::isfinite(field.origin_x_m) || !std::isfinite(field.origin_y_m)) {
    throw InputError("height field: the origin is not finite");
  }
  if (field.height_m.size() != field.node_count()) {
    throw InputError("height field: height_m has " + std::to_string(field.height_m.size()) +
                     " values, nx ny = " + std::to_string(field.node_count()));
  }
  if (!field.deviation_m.empty() && field.deviation_m.size() != field.node_count()) {
    throw InputError("height field: deviation_m has " + std::to_string(field.deviation_m.size()) +
                     " values, nx ny = " + std::to_string(field.node_count()) +
                     " (or none)");
  }
  for (const auto* values : {&field.height_m, &field.deviation_m}) {
    for (std::size_t k = 0; k < values->size(); ++k) {
      if (!std::isfinite((*values)[k])) {
        throw InputError(std::string("height field: ") +
                         (values == &field.height_m ? "height_m" : "deviation_m") + " at node " +
                         std::to_string(k) + " (i " + std::to_string(k % field.nx) + ", j " +
                         std::to_string(k / field.nx) + ") is not finite");
      }
    }
  }
}

// The labels of options.labels, placed without overlap (label_placement.hpp) in the image of
// `renderer` (its camera set, its window sized): text boxes and leader lines as 2-D actors.
// Returns the indices of the labels left out.
static std::vector<std::size_t> add_labels(vtkRenderer* renderer, const HeightField& field,
                                           const SurfaceRenderOptions& options, double right_share) {
  std::vector<std::size_t> left_out;
  if (options.labels.empty()) return left_out;
  const double width_px = options.size.width_px, height_px = options.size.height_px;
  // Left of the colour bar and below the title.
  const PixelBox area{0.0, 0.0, width_px * right_share, height_px * 0.9};
  constexpr int kFontPx = 13;
  std::vector<LabelRequest> requests;
  std::vector<std::size_t> requested;  // index into options.labels
  std::vector<std::array<double, 2>> anchors_px;
  for (std::size_t n = 0; n < options.labels.size(); ++n) {
    const SurfaceLabel& label = options.labels[n];
    const int i = std::clamp(static_cast<int>(std::lround((label.x_m - field.origin_x_m) / field.spacing_x_m)), 0,
                             field.nx - 1);
    const int j = std::clamp(static_cast<int>(std::lround((label.y_m - field.origin_y_m) / field.spacing_y_m)), 0,
                             field.ny - 1);
    renderer->SetWorldPoint(label.x_m, label.y_m, field.height_m[field.index(i, j)] * options.height_scale, 1.0);
    renderer->WorldToDisplay();
    double display[3];
    renderer->GetDisplayPoint(display);
    if (display[0] < area.x_min_px || display[0] > area.x_max_px || display[1] < area.y_min_px ||
        display[1] > area.y_max_px) {
      left_out.push_back(n);
      continue;
    }
    // About 0.62 em a bold digit, and a margin round the text.
    requests.push_back({display[0], display[1], 0.62 * kFontPx * static_cast<double>(label.text.size()) + 6.0,
                        kFontPx + 4.0});
    requested.push_back(n);
  }
  const std::vector<std::optional<PlacedLabel>> placed = place_labels(requests, area);
  auto points = vtkSmartPointer<vtkPoints>::New();
  auto lines = vtkSmartPointer<vtkCellArray>::New();
  for (std::size_t k = 0; k < requests.size(); ++k) {
    if (!placed[k]) {
      left_out.push_back(requested[k]);
      continue;
    }
    const LabelRequest& request = requests[k];
    const double x0 = placed[k]->x_px, y0 = placed[k]->y_px;
    auto text = vtkSmartPointer<vtkTextActor>::New();
    text->SetInput(options.labels[requested[k]].text.c_str());
    vtkTextProperty* property = text->GetTextProperty();
    property->SetFontSize(kFontPx);
    property->BoldOn();
    property->SetColor(0.0, 0.0, 0.0);
    property->SetBackgroundColor(1.0, 1.0, 1.0);
    property->SetBackgroundOpacity(0.85);
    property->SetFrame(1);
    property->SetFrameColor(0.0, 0.0, 0.0);
    detail::apply_font(property);
    property->SetJustificationToCentered();
    property->SetVerticalJustificationToCentered();
    text->SetDisplayPosition(static_cast<int>(std::lround(x0 + 0.5 * request.width_px)),
                             static_cast<int>(std::lround(y0 + 0.5 * request.height_px)));
    renderer->AddActor2D(text);
    // A leader line from the anchor to the nearest point of the box, when the box is away from it.
    const double near_x = std::clamp(request.anchor_x_px, x0, x0 + request.width_px);
    const double near_y = std::clamp(request.anchor_y_px, y0, y0 + request.height_px);
    if (std::hypot(near_x - request.anchor_x_px, near_y - request.anchor_y_px) > 6.0) {
      const vtkIdType a = points->InsertNextPoint(request.anchor_x_px, request.anchor_y_px, 0.0);
      const vtkIdType b = points->InsertNextPoint(near_x, near_y, 0.0);
      const vtkIdType ids[2] = {a, b};
      lines->InsertNextCell(2, ids);
    }
  }
  if (lines->GetNumberOfCells() > 0) {
    auto leaders = vtkSmartPointer<vtkPolyData>::New();
    leaders->SetPoints(points);
    leaders->SetLines(lines);
    auto mapper = vtkSmartPointer<vtkPolyDataMapper2D>::New();
    mapper->SetInputData(leaders);
    auto actor = vtkSmartPointer<vtkActor2D>::New();
    actor->SetMapper(mapper);
    actor->GetProperty()->SetColor(0.0, 0.0, 0.0);
    actor->GetProperty()->SetLineWidth(1.5);
    renderer->AddActor2D(actor);
  }
  std::sort(left_out.begin(), left_out.end());
  return left_out;
}

SurfaceRenderResult render_surface_png(const std::string& png_path, const HeightField& field,
                                       const SurfaceRenderOptions& options) {
  validate(field);
  check_options(field, options);

  // The nodes in view decide the default colour range.
  // The bounds in view (display coordinates: z scaled), for the camera and the outlines' lift.
  double bounds[6];
  {
    double x0 = field.origin_x_m, x1 = field.origin_x_m + (field.nx - 1) * field.spacing_x_m;
    double y0 = field.origin_y_m, y1 = field.origin_y_m + (field.ny - 1) * field.spacing_y_m;
    if (options.camera == CameraPreset::close_up) {
      const BoxXY& box = *options.close_up_box;
      x0 = std::max(x0, box.x_min_m);
      x1 = std::min(x1, box.x_max_m);
      y0 = std::max(y0, box.y_min_m);
      y1 = std::min(y1, box.y_max_m);
    }
    double z0 = std::numeric_limits<double>::infinity(), z1 = -z0;
    for (int j = 0; j < field.ny; ++j) {
      for (int i = 0; i < field.nx; ++i) {
        const double x = field.origin_x_m + i * field.spacing_x_m;
        const double y = field.origin_y_m + j * field.spacing_y_m;
        if (x < x0 || x > x1 || y < y0 || y > y1) continue;
        z0 = std::min(z0, field.height_m[field.index(i, j)] * options.height_scale);
        z1 = std::max(z1, field.height_m[field.index(i, j)] * options.height_scale);
      }
    }
    bounds[0] = x0, bounds[1] = x1, bounds[2] = y0, bounds[3] = y1, bounds[4] = z0, bounds[5] = z1;
  }
  const bool by_deviation = !field.deviation_m.empty();
  const std::vector<double>& colour_m = by_deviation ? field.deviation_m : field.height_m;
  double low = std::numeric_limits<double>::infinity(), high = -low;
  for (int j = 0; j < field.ny; ++j) {
    for (int i = 0; i < field.nx; ++i) {
      const double x = field.origin_x_m + i * field.spacing_x_m;
      const double y = field.origin_y_m + j * field.spacing_y_m;
      if (options.camera == CameraPreset::close_up && !in_box(*options.close_up_box, x, y)) {
        continue;
      }
      low = std::min(low, colour_m[field.index(i, j)]);
      high = std::max(high, colour_m[field.index(i, j)]);
    }
  }
  if (!(low <= high)) {
    throw InputError("surface render: close_up_box holds no node of the grid");
  }
  Range range_m;
  if (options.colour_range_m) {
    range_m = *options.colour_range_m;
  } else if (by_deviation) {
    const double half = std::max({std::abs(low), std::abs(high), 1e-9});
    range_m = {-half, half};
  } else {
    range_m = low < high ? Range{low, high} : Range{low - 1e-6, high + 1e-6};
  }

  require_display();

  // Heights in mm, or in um when their colour range is under 0.1 mm (machined marks).
  const bool in_um = by_deviation || range_m.max - range_m.min < 1e-4;
  const double display_factor = in_um ? kUmPerM : kMmPerM;
  auto surface = grid_polydata(field, options.height_scale);
  surface->GetPointData()->SetScalars(point_array("colour", colour_m, display_factor));
  auto normals = vtkSmartPointer<vtkPolyDataNormals>::New();
  normals->SetInputData(surface);
  normals->SplittingOff();
  normals->ConsistencyOn();

  const double display_low = range_m.min * display_factor;
  const double display_high = range_m.max * display_factor;
  auto map = by_deviation && !options.colour_range_m
                 ? diverging_map(display_high)
                 : (by_deviation ? diverging_map(std::max(std::abs(display_low),
                                                          std::abs(display_high)))
                                 : sequential_map(display_low, display_high));
  if (by_deviation && options.colour_range_m) {
    // A given range that is not symmetric: the map stays centred on zero, clipped to the range.
    map->SetClamping(true);
  }
  auto mapper = vtkSmartPointer<vtkPolyDataMapper>::New();
  mapper->SetInputConnection(normals->GetOutputPort());
  mapper->SetLookupTable(map);
  mapper->SetScalarRange(display_low, display_high);
  mapper->SetScalarModeToUsePointData();
  mapper->InterpolateScalarsBeforeMappingOn();
  // Push the surface back a little so that the outlines on it are drawn in front.
  mapper->SetRelativeCoincidentTopologyPolygonOffsetParameters(2.0, 2.0);
  auto actor = vtkSmartPointer<vtkActor>::New();
  actor->SetMapper(mapper);
  // Much ambient light: the colour carries the deviation, the shading only the shape.
  actor->GetProperty()->SetAmbient(0.4);
  actor->GetProperty()->SetDiffuse(0.6);
  actor->GetProperty()->SetSpecular(0.1);

  auto renderer = vtkSmartPointer<vtkRenderer>::New();
  renderer->SetBackground(1.0, 1.0, 1.0);
  renderer->AddActor(actor);

  // Outlines are lifted above the surface by a small part of the view's size, so that the
  // surface does not hide them where it slopes (depth offsets alone did not suffice).
  const double lift = 2e-3 * std::hypot(bounds[1] - bounds[0], bounds[3] - bounds[2],
                                        bounds[5] - bounds[4]);
  auto add_lines = [&](vtkPolyData* data) {
    auto line_mapper = vtkSmartPointer<vtkPolyDataMapper>::New();
    line_mapper->SetInputData(data);
    line_mapper->ScalarVisibilityOff();
    auto line_actor = vtkSmartPointer<vtkActor>::New();
    line_actor->SetMapper(line_mapper);
    line_actor->GetProperty()->SetColor(options.outline_colour.r, options.outline_colour.g,
                                        options.outline_colour.b);
    line_actor->GetProperty()->SetLineWidth(static_cast<float>(options.outline_width_px));
    line_actor->GetProperty()->LightingOff();
    renderer->AddActor(line_actor);
  };
  if (!options.region_mask.empty()) {
    add_lines(mask_outline(field, options.region_mask, options.height_scale, lift));
  }
  if (!options.outlines.empty()) {
    add_lines(draped_outlines(field, options.outlines, options.height_scale, lift));
  }

  // The colour bar's frame: from bar_left to bar_left + kBarWidth of the image's width.
  constexpr double kBarWidth = 0.11;
  double bar_left = 0.83;
  if (options.colour_bar) {
    auto bar = vtkSmartPointer<vtkScalarBarActor>::New();
    bar->SetLookupTable(map);
    const char* bar_title = by_deviation ? "deviation [um]" : (in_um ? "height [um]" : "height [mm]");
    bar->SetTitle(bar_title);
    bar->SetNumberOfLabels(5);
    bar->SetLabelFormat("%-#6.3g");
    bar->SetUnconstrainedFontSize(true);
    bar->DrawBackgroundOn();  // the surface may run behind the bar (close-ups)
    bar->GetBackgroundProperty()->SetColor(1.0, 1.0, 1.0);
    bar->SetHeight(0.72);
    for (vtkTextProperty* text : {bar->GetTitleTextProperty(), bar->GetLabelTextProperty()}) {
      text->SetColor(0.0, 0.0, 0.0);
      text->ShadowOff();
      text->ItalicOff();
      text->SetFontSize(15);
      text->BoldOff();
    }
    bar->GetTitleTextProperty()->BoldOn();
    detail::apply_font(bar->GetTitleTextProperty());
    detail::apply_font(bar->GetLabelTextProperty());
    // vtkScalarBarActor centres its title over the frame at its natural size (unconstrained
    // font): in a narrow image (the marks' 480 px thumbnails) it ran past the right edge. The
    // frame moves left as far as the title needs.
    const double title_width_px = text_width_px(bar->GetTitleTextProperty(), bar_title);
    const double width_px = options.size.width_px;
    const double centre_px = std::min((bar_left + 0.5 * kBarWidth) * width_px, width_px - 6.0 - 0.5 * title_width_px);
    bar_left = centre_px / width_px - 0.5 * kBarWidth;
    bar->GetPositionCoordinate()->SetCoordinateSystemToNormalizedViewport();
    bar->GetPositionCoordinate()->SetValue(bar_left, 0.12);
    bar->SetWidth(kBarWidth);
    renderer->AddActor2D(bar);
  }
  if (!options.title.empty()) {
    auto title = vtkSmartPointer<vtkTextActor>::New();
    title->SetInput(options.title.c_str());
    title->GetTextProperty()->SetFontSize(20);
    title->GetTextProperty()->BoldOn();
    title->GetTextProperty()->SetColor(0.0, 0.0, 0.0);
    detail::apply_font(title->GetTextProperty());
    title->GetTextProperty()->SetJustificationToCentered();
    title->GetTextProperty()->SetVerticalJustificationToTop();
    title->GetPositionCoordinate()->SetCoordinateSystemToNormalizedViewport();
    title->GetPositionCoordinate()->SetValue(0.5, 0.97);
    renderer->AddActor2D(title);
  }

  // Camera: the preset's direction towards the centre of the bounds in view.
  const double centre[3] = {0.5 * (bounds[0] + bounds[1]), 0.5 * (bounds[2] + bounds[3]),
                            0.5 * (bounds[4] + bounds[5])};
  vtkCamera* camera = renderer->GetActiveCamera();
  camera->SetFocalPoint(centre);
  if (options.camera == CameraPreset::top) {
    camera->SetPosition(centre[0], centre[1], centre[2] + 1.0);
    camera->SetViewUp(0.0, 1.0, 0.0);
    camera->ParallelProjectionOn();
  } else {
    const double azimuth = radians(options.view_azimuth_deg);
    const double elevation = radians(options.view_elevation_deg);
    camera->SetPosition(centre[0] + std::sin(azimuth) * std::cos(elevation),
                        centre[1] - std::cos(azimuth) * std::cos(elevation),
                        centre[2] + std::sin(elevation));
    camera->SetViewUp(0.0, 0.0, 1.0);
  }
  renderer->ResetCamera(bounds);
  // ResetCamera fits the bounding sphere of the box, which leaves a wide margin around it.
  camera->Zoom((options.colour_bar ? 1.0 : 1.15) *
               (options.camera == CameraPreset::close_up ? 1.3 : 1.0));
  // Centre the surface in the part of the image left of the colour bar (window centre in
  // normalised view coordinates [-1, 1]: a positive x moves the scene to the left).
  if (options.colour_bar) camera->SetWindowCenter(0.16, 0.0);
  if (options.camera != CameraPreset::close_up) {
    // The surface wholly in the image, below the title and left of the colour bar.
    const NormalizedArea free_area{-0.97, (options.colour_bar ? 2.0 * bar_left - 1.0 - 0.04 : 0.97), -0.97,
                                   options.title.empty() ? 0.97 : 0.76};
    fit_into_area(camera, surface->GetPoints(),
                  static_cast<double>(options.size.width_px) / options.size.height_px, free_area);
  }
  renderer->ResetCameraClippingRange();

  auto window = vtkSmartPointer<vtkRenderWindow>::New();
  window->SetOffScreenRendering(1);
  window->SetSize(options.size.width_px, options.size.height_px);
  window->AddRenderer(renderer);
  SurfaceRenderResult result;
  result.labels_left_out = add_labels(renderer, field, options, options.colour_bar ? std::min(0.8, bar_left - 0.03) : 1.0);
  detail::write_window_png(window, png_path);
  return result;
}

void write_surface_vtp(const std::string& vtp_path, const HeightField& field) {
  validate(field);
  auto surface = grid_polydata(field, 1.0);
  surface->GetPointData()->AddArray(point_array("height_m", field.height_m, 1.0));
  if (!field.deviation_m.empty()) {
    surface->GetPointData()->AddArray(point_array("deviation_m", field.deviation_m, 1.0));
  }
  auto writer = vtkSmartPointer<vtkXMLPolyDataWriter>::New();
  writer->SetInputData(surface);
  writer->SetDataModeToAppended();
  writer->EncodeAppendedDataOff();
  writer->SetCompressorTypeToZLib();
  writer->WriteToOutputStringOn();
  if (writer->Write() != 1) throw InputError(vtp_path + ": the VTK XML writer failed");
  write_file_atomically(vtp_path, writer->GetOutputString());
}

void write_surface_stl(const std::string& stl_path, const HeightField& field) {
  validate(field);
  const std::size_t triangle_count =
      2 * static_cast<std::size_t>(field.nx - 1) * static_cast<std::size_t>(field.ny - 1);
  if (triangle_count > std::numeric_limits<std::uint32_t>::max()) {
    throw InputError(stl_path + ": " + std::to_string(triangle_count) +
                     " triangles are more than binary STL can hold");
  }
  std::string bytes;
  bytes.reserve(84 + 50 * triangle_count);
  std::string header = "vmsim height field, mm";
  header.resize(80, ' ');
  bytes += header;
  auto put = [&bytes](const void* data, std::size_t size) {
    bytes.append(static_cast<const char*>(data), size);
  };
  const auto count = static_cast<std::uint32_t>(triangle_count);
  put(&count, 4);  // STL is little-endian, as is every machine Debian's amd64/arm64 runs on
  auto node = [&field](int i, int j) {
    return std::array<double, 3>{(field.origin_x_m + i * field.spacing_x_m) * kMmPerM,
                                 (field.origin_y_m + j * field.spacing_y_m) * kMmPerM,
                                 field.height_m[field.index(i, j)] * kMmPerM};
  };
  auto triangle = [&put](const std::array<double, 3>& a, const std::array<double, 3>& b,
                         const std::array<double, 3>& c) {
    const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const double v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
    const double length = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    float values[12];
    for (int k = 0; k < 3; ++k) {
      values[k] = static_cast<float>(length > 0.0 ? n[k] / length : 0.0);
      values[3 + k] = static_cast<float>(a[static_cast<std::size_t>(k)]);
      values[6 + k] = static_cast<float>(b[static_cast<std::size_t>(k)]);
      values[9 + k] = static_cast<float>(c[static_cast<std::size_t>(k)]);
    }
    put(values, sizeof values);
    const std::uint16_t attributes = 0;
    put(&attributes, 2);
  };
  for (int j = 0; j + 1 < field.ny; ++j) {
    for (int i = 0; i + 1 < field.nx; ++i) {
      triangle(node(i, j), node(i + 1, j), node(i + 1, j + 1));
      triangle(node(i, j), node(i + 1, j + 1), node(i, j + 1));
    }
  }
  write_file_atomically(stl_path, bytes);
}

}  // namespace vmsim::viz
