// Label placement (viz/label_placement.hpp) checked by its laws, with a pairwise overlap test
// written here apart from the placement's own: no two placed boxes overlap, every box stays in
// the area and near its anchor, no box hides another label's anchor, a label with room keeps
// its usual spot, and a crowd of labels at one point is spread out (or dropped) rather than
// stacked.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "vmsim/viz/label_placement.hpp"

namespace vmsim {
namespace {

struct Box {
  double x0, y0, x1, y1;
};

bool boxes_overlap(const Box& a, const Box& b) {
  return std::max(a.x0, b.x0) < std::min(a.x1, b.x1) && std::max(a.y0, b.y0) < std::min(a.y1, b.y1);
}

// Distance from a point to a box (0 inside).
double distance_to_box(const Box& box, double x, double y) {
  const double dx = std::max({box.x0 - x, 0.0, x - box.x1});
  const double dy = std::max({box.y0 - y, 0.0, y - box.y1});
  return std::hypot(dx, dy);
}

void check_laws(const std::vector<viz::LabelRequest>& requests, const viz::PixelBox& area,
                const std::vector<std::optional<viz::PlacedLabel>>& placed, double max_distance_px) {
  ASSERT_EQ(placed.size(), requests.size());
  std::vector<Box> boxes;
  std::vector<std::size_t> owner;
  for (std::size_t n = 0; n < placed.size(); ++n) {
    if (!placed[n]) continue;
    const Box box{placed[n]->x_px, placed[n]->y_px, placed[n]->x_px + requests[n].width_px,
                  placed[n]->y_px + requests[n].height_px};
    EXPECT_GE(box.x0, area.x_min_px) << n;
    EXPECT_LE(box.x1, area.x_max_px) << n;
    EXPECT_GE(box.y0, area.y_min_px) << n;
    EXPECT_LE(box.y1, area.y_max_px) << n;
    // Near: the box's nearest point within the largest ring (plus the box's own half-diagonal).
    EXPECT_LE(distance_to_box(box, requests[n].anchor_x_px, requests[n].anchor_y_px),
              max_distance_px + 8.0)
        << n;
    boxes.push_back(box);
    owner.push_back(n);
  }
  for (std::size_t a = 0; a < boxes.size(); ++a) {
    for (std::size_t b = a + 1; b < boxes.size(); ++b) {
      EXPECT_FALSE(boxes_overlap(boxes[a], boxes[b])) << "labels " << owner[a] << " and " << owner[b];
    }
    for (std::size_t k = 0; k < requests.size(); ++k) {
      if (k == owner[a]) continue;
      const double x = requests[k].anchor_x_px, y = requests[k].anchor_y_px;
      EXPECT_FALSE(x > boxes[a].x0 && x < boxes[a].x1 && y > boxes[a].y0 && y < boxes[a].y1)
          << "label " << owner[a] << " hides the anchor of " << k;
    }
  }
}

const viz::PixelBox kArea{0, 0, 800, 600};

TEST(LabelPlacement, ALonelyLabelSitsAboveRightOfItsAnchor) {
  const std::vector<viz::LabelRequest> requests{{400, 300, 20, 14}};
  const auto placed = viz::place_labels(requests, kArea);
  ASSERT_TRUE(placed[0]);
  EXPECT_DOUBLE_EQ(placed[0]->x_px, 404.0);
  EXPECT_DOUBLE_EQ(placed[0]->y_px, 302.0);
}

TEST(LabelPlacement, LabelsAtOnePointAreSpreadNotStacked) {
  // Ten marks whose anchors are within 3 px of each other (nearby marks on an edge-on wall).
  std::vector<viz::LabelRequest> requests;
  for (int n = 0; n < 10; ++n) requests.push_back({400.0 + 0.3 * n, 300.0, 20, 14});
  const auto placed = viz::place_labels(requests, kArea);
  check_laws(requests, kArea, placed, 80.0);
  int kept = 0;
  for (const auto& label : placed) kept += label ? 1 : 0;
  EXPECT_EQ(kept, 10);  // room enough around the point for all of them
}

TEST(LabelPlacement, LabelsAtTheBorderStayInside) {
  std::vector<viz::LabelRequest> requests{{795, 595, 30, 14}, {2, 2, 30, 14}, {795, 3, 30, 14}};
  const auto placed = viz::place_labels(requests, kArea);
  for (const auto& label : placed) EXPECT_TRUE(label);
  check_laws(requests, kArea, placed, 80.0);
}

TEST(LabelPlacement, WithoutRoomLabelsAreDroppedNotOverlapped) {
  // A small area: not all 40 labels fit; those placed must still obey the laws.
  const viz::PixelBox area{0, 0, 120, 60};
  std::vector<viz::LabelRequest> requests;
  for (int n = 0; n < 40; ++n) requests.push_back({60.0, 30.0, 24, 14});
  const auto placed = viz::place_labels(requests, area);
  check_laws(requests, area, placed, 80.0);
  EXPECT_TRUE(placed[0]);   // the first (most important) label always finds its spot
  EXPECT_FALSE(placed[39]); // 40 boxes of 24 x 14 px cannot fit in 120 x 60 px
}

TEST(LabelPlacement, RandomCrowdsObeyTheLaws) {
  std::mt19937 random(22);
  std::uniform_real_distribution<double> x(0, 800), y(0, 600), cluster(-15, 15);
  for (int trial = 0; trial < 50; ++trial) {
    std::vector<viz::LabelRequest> requests;
    const double cx = x(random), cy = y(random);
    for (int n = 0; n < 30; ++n) requests.push_back({cx + cluster(random), cy + cluster(random), 22, 14});
    check_laws(requests, kArea, viz::place_labels(requests, kArea), 80.0);
  }
}

}  // namespace
}  // namespace vmsim
