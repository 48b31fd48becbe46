#pragma once
// Where to put the numbered labels of marks in an image so that no two overlap (issue 22: the
// labels of nearby marks were drawn on top of each other). Pure geometry in image pixels: no
// VTK, no display, so that it is tested on its own.
#include <optional>
#include <vector>

namespace vmsim::viz {

/// A label to place: the point it names (its anchor) and the size of its text box [px].
struct LabelRequest {
  double anchor_x_px = 0.0;  ///< image x, to the right
  double anchor_y_px = 0.0;  ///< image y, up (VTK's display coordinates)
  double width_px = 0.0;     ///< > 0
  double height_px = 0.0;    ///< > 0
};

/// A placed label: its box's lower-left corner [px]. A box away from its anchor is drawn with a
/// leader line from the anchor to the box.
struct PlacedLabel {
  double x_px = 0.0;
  double y_px = 0.0;
};

/// A box in image pixels [px] (min < max), e.g. the part of the image the labels may use.
struct PixelBox {
  double x_min_px = 0.0;
  double y_min_px = 0.0;
  double x_max_px = 0.0;
  double y_max_px = 0.0;
};

/// Greedy placement in the order given (put the most important label first): each label goes
/// to the first position, on rings of growing distance around its anchor (the box's corner
/// next to the anchor first, then the positions on rings of `ring_step_px` out to
/// `max_distance_px`), where its box stays inside `area`, keeps `gap_px` from every label placed
/// before, and does not hide an anchor of the labels placed before. A label with no such
/// position is dropped (nullopt): the caller lists it elsewhere (a caption).
/// The result has one entry per request, in the same order.
std::vector<std::optional<PlacedLabel>> place_labels(const std::vector<LabelRequest>& requests,
                                                     const PixelBox& area, double max_distance_px = 80.0,
                                                     double ring_step_px = 8.0, double gap_px = 2.0);

}  // namespace vmsim::viz
