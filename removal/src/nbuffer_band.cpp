// Bands of an N-buffer: a range of tile rows held by one process (nbuffer.hpp, "Bands").
#include <algorithm>
#include <stdexcept>
#include <string>
#include <utility>

#include "vmsim/removal/nbuffer.hpp"

namespace vmsim::removal {
namespace {
constexpr std::size_t kTileLines = NBuffer::kTile * NBuffer::kTile;
constexpr std::size_t kBoundsDoubles = 7;  // lo (3), hi (3), h_max

// Throws unless tile rows [begin, end) lie within the rows held [held.first, held.second) (and
// are not empty, unless `empty_ok`); `what` names the caller.
void check_rows_held(const char* what, int begin, int end, std::pair<int, int> held, bool empty_ok) {
  if ((empty_ok ? begin <= end : begin < end) && begin >= held.first && end <= held.second) return;
  throw std::invalid_argument(std::string(what) + ": tile rows [" + std::to_string(begin) + ", " +
                              std::to_string(end) + ") are not within the rows held [" +
                              std::to_string(held.first) + ", " + std::to_string(held.second) + ")");
}
}  // namespace

NBuffer NBuffer::band(int tile_row_begin, int tile_row_end) const {
  check_rows_held("NBuffer::band", tile_row_begin, tile_row_end, band_tile_rows(), false);
  const std::size_t tiles_u = static_cast<std::size_t>(tiles_u_);
  const std::size_t begin = static_cast<std::size_t>(tile_row_begin) * tiles_u;
  const std::size_t end = static_cast<std::size_t>(tile_row_end) * tiles_u;
  NBuffer out;
  out.zmap_ = zmap_;
  out.nu_ = nu_, out.nv_ = nv_, out.tiles_u_ = tiles_u_, out.tiles_v_ = tiles_v_;
  out.spacing_ = spacing_;
  out.origin0_ = origin0_;
  out.compact_ = compact_;
  out.o_ = o_, out.u_ = u_;
  out.tiles_ = tiles_;
  out.band_tile_begin_ = begin, out.band_tile_end_ = end;
  if (compact_) {
    out.base_ = base_;
    out.offsets_.reset(offsets_.size());
    for (std::size_t t = begin; t < end; ++t) out.offsets_.assign(t, offsets_.block(t));
  } else {
    const auto first = h_.begin() + static_cast<std::ptrdiff_t>((begin - band_tile_begin_) * kTileLines);
    out.h_.assign(first, first + static_cast<std::ptrdiff_t>((end - begin) * kTileLines));
  }
  return out;
}

std::vector<double> NBuffer::pack_band() const {
  const auto [held_begin, held_end] = band_tile_rows();
  return pack_rows(held_begin, held_end);
}

std::vector<double> NBuffer::pack_rows(int tile_row_begin, int tile_row_end) const {
  check_rows_held("NBuffer::pack_rows", tile_row_begin, tile_row_end, band_tile_rows(), true);
  const std::size_t tiles_u = static_cast<std::size_t>(tiles_u_);
  const std::size_t begin = static_cast<std::size_t>(tile_row_begin) * tiles_u;
  const std::size_t end = static_cast<std::size_t>(tile_row_end) * tiles_u;
  if (!compact_) {
    const auto first = h_.begin() + static_cast<std::ptrdiff_t>((begin - band_tile_begin_) * kTileLines);
    return std::vector<double>(first, first + static_cast<std::ptrdiff_t>((end - begin) * kTileLines));
  }
  std::size_t size = 0;  // sized first: a band's pack may be gigabytes (no doubling growth)
  for (std::size_t t = begin; t < end; ++t) size += 2 + offsets_.block(t).size();
  std::vector<double> packed;
  packed.reserve(size);
  for (std::size_t t = begin; t < end; ++t) {
    packed.push_back(base_[t]);
    const std::span<const float> offsets = offsets_.block(t);
    packed.push_back(static_cast<double>(offsets.size()));
    for (float offset : offsets) packed.push_back(static_cast<double>(offset));  // exact
  }
  return packed;
}

void NBuffer::unpack_band(int tile_row_begin, int tile_row_end, std::span<const double> packed) {
  if (!holds_all_tiles() || !(0 <= tile_row_begin && tile_row_begin < tile_row_end && tile_row_end <= tiles_v_)) {
    throw std::invalid_argument("NBuffer::unpack_band: needs a whole buffer and tile rows within it");
  }
  const std::size_t tiles_u = static_cast<std::size_t>(tiles_u_);
  const std::size_t begin = static_cast<std::size_t>(tile_row_begin) * tiles_u;
  const std::size_t end = static_cast<std::size_t>(tile_row_end) * tiles_u;
  double h[kTileLines];
  if (!compact_) {
    if (packed.size() != (end - begin) * kTileLines) {
      throw std::invalid_argument("NBuffer::unpack_band: " + std::to_string(packed.size()) + " lengths for " +
                                  std::to_string(end - begin) + " tiles");
    }
    std::copy(packed.begin(), packed.end(), h_.begin() + static_cast<std::ptrdiff_t>(begin * kTileLines));
    for (std::size_t t = begin; t < end; ++t) refresh_tile(t, &h_[t * kTileLines]);
    return;
  }
  std::size_t at = 0;
  for (std::size_t t = begin; t < end; ++t) {
    if (at + 2 > packed.size()) throw std::invalid_argument("NBuffer::unpack_band: pack too short");
    base_[t] = packed[at];
    const auto count = static_cast<std::size_t>(packed[at + 1]);
    at += 2;
    if ((count != 0 && count != kTileLines) || at + count > packed.size()) {
      throw std::invalid_argument("NBuffer::unpack_band: bad offset count in the pack");
    }
    std::vector<float> offsets(packed.begin() + static_cast<std::ptrdiff_t>(at),
                               packed.begin() + static_cast<std::ptrdiff_t>(at + count));  // float: exact
    offsets_.assign(t, offsets);
    at += count;
    tile_lengths(t, h);
    refresh_tile(t, h);
  }
  if (at != packed.size()) throw std::invalid_argument("NBuffer::unpack_band: pack too long");
}

std::vector<double> NBuffer::pack_tile_bounds() const {
  std::vector<double> packed;
  packed.reserve(tiles_.size() * kBoundsDoubles);
  for (const TileBounds& b : tiles_) {
    packed.insert(packed.end(), {b.lo.x(), b.lo.y(), b.lo.z(), b.hi.x(), b.hi.y(), b.hi.z(), b.h_max});
  }
  return packed;
}

void NBuffer::set_foreign_tile_bounds(std::span<const double> packed) {
  if (packed.size() != tiles_.size() * kBoundsDoubles) {
    throw std::invalid_argument("NBuffer::set_foreign_tile_bounds: wrong size");
  }
  for (std::size_t t = 0; t < tiles_.size(); ++t) {
    if (t >= band_tile_begin_ && t < band_tile_end_) continue;
    const double* p = &packed[t * kBoundsDoubles];
    tiles_[t].lo = Eigen::Vector3d(p[0], p[1], p[2]);
    tiles_[t].hi = Eigen::Vector3d(p[3], p[4], p[5]);
    tiles_[t].h_max = p[6];
  }
}

}  // namespace vmsim::removal
