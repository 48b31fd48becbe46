// The streamed mark finder (marks_stream.hpp) against find_marks (marks.hpp), an independent
// algorithm (one flood fill over the whole view): the same marks bit for bit, the same labels,
// on random fields and on hand-made shapes (regions merging late, U-shapes, spirals, regions
// across tile edges, min_lines filtering).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <string>

#include "vmsim/removal/marks.hpp"
#include "vmsim/removal/marks_stream.hpp"
#include "vmsim/removal/nbuffer.hpp"

namespace vmsim::removal {
namespace {

// General lines on a wavy sheet (each line stands for a different area, so that the centroid's
// sum depends on the order of its terms), with varied lengths.
NBuffer wavy_lines(int nu, int nv, std::mt19937& random) {
  std::uniform_real_distribution<double> length_m(0.001, 0.002);
  std::vector<Eigen::Vector3d> origins, directions;
  std::vector<double> lengths;
  for (int iv = 0; iv < nv; ++iv) {
    for (int iu = 0; iu < nu; ++iu) {
      const double x = 1e-4 * iu + 3e-6 * iu * iu / (1 + iv), y = 1.3e-4 * iv + 1e-6 * iu;
      origins.emplace_back(x, y, 1e-4 * std::sin(0.3 * iu) * std::cos(0.2 * iv));
      directions.emplace_back(0.1 * std::sin(0.1 * iv), 0.05, 1.0);
      lengths.push_back(length_m(random));
    }
  }
  return NBuffer::lines(nu, nv, std::move(origins), std::move(directions), std::move(lengths));
}

// A deviation [m] of blobs of both signs above a 2 um threshold, with noise that makes specks.
std::vector<double> blobby_field(int nu, int nv, std::mt19937& random) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<double> field(static_cast<std::size_t>(nu) * static_cast<std::size_t>(nv));
  const double fu = 0.2 + unit(random), fv = 0.2 + unit(random), phase = 6 * unit(random);
  for (int iv = 0; iv < nv; ++iv) {
    for (int iu = 0; iu < nu; ++iu) {
      double d = 4e-6 * std::sin(fu * iu + phase) * std::cos(fv * iv);
      if (unit(random) < 0.15) d = (unit(random) - 0.5) * 1e-5;  // specks
      if (unit(random) < 0.01) d = 3e-6;                            // ties in depth
      field[static_cast<std::size_t>(iu) + static_cast<std::size_t>(nu) * static_cast<std::size_t>(iv)] = d;
    }
  }
  return field;
}

// The field read `band_rows` rows at a time (as simulate-part reads a view band by band).
DeviationReader reader_of(const std::vector<double>& field, int nu, int band_rows) {
  auto band = std::make_shared<std::vector<double>>();
  auto band_first_row = std::make_shared<int>(-1);
  DeviationReader reader;
  reader.row = [&field, nu, band_rows, band, band_first_row](int iv, std::span<double> row_m) {
    if (*band_first_row < 0 || iv >= *band_first_row + band_rows) {
      *band_first_row = iv;
      const auto begin = field.begin() + static_cast<std::ptrdiff_t>(iv) * nu;
      const auto end = std::min(field.end(), begin + static_cast<std::ptrdiff_t>(band_rows) * nu);
      band->assign(begin, end);
    }
    const auto offset = static_cast<std::ptrdiff_t>(iv - *band_first_row) * nu;
    std::copy_n(band->begin() + offset, nu, row_m.begin());
  };
  reader.at = [&field, nu](int iu, int iv) {
    return field[static_cast<std::size_t>(iu) + static_cast<std::size_t>(nu) * static_cast<std::size_t>(iv)];
  };
  return reader;
}

void expect_same_marks(const NBuffer& production, const std::vector<double>& field, const MarkOptions& options,
                       int band_rows, const std::string& what) {
  const MarkMap expected = find_marks(production, field, options);
  const StreamedMarkMap streamed = find_marks_streamed(production, reader_of(field, production.nu(), band_rows), options);
  ASSERT_EQ(streamed.marks.size(), expected.marks.size()) << what;
  for (std::size_t m = 0; m < expected.marks.size(); ++m) {
    const Mark &a = streamed.marks[m], &b = expected.marks[m];
    EXPECT_EQ(a.kind, b.kind) << what << " mark " << m;
    EXPECT_EQ(a.line_count, b.line_count) << what << " mark " << m;
    // Bit for bit: the same terms summed in the same order.
    EXPECT_EQ(a.depth_m, b.depth_m) << what << " mark " << m;
    EXPECT_EQ(a.area_m2, b.area_m2) << what << " mark " << m;
    EXPECT_EQ(a.deepest_point_W_m, b.deepest_point_W_m) << what << " mark " << m;
    EXPECT_EQ(a.centroid_W_m, b.centroid_W_m) << what << " mark " << m;
    EXPECT_EQ(a.iu_min, b.iu_min) << what << " mark " << m;
    EXPECT_EQ(a.iu_max, b.iu_max) << what << " mark " << m;
    EXPECT_EQ(a.iv_min, b.iv_min) << what << " mark " << m;
    EXPECT_EQ(a.iv_max, b.iv_max) << what << " mark " << m;
  }
  std::size_t labelled = 0;
  for (int iv = 0; iv < production.nv(); ++iv) {
    for (int iu = 0; iu < production.nu(); ++iu) {
      const int label = expected.label[static_cast<std::size_t>(iu) + static_cast<std::size_t>(production.nu()) * iv];
      ASSERT_EQ(streamed.labels.at(iu, iv), label) << what << " line " << iu << ", " << iv;
      labelled += label >= 0 ? 1 : 0;
    }
  }
  // Sparse: no tile held without a marked line.
  EXPECT_LE(streamed.labels.tiles_held(), labelled) << what;
}

TEST(MarksStreamed, SameAsFindMarksOnRandomFields) {
  std::mt19937 random(21);
  std::uniform_int_distribution<int> size(1, 70);
  int with_marks = 0;
  for (int seed = 0; seed < 60; ++seed) {
    const int nu = size(random), nv = size(random);
    const NBuffer production = wavy_lines(nu, nv, random);
    const std::vector<double> field = blobby_field(nu, nv, random);
    MarkOptions options;
    options.min_lines = static_cast<std::size_t>(1 + seed % 6);
    for (int band_rows : {1, 16, 17}) {
      expect_same_marks(production, field, options, band_rows,
                        "seed " + std::to_string(seed) + " band " + std::to_string(band_rows));
    }
    with_marks += find_marks(production, field, options).marks.empty() ? 0 : 1;
  }
  EXPECT_GT(with_marks, 40);  // the fields do hold marks
}

TEST(MarksStreamed, SameAsFindMarksOnAZmapWithRegionsAcrossTiles) {
  const NBuffer production = NBuffer::zmap(Box{{0.0, 0.0, 0.0}, {0.0049, 0.0039, 0.005}}, 1e-4);
  std::mt19937 random(5);
  for (int seed = 0; seed < 10; ++seed) {
    const std::vector<double> field = blobby_field(production.nu(), production.nv(), random);
    expect_same_marks(production, field, {}, 16, "zmap seed " + std::to_string(seed));
  }
}

// Shapes drawn with '-' (gouge), '+' (excess), '.' (none).
std::vector<double> drawn(const std::vector<std::string>& rows) {
  std::vector<double> field;
  for (const std::string& row : rows) {
    for (char c : row) field.push_back(c == '-' ? -5e-6 : c == '+' ? 5e-6 : 0.0);
  }
  return field;
}

TEST(MarksStreamed, RegionsThatMeetLateAreOneMark) {
  // A U whose arms meet on the last row, a hooked region, a comb joined at the bottom; a lone
  // speck and a pair below min_lines.
  const std::vector<std::string> rows = {
      "-..-.+++++.-.-.-.-..",
      "-..-.+...+.-.-.-.-..",
      "-..-.+.+.+.-.-.-.-.+",
      "-..-.+.+++.-.-.-.-..",
      "-..-.+.....-------..",
      "----.+++++++......--",
  };
  const int nu = 20, nv = 6;
  std::mt19937 random(1);
  const NBuffer production = wavy_lines(nu, nv, random);
  const std::vector<double> field = drawn(rows);
  for (int band_rows : {1, 2, 16}) expect_same_marks(production, field, {}, band_rows, "drawn");
  const StreamedMarkMap streamed = find_marks_streamed(production, reader_of(field, nu, 1), {});
  // Hand count: the U (14 lines), the spiral (22), the comb (23); the speck and the pair drop.
  ASSERT_EQ(streamed.marks.size(), 3u);
  std::vector<std::size_t> counts;
  for (const Mark& mark : streamed.marks) counts.push_back(mark.line_count);
  std::sort(counts.begin(), counts.end());
  EXPECT_EQ(counts, (std::vector<std::size_t>{14, 22, 23}));
  EXPECT_EQ(streamed.labels.at(0, 0), streamed.labels.at(3, 0));        // the U's arms
  EXPECT_EQ(streamed.labels.at(11, 0), streamed.labels.at(17, 0));      // the comb's teeth
  EXPECT_EQ(streamed.labels.at(19, 2), -1);                             // the speck
  EXPECT_EQ(streamed.labels.at(18, 5), -1);                             // the pair
}

TEST(MarksStreamed, RowsOfAWrongSizeOrMissingAreErrors) {
  MarkRegionFinder finder(4, 2, {});
  const std::vector<double> short_row(3, 0.0), row(4, 0.0);
  EXPECT_THROW(finder.add_row(short_row), std::invalid_argument);
  finder.add_row(row);
  EXPECT_THROW((void)finder.regions(), std::logic_error);
  finder.add_row(row);
  EXPECT_THROW(finder.add_row(row), std::invalid_argument);
  EXPECT_TRUE(finder.regions().empty());
}

}  // namespace
}  // namespace vmsim::removal
