#include "view_deviation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>

#include "surface_views.hpp"

namespace vmsim::app {

ViewDeviation::ViewDeviation(const removal::NBuffer& a, const removal::NBuffer& b, double spacing_m,
                             bool nan_as_infinity)
    : a_(&a), b_(&b), step_limit_m_(kSteepStepPerSpacing * spacing_m), nan_as_infinity_(nan_as_infinity) {
  if (!a.same_lines(b)) throw std::invalid_argument("ViewDeviation: the two N-buffers are not on identical lines");
  if (!a.holds_all_tiles() || !b.holds_all_tiles()) {
    throw std::invalid_argument("ViewDeviation: a band buffer (gather the bands first)");
  }
}

// |a - b| and |b - a| are the same double: the test is symmetric in the two neighbours, as
// exclude_steep_lines' pairs are.
bool ViewDeviation::steep_in(const removal::NBuffer& buffer, int iu, int iv) const {
  const double h = buffer.length(iu, iv);
  auto differs = [&](int ju, int jv) { return std::abs(buffer.length(ju, jv) - h) > step_limit_m_; };
  return (iu > 0 && differs(iu - 1, iv)) || (iu + 1 < buffer.nu() && differs(iu + 1, iv)) ||
         (iv > 0 && differs(iu, iv - 1)) || (iv + 1 < buffer.nv() && differs(iu, iv + 1));
}

bool ViewDeviation::steep(int iu, int iv) const { return steep_in(*a_, iu, iv) || steep_in(*b_, iu, iv); }

double ViewDeviation::value(double a_m, double b_m, bool steep) const {
  double deviation_m = steep ? 0.0 : a_m - b_m;
  if (nan_as_infinity_ && std::isnan(deviation_m)) deviation_m = std::numeric_limits<double>::infinity();
  return deviation_m;
}

double ViewDeviation::at(int iu, int iv) const {
  return value(a_->length(iu, iv), b_->length(iu, iv), steep(iu, iv));
}

removal::DeviationReader ViewDeviation::reader() const {
  auto rows = std::make_shared<DeviationRows>(*this);
  removal::DeviationReader reader;
  reader.row = [rows](int iv, std::span<double> row_m) {
    const std::span<const double> values = rows->row(iv);
    std::copy(values.begin(), values.end(), row_m.begin());
  };
  reader.at = [this](int iu, int iv) { return at(iu, iv); };
  return reader;
}

DeviationRows::DeviationRows(const ViewDeviation& deviation)
    : deviation_(deviation),
      deviation_m_(static_cast<std::size_t>(deviation.nu())),
      steep_(static_cast<std::size_t>(deviation.nu())) {}

void DeviationRows::load(const removal::NBuffer& buffer, int iv, std::vector<double>& row) const {
  row.clear();
  if (iv < 0 || iv >= buffer.nv()) return;  // beyond the grid: no neighbour
  row.resize(static_cast<std::size_t>(buffer.nu()));
  for (int iu = 0; iu < buffer.nu(); ++iu) row[static_cast<std::size_t>(iu)] = buffer.length(iu, iv);
}

void DeviationRows::move_to(int iv) {
  for (auto [lengths, buffer] : {std::pair{&a_, deviation_.a_}, std::pair{&b_, deviation_.b_}}) {
    if (iv == current_row_ + 1 && current_row_ >= 0) {
      std::swap(lengths->above, lengths->at);
      std::swap(lengths->at, lengths->below);
      load(*buffer, iv + 1, lengths->below);
    } else {
      load(*buffer, iv - 1, lengths->above);
      load(*buffer, iv, lengths->at);
      load(*buffer, iv + 1, lengths->below);
    }
  }
  current_row_ = iv;
}

void DeviationRows::mark_steep(const Lengths& lengths) {
  const double limit_m = deviation_.step_limit_m_;
  const std::size_t nu = lengths.at.size();
  for (std::size_t iu = 0; iu < nu; ++iu) {
    const double h = lengths.at[iu];
    if (iu + 1 < nu && std::abs(lengths.at[iu + 1] - h) > limit_m) steep_[iu] = steep_[iu + 1] = 1;
    if (!lengths.above.empty() && std::abs(lengths.above[iu] - h) > limit_m) steep_[iu] = 1;
    if (!lengths.below.empty() && std::abs(lengths.below[iu] - h) > limit_m) steep_[iu] = 1;
  }
}

std::span<const double> DeviationRows::row(int iv) {
  if (iv < 0 || iv >= deviation_.nv()) throw std::out_of_range("DeviationRows: row " + std::to_string(iv));
  if (iv != current_row_) move_to(iv);
  std::fill(steep_.begin(), steep_.end(), std::uint8_t{0});
  mark_steep(a_);
  mark_steep(b_);
  for (std::size_t iu = 0; iu < deviation_m_.size(); ++iu) {
    deviation_m_[iu] = deviation_.value(a_.at[iu], b_.at[iu], steep_[iu] != 0);
  }
  return deviation_m_;
}

}  // namespace vmsim::app
