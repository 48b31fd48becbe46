#include "vmsim/removal/marks_stream.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "mark_geometry.hpp"

namespace vmsim::removal {

// --- SparseMarkLabels ---

std::size_t SparseMarkLabels::tile_of(int iu, int iv) const {
  const std::size_t tiles_u = static_cast<std::size_t>((nu_ + kTile - 1) / kTile);
  return static_cast<std::size_t>(iu / kTile) + tiles_u * static_cast<std::size_t>(iv / kTile);
}

int SparseMarkLabels::at(int iu, int iv) const {
  const auto found = tiles_.find(tile_of(iu, iv));
  if (found == tiles_.end()) return -1;
  return found->second[static_cast<std::size_t>(iu % kTile + kTile * (iv % kTile))];
}

void SparseMarkLabels::set(int iu, int iv, int label) {
  std::vector<int>& tile = tiles_[tile_of(iu, iv)];
  if (tile.empty()) tile.assign(kTile * kTile, -1);
  tile[static_cast<std::size_t>(iu % kTile + kTile * (iv % kTile))] = label;
}

void SparseMarkLabels::relabel(const std::vector<int>& new_label) {
  for (auto& [tile, labels] : tiles_) {
    for (int& label : labels) {
      if (label >= 0) label = new_label[static_cast<std::size_t>(label)];
    }
  }
}

// --- MarkRegionFinder ---

MarkRegionFinder::MarkRegionFinder(int nu, int nv, const MarkOptions& options)
    : nu_(nu), nv_(nv), options_(options), previous_row_label_(static_cast<std::size_t>(std::max(nu, 0)), -1) {}

int MarkRegionFinder::sign_of(double deviation_m) const {
  if (deviation_m < -options_.threshold_m) return -1;
  if (deviation_m > options_.threshold_m) return 1;
  return 0;
}

int MarkRegionFinder::root_of(int id) {
  while (open_[static_cast<std::size_t>(id)].parent != id) {
    Open& region = open_[static_cast<std::size_t>(id)];
    region.parent = open_[static_cast<std::size_t>(region.parent)].parent;  // path halving
    id = region.parent;
  }
  return id;
}

int MarkRegionFinder::join(int a, int b) {
  const int root_a = root_of(a), root_b = root_of(b);
  if (root_a == root_b) return root_a;
  Open& kept = open_[static_cast<std::size_t>(root_a)];
  const Open& merged = open_[static_cast<std::size_t>(root_b)];
  kept.line_count += merged.line_count;
  kept.first_line = std::min(kept.first_line, merged.first_line);
  open_[static_cast<std::size_t>(root_b)].parent = root_a;
  return root_a;
}

void MarkRegionFinder::keep(const Open& region) {
  if (region.line_count < options_.min_lines) return;
  kept_.push_back({region.first_line, region.sign, region.line_count});
}

void MarkRegionFinder::add_row(std::span<const double> deviation_m) {
  if (deviation_m.size() != static_cast<std::size_t>(nu_) || rows_seen_ >= nv_) {
    throw std::invalid_argument("MarkRegionFinder: row " + std::to_string(rows_seen_) + " of " +
                                std::to_string(deviation_m.size()) + " deviations on a grid of " +
                                std::to_string(nu_) + " x " + std::to_string(nv_) + " lines");
  }
  const std::size_t row_start = static_cast<std::size_t>(nu_) * static_cast<std::size_t>(rows_seen_);
  std::vector<int> row_label(static_cast<std::size_t>(nu_), -1);
  for (int iu = 0; iu < nu_; ++iu) {
    const int sign = sign_of(deviation_m[static_cast<std::size_t>(iu)]);
    if (sign == 0) continue;
    int id = -1;
    const int left = iu > 0 ? row_label[static_cast<std::size_t>(iu - 1)] : -1;
    if (left >= 0 && open_[static_cast<std::size_t>(root_of(left))].sign == sign) id = root_of(left);
    const int up = previous_row_label_[static_cast<std::size_t>(iu)];
    if (up >= 0 && open_[static_cast<std::size_t>(root_of(up))].sign == sign) id = id < 0 ? root_of(up) : join(id, up);
    if (id < 0) {
      id = static_cast<int>(open_.size());
      open_.push_back({id, sign, row_start + static_cast<std::size_t>(iu), 0});
    }
    ++open_[static_cast<std::size_t>(id)].line_count;
    row_label[static_cast<std::size_t>(iu)] = id;
  }
  close_regions_left_behind(row_label);
  ++rows_seen_;
}

// Regions not on the new row are complete: kept or dropped. The open ones are renumbered
// 0, 1, ... so that the union-find never holds more than two rows' labels.
void MarkRegionFinder::close_regions_left_behind(const std::vector<int>& row_label) {
  std::vector<int> new_id(open_.size(), -1);
  std::vector<Open> still_open;
  for (std::size_t iu = 0; iu < row_label.size(); ++iu) {
    if (row_label[iu] < 0) {
      previous_row_label_[iu] = -1;
      continue;
    }
    const int root = root_of(row_label[iu]);
    if (new_id[static_cast<std::size_t>(root)] < 0) {
      new_id[static_cast<std::size_t>(root)] = static_cast<int>(still_open.size());
      still_open.push_back(open_[static_cast<std::size_t>(root)]);
      still_open.back().parent = new_id[static_cast<std::size_t>(root)];
    }
    previous_row_label_[iu] = new_id[static_cast<std::size_t>(root)];
  }
  for (std::size_t id = 0; id < open_.size(); ++id) {
    if (open_[id].parent == static_cast<int>(id) && new_id[id] < 0) keep(open_[id]);
  }
  open_ = std::move(still_open);
}

std::vector<MarkRegion> MarkRegionFinder::regions() const {
  if (rows_seen_ != nv_) {
    throw std::logic_error("MarkRegionFinder: " + std::to_string(rows_seen_) + " of " + std::to_string(nv_) +
                           " rows given");
  }
  std::vector<MarkRegion> all = kept_;
  for (const Open& region : open_) {
    if (region.line_count >= options_.min_lines) all.push_back({region.first_line, region.sign, region.line_count});
  }
  std::sort(all.begin(), all.end(), [](const MarkRegion& a, const MarkRegion& b) { return a.first_line < b.first_line; });
  return all;
}

// --- find_marks_streamed ---

namespace {

struct Pending {
  int iu = 0, iv = 0;
  double deviation_m = 0.0;
};

// The region's flood fill exactly as find_marks does it (depth-first from the region's first
// line, neighbours -u, +u, -v, +v), summing in the same order: the same sums bit for bit.
Mark fill_mark(const NBuffer& production, const DeviationReader& deviation, const MarkRegionFinder& finder,
               const MarkRegion& region, int index, SparseMarkLabels& labels) {
  const int nu = production.nu(), nv = production.nv();
  Mark mark;
  mark.kind = region.sign < 0 ? MarkKind::gouge : MarkKind::excess;
  mark.iu_min = nu;
  mark.iv_min = nv;
  mark.iu_max = -1;
  mark.iv_max = -1;
  Eigen::Vector3d weighted = Eigen::Vector3d::Zero();
  const int seed_iu = static_cast<int>(region.first_line % static_cast<std::size_t>(nu));
  const int seed_iv = static_cast<int>(region.first_line / static_cast<std::size_t>(nu));
  std::vector<Pending> stack{{seed_iu, seed_iv, deviation.at(seed_iu, seed_iv)}};
  labels.set(seed_iu, seed_iv, index);
  while (!stack.empty()) {
    const Pending line = stack.back();
    stack.pop_back();
    ++mark.line_count;
    const double area = detail::line_area_m2(production, line.iu, line.iv);
    const Eigen::Vector3d point = production.surface_point(line.iu, line.iv);
    mark.area_m2 += area;
    weighted += area * point;
    if (std::abs(line.deviation_m) > mark.depth_m) {
      mark.depth_m = std::abs(line.deviation_m);
      mark.deepest_point_W_m = point;
    }
    mark.iu_min = std::min(mark.iu_min, line.iu);
    mark.iu_max = std::max(mark.iu_max, line.iu);
    mark.iv_min = std::min(mark.iv_min, line.iv);
    mark.iv_max = std::max(mark.iv_max, line.iv);
    const int neighbours[4][2] = {{line.iu - 1, line.iv}, {line.iu + 1, line.iv}, {line.iu, line.iv - 1}, {line.iu, line.iv + 1}};
    for (const auto& n : neighbours) {
      if (n[0] < 0 || n[0] >= nu || n[1] < 0 || n[1] >= nv || labels.at(n[0], n[1]) >= 0) continue;
      const double d = deviation.at(n[0], n[1]);
      if (finder.sign_of(d) != region.sign) continue;
      labels.set(n[0], n[1], index);
      stack.push_back({n[0], n[1], d});
    }
  }
  if (mark.line_count != region.line_count) {
    throw std::logic_error("find_marks_streamed: the flood fill found " + std::to_string(mark.line_count) +
                           " lines, the row pass " + std::to_string(region.line_count) +
                           " (DeviationReader::at and ::row disagree?)");
  }
  mark.centroid_W_m = mark.area_m2 > 0.0 ? Eigen::Vector3d(weighted / mark.area_m2) : mark.deepest_point_W_m;
  return mark;
}

}  // namespace

StreamedMarkMap find_marks_streamed(const NBuffer& production, const DeviationReader& deviation,
                                    const MarkOptions& options) {
  const int nu = production.nu(), nv = production.nv();
  MarkRegionFinder finder(nu, nv, options);
  std::vector<double> row_m(static_cast<std::size_t>(nu));
  for (int iv = 0; iv < nv; ++iv) {
    deviation.row(iv, row_m);
    finder.add_row(row_m);
  }
  StreamedMarkMap result;
  result.labels = SparseMarkLabels(nu, nv);
  for (const MarkRegion& region : finder.regions()) {
    result.marks.push_back(
        fill_mark(production, deviation, finder, region, static_cast<int>(result.marks.size()), result.labels));
  }
  // Deepest first, ties in the order found (as find_marks); labels follow the new order.
  const std::vector<int> new_index = detail::sort_deepest_first(result.marks);
  result.labels.relabel(new_index);
  return result;
}

}  // namespace vmsim::removal
