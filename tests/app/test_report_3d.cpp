// The report's 3-D view data (app/report_3d.hpp): the decimation keeps each cell's worst line
// (a mark never vanishes), the nearest programmed segment agrees with a search of every segment,
// the encoding reads back with zlib's own decoder, and the page's section says how to get the
// view when the library is missing.
#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <random>

#include <unistd.h>

#include "report_3d.hpp"
#include "report_html.hpp"
#include "report_marks.hpp"

namespace vmsim::app {
namespace {

using Json = nlohmann::json;
constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();

// An independent base64 decoder (RFC 4648 alphabet), then zlib's uncompress.
std::vector<unsigned char> from_base64(const std::string& text) {
  std::vector<unsigned char> out;
  unsigned value = 0;
  int bits = 0;
  for (char c : text) {
    int digit;
    if (c >= 'A' && c <= 'Z') digit = c - 'A';
    else if (c >= 'a' && c <= 'z') digit = c - 'a' + 26;
    else if (c >= '0' && c <= '9') digit = c - '0' + 52;
    else if (c == '+') digit = 62;
    else if (c == '/') digit = 63;
    else break;  // padding
    value = (value << 6) | static_cast<unsigned>(digit);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<unsigned char>((value >> bits) & 0xFF));
    }
  }
  return out;
}

std::vector<unsigned char> inflate(const std::string& text, std::size_t expected_bytes) {
  const std::vector<unsigned char> packed = from_base64(text);
  std::vector<unsigned char> bytes(expected_bytes + 16);
  uLongf size = bytes.size();
  EXPECT_EQ(uncompress(bytes.data(), &size, packed.data(), packed.size()), Z_OK);
  bytes.resize(size);
  return bytes;
}

template <typename T>
std::vector<T> as(const std::vector<unsigned char>& bytes) {
  std::vector<T> values(bytes.size() / sizeof(T));
  std::memcpy(values.data(), bytes.data(), values.size() * sizeof(T));
  return values;
}

TEST(Report3d, Base64MatchesTheRfcVectors) {
  const std::pair<const char*, const char*> vectors[] = {{"", ""},         {"f", "Zg=="},         {"fo", "Zm8="},
                                                         {"foo", "Zm9v"},  {"foob", "Zm9vYg=="},  {"fooba", "Zm9vYmE="},
                                                         {"foobar", "Zm9vYmFy"}};
  for (const auto& [plain, coded] : vectors) EXPECT_EQ(base64(plain, std::strlen(plain)), coded) << plain;
}

TEST(Report3d, DeflatedDataReadsBackWithZlib) {
  std::vector<float> values;
  std::mt19937 random(5);
  for (int i = 0; i < 5000; ++i) values.push_back(std::uniform_real_distribution<float>(-20.0f, 20.0f)(random));
  const std::string text = deflated_base64(values.data(), values.size() * sizeof(float));
  EXPECT_EQ(as<float>(inflate(text, values.size() * sizeof(float))), values);
}

TEST(Report3d, CellSideIsTheSmallestWithinTheBudget) {
  for (const auto& [nu, nv, budget] : {std::tuple{4000, 500, 120000}, std::tuple{1600, 200, 60000},
                                       std::tuple{7, 3, 100}, std::tuple{1000, 1, 10}}) {
    const int k = cell_lines_for(nu, nv, static_cast<std::size_t>(budget));
    const auto cells = [&](int side) { return ((nu + side - 1) / side) * ((nv + side - 1) / side); };
    EXPECT_LE(cells(k), budget) << nu << " x " << nv;
    if (k > 1) {
      EXPECT_GT(cells(k - 1), budget) << nu << " x " << nv;
    }
  }
}

TEST(Report3d, EachCellKeepsItsWorstLineAndAMarkNeverVanishes) {
  const int nu = 53, nv = 31, side = 4;
  std::mt19937 random(11);
  std::vector<double> deviation(static_cast<std::size_t>(nu * nv));
  for (double& d : deviation) d = std::uniform_real_distribution<double>(-1e-6, 1e-6)(random);
  // A narrow mark, three lines wide, deepest at (22, 17).
  for (int iv = 16; iv <= 18; ++iv) {
    for (int iu = 10; iu <= 40; ++iu) deviation[static_cast<std::size_t>(iu + nu * iv)] = -8e-6;
  }
  deviation[static_cast<std::size_t>(22 + nu * 17)] = -19e-6;
  const WorstOfCells cells = keep_worst_of_cells(nu, nv, deviation, side);
  ASSERT_EQ(cells.cells_u, 14);
  ASSERT_EQ(cells.cells_v, 8);
  bool deepest_kept = false;
  for (int cv = 0; cv < cells.cells_v; ++cv) {
    for (int cu = 0; cu < cells.cells_u; ++cu) {
      const std::size_t kept = cells.line[static_cast<std::size_t>(cu + cells.cells_u * cv)];
      ASSERT_NE(kept, kNone);
      const int iu = static_cast<int>(kept % nu), iv = static_cast<int>(kept / nu);
      // In its cell, and no line of the cell deviates more.
      EXPECT_EQ(iu / side, cu);
      EXPECT_EQ(iv / side, cv);
      for (int jv = cv * side; jv < std::min(nv, cv * side + side); ++jv) {
        for (int ju = cu * side; ju < std::min(nu, cu * side + side); ++ju) {
          EXPECT_GE(std::abs(deviation[kept]), std::abs(deviation[static_cast<std::size_t>(ju + nu * jv)]));
        }
      }
      deepest_kept = deepest_kept || kept == static_cast<std::size_t>(22 + nu * 17);
    }
  }
  EXPECT_TRUE(deepest_kept);
}

TEST(Report3d, FlatCellsKeepTheirCentreAndLinesWithoutMaterialAreNeverKept) {
  const int nu = 9, nv = 6;
  // Deviations within the threshold (here 1 um) count as none.
  std::vector<double> flat(static_cast<std::size_t>(nu * nv), 0.0);
  flat[0] = 0.9e-6;
  flat[static_cast<std::size_t>(5 + nu * 2)] = -1e-6;
  std::vector<bool> usable(flat.size(), true);
  for (int iu = 6; iu < 9; ++iu) {
    for (int iv = 0; iv < 3; ++iv) usable[static_cast<std::size_t>(iu + nu * iv)] = false;  // cell (2, 0)
  }
  usable[static_cast<std::size_t>(1 + nu * 1)] = false;  // the centre of cell (0, 0)
  const WorstOfCells cells = keep_worst_of_cells(nu, nv, flat, 3, &usable, 1e-6);
  EXPECT_EQ(cells.line[1], static_cast<std::size_t>(4 + nu * 1));  // cell (1, 0): its centre
  EXPECT_EQ(cells.line[2], kNone);                                 // no material at all
  const std::size_t first = cells.line[0];
  ASSERT_NE(first, kNone);
  EXPECT_TRUE(usable[first]);
  // Next to the missing centre: one of its four neighbours.
  const int iu = static_cast<int>(first % nu), iv = static_cast<int>(first / nu);
  EXPECT_EQ(std::abs(iu - 1) + std::abs(iv - 1), 1);
}

TEST(Report3d, NearestSegmentAgreesWithASearchOfEverySegment) {
  std::mt19937 random(3);
  std::uniform_real_distribution<double> coordinate(-0.04, 0.04);
  std::vector<Eigen::Vector3d> points;
  std::vector<bool> cutting;
  for (int k = 0; k < 400; ++k) {
    points.emplace_back(coordinate(random), 0.25 * coordinate(random), 0.02 + 0.1 * coordinate(random));
    cutting.push_back(k % 7 != 0);  // every seventh motion a rapid
  }
  const NearestSegment index(points, cutting);
  const auto distance = [&](const Eigen::Vector3d& p, std::size_t k) {
    const Eigen::Vector3d a = points[k - 1], ab = points[k] - a;
    const double f = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    return (a + f * ab - p).norm();
  };
  for (int query = 0; query < 500; ++query) {
    const Eigen::Vector3d p(1.5 * coordinate(random), 1.5 * coordinate(random), 0.02 + coordinate(random));
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t k = 1; k < points.size(); ++k) {
      if (cutting[k]) best = std::min(best, distance(p, k));
    }
    const long found = index.nearest(p);
    ASSERT_GE(found, 1);
    EXPECT_TRUE(cutting[static_cast<std::size_t>(found)]);
    EXPECT_DOUBLE_EQ(distance(p, static_cast<std::size_t>(found)), best);
  }
  EXPECT_EQ(NearestSegment({Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX()}, {true, false}).nearest(Eigen::Vector3d::Zero()), -1);
}

// A 20 x 10 grid of lines 1 mm apart at z = x / 10 mm; one mark; two programmed passes along x.
View3dInputs small_inputs(std::vector<double>& deviation, std::vector<int>& label) {
  const int nu = 20, nv = 10;
  deviation.assign(static_cast<std::size_t>(nu * nv), 0.0);
  label.assign(deviation.size(), -1);
  for (int iu = 4; iu <= 7; ++iu) {
    for (int iv = 6; iv <= 8; ++iv) {
      deviation[static_cast<std::size_t>(iu + nu * iv)] = -5e-6;
      label[static_cast<std::size_t>(iu + nu * iv)] = 0;
    }
  }
  deviation[static_cast<std::size_t>(5 + nu * 7)] = -12e-6;
  View3dInputs inputs;
  View3dInput view;
  view.id = "zmap";
  view.title = "Z-map";
  view.nu = nu;
  view.nv = nv;
  view.surface_point_W_m = [](int iu, int iv) { return Eigen::Vector3d(iu * 1e-3, iv * 1e-3, iu * 1e-4); };
  view.deviation_m_at = [&deviation, nu](int iu, int iv) { return deviation[static_cast<std::size_t>(iu + nu * iv)]; };
  view.rows = [&deviation, nu](int iv, std::span<double> row_m, std::span<std::uint8_t> usable) {
    for (int iu = 0; iu < nu; ++iu) {
      row_m[static_cast<std::size_t>(iu)] = deviation[static_cast<std::size_t>(iu + nu * iv)];
      usable[static_cast<std::size_t>(iu)] = 1;
    }
  };
  view.mark_label_at = [&label, nu](int iu, int iv) { return label[static_cast<std::size_t>(iu + nu * iv)]; };
  inputs.views.push_back(view);
  // Pass 1 at y = 2 mm (blocks 0 -> 1), a rapid, pass 2 at y = 7 mm (blocks 2 -> 3).
  inputs.path_centre_W_m = {{0, 2e-3, 0}, {20e-3, 2e-3, 0}, {0, 7e-3, 0}, {20e-3, 7e-3, 0}};
  inputs.path_block = {0, 1, 2, 3};
  inputs.path_cutting = {true, true, false, true};
  for (int b = 0; b < 4; ++b) inputs.blocks.push_back({"part.nc", 10 + b, b == 3 ? 40 : -1, "G1 X" + std::to_string(b)});
  Json mark{{"view", "zmap"}, {"view_mark_index", 0}, {"depth_um", 12.0}, {"area_mm2", 12.0}, {"kind", "gouge"},
            {"line", 13}, {"block", "part.nc:13 N40"}, {"block_text", "G1 X3"}, {"deepest_point_mm", {5, 7, 0.5}}};
  inputs.curated_marks = curate_marks(Json::array({mark}), 1.0);
  inputs.mark_threshold_um = 2.0;
  inputs.max_vertices = 28;  // cells of 3 x 3 lines: 7 x 4
  return inputs;
}

TEST(Report3d, DataHoldsTheDecimatedSurfaceItsMarksAndTheNearestBlocks) {
  std::vector<double> deviation;
  std::vector<int> label;
  const View3dData data = view3d_data(small_inputs(deviation, label));
  const std::string prefix = "window.vmsimDeviationMesh = ";
  const std::size_t start = data.script.find(prefix);
  ASSERT_NE(start, std::string::npos);
  const Json json = Json::parse(data.script.substr(start + prefix.size(), data.script.rfind(';') - start - prefix.size()));
  const Json& view = json["views"][0];
  EXPECT_EQ(view["cells"], Json::array({7, 4}));
  EXPECT_EQ(view["cell_lines"], 3);
  const std::size_t n = 28;
  const auto positions = as<float>(inflate(view["positions_mm"], 12 * n));
  const auto deviations = as<float>(inflate(view["deviation_um"], 4 * n));
  const auto marks = as<std::int16_t>(inflate(view["mark"], 2 * n));
  ASSERT_EQ(view["block_bytes"], 2);
  const auto blocks = as<std::uint16_t>(inflate(view["block"], 2 * n));
  ASSERT_EQ(deviations.size(), n);
  // Cell (1, 2) holds lines 3..5 x 6..8: it keeps the deepest line (5, 7), at its own place.
  const std::size_t cell = 1 + 7 * 2;
  EXPECT_FLOAT_EQ(deviations[cell], -12.0f);
  EXPECT_FLOAT_EQ(positions[3 * cell], 5.0f);
  EXPECT_FLOAT_EQ(positions[3 * cell + 1], 7.0f);
  EXPECT_FLOAT_EQ(positions[3 * cell + 2], 0.5f);
  EXPECT_EQ(marks[cell], 0);
  EXPECT_EQ(json["marks"][0]["rank"], 1);
  EXPECT_EQ(json["marks"][0]["line"], 13);
  // A flat cell keeps its centre: cell (0, 0) -> line (1, 1), nearest pass 1 (block 1, line 11).
  EXPECT_FLOAT_EQ(positions[0], 1.0f);
  EXPECT_FLOAT_EQ(positions[1], 1.0f);
  EXPECT_EQ(marks[0], -1);
  const Json program = Json::parse(inflate(json["blocks"], 1 << 16));
  ASSERT_GT(blocks[0], 0);
  EXPECT_EQ(program[blocks[0] - 1][1], 11);
  // Cell (0, 3) (lines 0..2 x 9): centre (1, 9), nearest pass 2 (block 3, line 13, N40); the rapid
  // between the passes (block 2) never counts.
  const std::size_t top = 0 + 7 * 3;
  EXPECT_FLOAT_EQ(positions[3 * top + 1], 9.0f);
  EXPECT_EQ(program[blocks[top] - 1][1], 13);
  EXPECT_EQ(program[blocks[top] - 1][2], 40);
  EXPECT_EQ(json["files"][program[blocks[top] - 1][0].get<int>()], "part.nc");
  EXPECT_EQ(data.summary["vertices"], n);
}

TEST(Report3dHtml, WithoutTheLibraryThePageSaysHowToGetTheView) {
  std::vector<double> deviation;
  std::vector<int> label;
  const auto folder = std::filesystem::temp_directory_path() / ("vmsim_report3d_" + std::to_string(::getpid()));
  std::filesystem::remove_all(folder);
  std::filesystem::create_directories(folder);
  const Json missing = write_view3d(folder, small_inputs(deviation, label), std::nullopt);
  EXPECT_FALSE(missing["available"].get<bool>());
  EXPECT_FALSE(std::filesystem::exists(folder / "3d"));
  Json report;
  report["part"] = {{"name", "p"}, {"description", ""}};
  report["surface"] = {{"mark_threshold_um", 2.0}, {"views", Json::array()}};
  report["marks"] = small_inputs(deviation, label).curated_marks["marks"];
  report["runs"] = Json::object();
  report["view_3d"] = missing;
  std::string html = html_report(report, {});
  EXPECT_NE(html.find("No 3-D view in this report"), std::string::npos);
  EXPECT_NE(html.find("bash scripts/setup-web.sh"), std::string::npos);
  EXPECT_EQ(html.find("<script"), std::string::npos);
  EXPECT_EQ(html.find("show-in-3d"), std::string::npos);

  // With a library (any file stands in for it here): the files beside the page, by relative
  // paths, and a link from each mark to the view.
  const auto library = folder / "library.js";
  std::ofstream(library) << "// stand-in\n";
  const Json written = write_view3d(folder / "out", small_inputs(deviation, label), library);
  EXPECT_TRUE(written["available"].get<bool>());
  for (const char* file : {"3d/vtk.js", "3d/view3d.js", "3d/deviation_mesh.js"}) {
    EXPECT_TRUE(std::filesystem::is_regular_file(folder / "out" / file)) << file;
  }
  EXPECT_EQ(written["library_bytes"], 12);
  report["view_3d"] = written;
  html = html_report(report, {});
  EXPECT_NE(html.find("<script src=\"3d/vtk.js\"></script>"), std::string::npos);
  EXPECT_LT(html.find("3d/deviation_mesh.js"), html.find("3d/view3d.js"));
  EXPECT_NE(html.find("class=\"show-in-3d\" href=\"#view-3d\" data-rank=\"1\""), std::string::npos);
  EXPECT_EQ(html.find(folder.string()), std::string::npos);
  std::filesystem::remove_all(folder);
}

}  // namespace
}  // namespace vmsim::app
