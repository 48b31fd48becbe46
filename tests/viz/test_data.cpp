// What needs no display: histograms, validation of the plain data types, the surface files
// (.vtp read back with VTK's reader, .stl parsed by hand).
#include <gtest/gtest.h>
#include <vtkCellArray.h>
#include <vtkDataArray.h>
#include <vtkPointData.h>
#include <vtkPolyData.h>
#include <vtkSmartPointer.h>
#include <vtkXMLPolyDataReader.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <numeric>
#include <random>

#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/viz/plot.hpp"
#include "vmsim/viz/surface.hpp"
#include "../temp_folder.hpp"

namespace vmsim::viz {
namespace {

TEST(Histogram, KnownValuesFallInTheirBins) {
  const Histogram h = make_histogram({0.0, 0.5, 1.0, 1.5, 2.0, 3.9, 4.0}, 4, Range{0.0, 4.0});
  ASSERT_EQ(h.edges.size(), 5u);
  EXPECT_EQ(h.edges.front(), 0.0);
  EXPECT_EQ(h.edges.back(), 4.0);
  EXPECT_EQ(h.counts, (std::vector<double>{2, 2, 1, 2}));  // 4.0 is in the closed last bin
  EXPECT_EQ(h.below, 0u);
  EXPECT_EQ(h.above, 0u);
}

TEST(Histogram, EveryValueIsCountedOnceInABinOrOutside) {
  std::mt19937 random(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<double> values(5000);
  for (double& v : values) v = normal(random);
  const Histogram h = make_histogram(values, 37, Range{-2.0, 2.5});
  const double in_bins = std::accumulate(h.counts.begin(), h.counts.end(), 0.0);
  EXPECT_EQ(static_cast<std::size_t>(in_bins) + h.below + h.above, values.size());
  std::size_t below = 0, above = 0;
  for (double v : values) {
    below += v < -2.0 ? 1 : 0;
    above += v > 2.5 ? 1 : 0;
  }
  EXPECT_EQ(h.below, below);
  EXPECT_EQ(h.above, above);
  // Default range: every value in a bin.
  const Histogram all = make_histogram(values, 10);
  EXPECT_EQ(std::accumulate(all.counts.begin(), all.counts.end(), 0.0), 5000.0);
}

TEST(Histogram, RepeatedValueGetsAUnitWideRange) {
  const Histogram h = make_histogram({2.0, 2.0, 2.0}, 2);
  EXPECT_EQ(h.edges.front(), 1.5);
  EXPECT_EQ(h.edges.back(), 2.5);
  EXPECT_EQ(h.counts[1], 3.0);
}

TEST(Histogram, BadInputIsRejected) {
  EXPECT_THROW(make_histogram({}, 3), InputError);
  EXPECT_THROW(make_histogram({1.0}, 0), InputError);
  EXPECT_THROW(make_histogram({1.0, NAN}, 3), InputError);
  EXPECT_THROW(make_histogram({1.0}, 3, Range{1.0, 1.0}), InputError);
}

TEST(PlotValidation, MessagesNameSeriesFieldAndIndex) {
  LinePlot plot;
  plot.title = "t";
  EXPECT_THROW(validate(plot), InputError);
  plot.series.push_back({.name = "speed", .x = {0.0, 1.0, 2.0}, .y = {0.0, 1.0}});
  try {
    validate(plot);
    FAIL() << "no error for x and y of different lengths";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("series 'speed': x has 3 values, y has 2"),
              std::string::npos)
        << error.what();
  }
  plot.series[0].y = {0.0, INFINITY, 2.0};
  try {
    validate(plot);
    FAIL() << "no error for an infinite value";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("point 1"), std::string::npos) << error.what();
  }
  plot.series[0].y = {0.0, 1.0, 2.0};
  EXPECT_NO_THROW(validate(plot));
  plot.x_range = Range{1.0, 0.0};
  EXPECT_THROW(validate(plot), InputError);
}

HeightField ramp(int nx, int ny) {
  HeightField field;
  field.origin_x_m = 0.01;
  field.origin_y_m = -0.02;
  field.spacing_x_m = 1e-3;
  field.spacing_y_m = 2e-3;
  field.nx = nx;
  field.ny = ny;
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      field.height_m.push_back(1e-4 * i + 1e-5 * j);
      field.deviation_m.push_back(1e-6 * (i - j));
    }
  }
  return field;
}

TEST(SurfaceValidation, BadFieldsAreRejectedNamingTheField) {
  HeightField field = ramp(3, 2);
  EXPECT_NO_THROW(validate(field));
  field.deviation_m.pop_back();
  try {
    validate(field);
    FAIL();
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("deviation_m has 5 values"), std::string::npos)
        << error.what();
  }
  field = ramp(3, 2);
  field.height_m[4] = NAN;
  try {
    validate(field);
    FAIL();
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("height_m at node 4 (i 1, j 1)"), std::string::npos)
        << error.what();
  }
  field = ramp(1, 2);
  EXPECT_THROW(validate(field), InputError);
  field = ramp(3, 2);
  field.spacing_y_m = 0.0;
  EXPECT_THROW(validate(field), InputError);
}

TEST(SurfaceFiles, VtpReadsBackWithPointsTrianglesAndArrays) {
  const HeightField field = ramp(4, 3);
  const auto path = test::fresh_temp_folder("viz_vtp") / "surface.vtp";
  write_surface_vtp(path.string(), field);
  auto reader = vtkSmartPointer<vtkXMLPolyDataReader>::New();
  reader->SetFileName(path.string().c_str());
  reader->Update();
  vtkPolyData* surface = reader->GetOutput();
  ASSERT_EQ(surface->GetNumberOfPoints(), 12);
  EXPECT_EQ(surface->GetNumberOfPolys(), 2 * 3 * 2);
  vtkDataArray* height = surface->GetPointData()->GetArray("height_m");
  vtkDataArray* deviation = surface->GetPointData()->GetArray("deviation_m");
  ASSERT_NE(height, nullptr);
  ASSERT_NE(deviation, nullptr);
  for (int j = 0; j < field.ny; ++j) {
    for (int i = 0; i < field.nx; ++i) {
      const auto k = static_cast<vtkIdType>(field.index(i, j));
      double p[3];
      surface->GetPoint(k, p);
      EXPECT_DOUBLE_EQ(p[0], field.origin_x_m + i * field.spacing_x_m);
      EXPECT_DOUBLE_EQ(p[1], field.origin_y_m + j * field.spacing_y_m);
      EXPECT_DOUBLE_EQ(p[2], field.height_m[static_cast<std::size_t>(k)]);
      EXPECT_DOUBLE_EQ(height->GetTuple1(k), field.height_m[static_cast<std::size_t>(k)]);
      EXPECT_DOUBLE_EQ(deviation->GetTuple1(k), field.deviation_m[static_cast<std::size_t>(k)]);
    }
  }
}

TEST(SurfaceFiles, VtpWithoutDeviationHasOnlyTheHeight) {
  HeightField field = ramp(2, 2);
  field.deviation_m.clear();
  const auto path = test::fresh_temp_folder("viz_vtp_height") / "surface.vtp";
  write_surface_vtp(path.string(), field);
  auto reader = vtkSmartPointer<vtkXMLPolyDataReader>::New();
  reader->SetFileName(path.string().c_str());
  reader->Update();
  EXPECT_NE(reader->GetOutput()->GetPointData()->GetArray("height_m"), nullptr);
  EXPECT_EQ(reader->GetOutput()->GetPointData()->GetArray("deviation_m"), nullptr);
}

TEST(SurfaceFiles, BinaryStlHoldsTwoTrianglesPerCellInMillimetres) {
  const HeightField field = ramp(3, 2);
  const auto path = test::fresh_temp_folder("viz_stl") / "surface.stl";
  write_surface_stl(path.string(), field);
  const std::string bytes = read_file(path.string());
  const std::size_t triangles = 2 * 2 * 1;
  ASSERT_EQ(bytes.size(), 84 + 50 * triangles);
  std::uint32_t count = 0;
  std::memcpy(&count, bytes.data() + 80, 4);
  EXPECT_EQ(count, triangles);
  // Every normal points up (z > 0) and has unit length; the first triangle's
  // first vertex is node (0, 0) in mm.
  for (std::size_t t = 0; t < triangles; ++t) {
    float values[12];
    std::memcpy(values, bytes.data() + 84 + 50 * t, sizeof values);
    EXPECT_NEAR(values[0] * values[0] + values[1] * values[1] + values[2] * values[2], 1.0, 1e-6);
    EXPECT_GT(values[2], 0.0f);
    if (t == 0) {
      EXPECT_FLOAT_EQ(values[3], 10.0f);
      EXPECT_FLOAT_EQ(values[4], -20.0f);
      EXPECT_FLOAT_EQ(values[5], 0.0f);
    }
  }
}

TEST(SurfaceFiles, UnwritablePathIsAnInputErrorNamingIt) {
  const std::string path = "/nonexistent-folder-vmsim/surface.vtp";
  try {
    write_surface_vtp(path, ramp(2, 2));
    FAIL();
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find(path), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace vmsim::viz
