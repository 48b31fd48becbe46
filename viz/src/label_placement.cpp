// Greedy label placement (label_placement.hpp): candidates on rings around the anchor.
#include "vmsim/viz/label_placement.hpp"

#include <cmath>
#include <numbers>

namespace vmsim::viz {
namespace {

bool overlap(const PixelBox& a, const PixelBox& b, double gap_px) {
  return a.x_min_px < b.x_max_px + gap_px && b.x_min_px < a.x_max_px + gap_px &&
         a.y_min_px < b.y_max_px + gap_px && b.y_min_px < a.y_max_px + gap_px;
}

bool holds(const PixelBox& box, double x_px, double y_px) {
  return x_px >= box.x_min_px && x_px <= box.x_max_px && y_px >= box.y_min_px && y_px <= box.y_max_px;
}

}  // namespace

std::vector<std::optional<PlacedLabel>> place_labels(const std::vector<LabelRequest>& requests,
                                                     const PixelBox& area, double max_distance_px,
                                                     double ring_step_px, double gap_px) {
  std::vector<std::optional<PlacedLabel>> placed(requests.size());
  std::vector<PixelBox> taken;
  // Every anchor is kept visible: a label box must not cover another label's anchor point.
  auto fits = [&](const PixelBox& box, std::size_t self) {
    if (box.x_min_px < area.x_min_px || box.x_max_px > area.x_max_px || box.y_min_px < area.y_min_px ||
        box.y_max_px > area.y_max_px) {
      return false;
    }
    for (const PixelBox& other : taken) {
      if (overlap(box, other, gap_px)) return false;
    }
    for (std::size_t k = 0; k < requests.size(); ++k) {
      if (k != self && holds(box, requests[k].anchor_x_px, requests[k].anchor_y_px)) return false;
    }
    return true;
  };
  for (std::size_t n = 0; n < requests.size(); ++n) {
    const LabelRequest& label = requests[n];
    const double w = label.width_px, h = label.height_px;
    // The box's centre at distance r from the anchor in direction a; r = 0 is the usual spot:
    // above and to the right of the anchor, its lower-left corner a few pixels off.
    std::optional<PixelBox> chosen;
    const double first_x = label.anchor_x_px + 4.0, first_y = label.anchor_y_px + 2.0;
    const PixelBox usual{first_x, first_y, first_x + w, first_y + h};
    if (fits(usual, n)) chosen = usual;
    for (double r = ring_step_px; !chosen && r <= max_distance_px + 1e-9; r += ring_step_px) {
      // Around the box's half-size plus r, 16 directions from up-right anticlockwise.
      for (int d = 0; d < 16 && !chosen; ++d) {
        const double a = std::numbers::pi / 4 + d * std::numbers::pi / 8;
        const double cx = label.anchor_x_px + std::cos(a) * (0.5 * w + r);
        const double cy = label.anchor_y_px + std::sin(a) * (0.5 * h + r);
        const PixelBox box{cx - 0.5 * w, cy - 0.5 * h, cx + 0.5 * w, cy + 0.5 * h};
        if (fits(box, n)) chosen = box;
      }
    }
    if (!chosen) continue;
    taken.push_back(*chosen);
    placed[n] = PlacedLabel{chosen->x_min_px, chosen->y_min_px};
  }
  return placed;
}

}  // namespace vmsim::viz
