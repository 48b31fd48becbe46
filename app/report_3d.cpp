#include "report_3d.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <map>
#include <stdexcept>

#include <zlib.h>

#include "vmsim/common/files.hpp"
#include "view3d_script.hpp"  // generated from viz/web/view3d.js (app/CMakeLists.txt)

namespace vmsim::app {
namespace {

using Json = nlohmann::json;
constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();

double segment_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double length2 = ab.squaredNorm();
  const double f = length2 > 0 ? std::clamp((p - a).dot(ab) / length2, 0.0, 1.0) : 0.0;
  return (a + f * ab - p).norm();
}

template <typename T>
void append_bytes(std::vector<unsigned char>& bytes, T value) {
  unsigned char raw[sizeof(T)];
  std::memcpy(raw, &value, sizeof(T));  // the browser reads typed arrays in the machine's order
  bytes.insert(bytes.end(), raw, raw + sizeof(T));
}

std::string encoded(const std::vector<unsigned char>& bytes) { return deflated_base64(bytes.data(), bytes.size()); }

// The marks table of the data: every curated mark, then every speck; keyed by (view, view mark).
struct MarkTable {
  Json entries = Json::array();
  std::map<std::pair<std::string, int>, int> index;
};

MarkTable mark_table(const Json& curated) {
  MarkTable table;
  const auto add = [&table](const Json& mark, bool speck) {
    if (table.entries.size() >= 32767) return;  // int16 per vertex; deepest first
    Json entry{{"rank", mark.value("rank", 0)},
               {"speck", speck},
               {"depth_um", mark.value("depth_um", 0.0)},
               {"kind", mark.value("kind", "")},
               {"view", mark.value("view", "")},
               {"line", mark.value("line", 0)},
               {"block", mark.value("block", "")},
               {"block_text", mark.value("block_text", "")}};
    if (mark.contains("deepest_point_mm")) entry["deepest_point_mm"] = mark["deepest_point_mm"];
    table.index[{mark.value("view", ""), mark.value("view_mark_index", -1)}] = static_cast<int>(table.entries.size());
    table.entries.push_back(std::move(entry));
  };
  if (curated.contains("marks")) {
    for (const auto& mark : curated["marks"]) add(mark, false);
  }
  if (curated.contains("specks") && curated["specks"].contains("list")) {
    for (const auto& speck : curated["specks"]["list"]) add(speck, true);
  }
  return table;
}

}  // namespace

int cell_lines_for(int nu, int nv, std::size_t max_cells) {
  if (nu < 1 || nv < 1 || max_cells < 1) throw std::invalid_argument("cell_lines_for: empty grid or budget");
  const double lines = static_cast<double>(nu) * static_cast<double>(nv);
  int k = std::max(1, static_cast<int>(std::floor(std::sqrt(lines / static_cast<double>(max_cells)))));
  const auto cells = [&](int side) {
    return static_cast<std::size_t>((nu + side - 1) / side) * static_cast<std::size_t>((nv + side - 1) / side);
  };
  while (cells(k) > max_cells) ++k;
  return k;
}

WorstOfCells keep_worst_of_cells(int nu, int nv, const std::vector<double>& deviation_m, int cell_lines,
                                 const std::vector<bool>* usable, double significant_m) {
  const std::size_t lines = static_cast<std::size_t>(std::max(nu, 0)) * static_cast<std::size_t>(std::max(nv, 0));
  if (cell_lines < 1 || nu < 1 || nv < 1 || deviation_m.size() != lines || (usable && usable->size() != lines)) {
    throw std::invalid_argument("keep_worst_of_cells: sizes do not match the grid");
  }
  const ViewRowReader rows = [&](int iv, std::span<double> row_m, std::span<std::uint8_t> row_usable) {
    const std::size_t first = static_cast<std::size_t>(nu) * static_cast<std::size_t>(iv);
    for (std::size_t iu = 0; iu < row_m.size(); ++iu) {
      row_m[iu] = deviation_m[first + iu];
      row_usable[iu] = !usable || (*usable)[first + iu] ? 1 : 0;
    }
  };
  return keep_worst_of_cells(nu, nv, rows, cell_lines, significant_m);
}

namespace {

// A cell's choice so far (lines seen in row-major order within the cell).
struct CellChoice {
  std::size_t line = kNone;
  double size = -1.0;
  long centre_distance = 0;
};

}  // namespace

WorstOfCells keep_worst_of_cells(int nu, int nv, const ViewRowReader& rows, int cell_lines, double significant_m) {
  if (cell_lines < 1 || nu < 1 || nv < 1) throw std::invalid_argument("keep_worst_of_cells: sizes do not match the grid");
  WorstOfCells result;
  result.cell_lines = cell_lines;
  result.cells_u = (nu + cell_lines - 1) / cell_lines;
  result.cells_v = (nv + cell_lines - 1) / cell_lines;
  result.line.assign(static_cast<std::size_t>(result.cells_u) * static_cast<std::size_t>(result.cells_v), kNone);
  std::vector<double> row_m(static_cast<std::size_t>(nu));
  std::vector<std::uint8_t> usable(static_cast<std::size_t>(nu));
  std::vector<CellChoice> choices(static_cast<std::size_t>(result.cells_u));
  for (int cv = 0; cv < result.cells_v; ++cv) {
    const int v0 = cv * cell_lines, v1 = std::min(nv, v0 + cell_lines);
    std::fill(choices.begin(), choices.end(), CellChoice{});
    for (int iv = v0; iv < v1; ++iv) {
      rows(iv, row_m, usable);
      for (int cu = 0; cu < result.cells_u; ++cu) {
        const int u0 = cu * cell_lines, u1 = std::min(nu, u0 + cell_lines);
        // Twice the cell's centre, so that it is an integer.
        const int cu2 = u0 + u1 - 1, cv2 = v0 + v1 - 1;
        CellChoice& best = choices[static_cast<std::size_t>(cu)];
        for (int iu = u0; iu < u1; ++iu) {
          if (!usable[static_cast<std::size_t>(iu)]) continue;
          double size = std::abs(row_m[static_cast<std::size_t>(iu)]);
          if (!std::isfinite(size)) continue;
          if (size <= significant_m) size = 0.0;
          const long du = 2L * iu - cu2, dv = 2L * iv - cv2;
          const long centre_distance = du * du + dv * dv;
          if (size > best.size || (size == best.size && centre_distance < best.centre_distance)) {
            best = {static_cast<std::size_t>(iu) + static_cast<std::size_t>(nu) * static_cast<std::size_t>(iv), size,
                    centre_distance};
          }
        }
      }
    }
    for (int cu = 0; cu < result.cells_u; ++cu) {
      result.line[static_cast<std::size_t>(cu) + static_cast<std::size_t>(result.cells_u) * static_cast<std::size_t>(cv)] =
          choices[static_cast<std::size_t>(cu)].line;
    }
  }
  return result;
}

NearestSegment::NearestSegment(std::vector<Eigen::Vector3d> points_W_m, std::vector<bool> cutting)
    : points_(std::move(points_W_m)) {
  if (cutting.size() != points_.size()) throw std::invalid_argument("NearestSegment: one flag per point");
  double x1 = -std::numeric_limits<double>::infinity(), y1 = x1;
  x0_ = y0_ = std::numeric_limits<double>::infinity();
  for (std::size_t k = 1; k < points_.size(); ++k) {
    if (!cutting[k]) continue;
    segments_.push_back(static_cast<long>(k));
    for (const Eigen::Vector3d* p : {&points_[k - 1], &points_[k]}) {
      x0_ = std::min(x0_, p->x()), x1 = std::max(x1, p->x());
      y0_ = std::min(y0_, p->y()), y1 = std::max(y1, p->y());
    }
  }
  if (segments_.empty()) return;
  // About four segments a cell, at most 256 cells a side.
  const double width = std::max(x1 - x0_, 1e-6), height = std::max(y1 - y0_, 1e-6);
  const double cells_wanted = std::clamp(static_cast<double>(segments_.size()) / 4.0, 1.0, 65536.0);
  cell_m_ = std::max(std::sqrt(width * height / cells_wanted), std::max(width, height) / 256.0);
  cells_x_ = std::max(1, static_cast<int>(std::ceil(width / cell_m_)));
  cells_y_ = std::max(1, static_cast<int>(std::ceil(height / cell_m_)));
  cells_.resize(static_cast<std::size_t>(cells_x_) * static_cast<std::size_t>(cells_y_));
  cell_z_min_.assign(cells_.size(), std::numeric_limits<double>::infinity());
  cell_z_max_.assign(cells_.size(), -std::numeric_limits<double>::infinity());
  const auto cell_x = [this](double x) { return std::clamp(static_cast<int>((x - x0_) / cell_m_), 0, cells_x_ - 1); };
  const auto cell_y = [this](double y) { return std::clamp(static_cast<int>((y - y0_) / cell_m_), 0, cells_y_ - 1); };
  for (long k : segments_) {
    const Eigen::Vector3d& a = points_[static_cast<std::size_t>(k) - 1];
    const Eigen::Vector3d& b = points_[static_cast<std::size_t>(k)];
    for (int j = cell_y(std::min(a.y(), b.y())); j <= cell_y(std::max(a.y(), b.y())); ++j) {
      for (int i = cell_x(std::min(a.x(), b.x())); i <= cell_x(std::max(a.x(), b.x())); ++i) {
        const std::size_t cell = static_cast<std::size_t>(i) + static_cast<std::size_t>(cells_x_) * static_cast<std::size_t>(j);
        cells_[cell].push_back(k);
        cell_z_min_[cell] = std::min({cell_z_min_[cell], a.z(), b.z()});
        cell_z_max_[cell] = std::max({cell_z_max_[cell], a.z(), b.z()});
      }
    }
  }
}

long NearestSegment::nearest(const Eigen::Vector3d& point_W_m) const {
  if (segments_.empty()) return -1;
  const int ci = std::clamp(static_cast<int>(std::floor((point_W_m.x() - x0_) / cell_m_)), 0, cells_x_ - 1);
  const int cj = std::clamp(static_cast<int>(std::floor((point_W_m.y() - y0_) / cell_m_)), 0, cells_y_ - 1);
  long best = -1;
  double best_distance = std::numeric_limits<double>::infinity();
  const int rings = std::max(cells_x_, cells_y_);
  for (int r = 0; r <= rings; ++r) {
    // The point lies in its cell's row or column (clamped or not), so every cell of ring r is at
    // least (r - 1) cells away from it in x or in y.
    if (r >= 1 && (r - 1) * cell_m_ > best_distance) break;
    for (int j = cj - r; j <= cj + r; ++j) {
      if (j < 0 || j >= cells_y_) continue;
      const bool edge_row = j == cj - r || j == cj + r;
      for (int i = ci - r; i <= ci + r; i += (edge_row || r == 0) ? 1 : 2 * r) {
        if (i < 0 || i >= cells_x_) continue;
        const std::size_t cell = static_cast<std::size_t>(i) + static_cast<std::size_t>(cells_x_) * static_cast<std::size_t>(j);
        if (cells_[cell].empty()) continue;
        // The nearest point of a segment lies in a cell that lists it: this cell's box bounds it.
        const double dx = std::max({0.0, x0_ + i * cell_m_ - point_W_m.x(), point_W_m.x() - (x0_ + (i + 1) * cell_m_)});
        const double dy = std::max({0.0, y0_ + j * cell_m_ - point_W_m.y(), point_W_m.y() - (y0_ + (j + 1) * cell_m_)});
        const double dz = std::max({0.0, cell_z_min_[cell] - point_W_m.z(), point_W_m.z() - cell_z_max_[cell]});
        if (std::sqrt(dx * dx + dy * dy + dz * dz) > best_distance + 1e-12) continue;
        for (long k : cells_[cell]) {
          const double distance =
              segment_distance(point_W_m, points_[static_cast<std::size_t>(k) - 1], points_[static_cast<std::size_t>(k)]);
          if (distance < best_distance || (distance == best_distance && k < best)) {
            best_distance = distance;
            best = k;
          }
        }
      }
    }
  }
  return best;
}

std::string base64(const void* data, std::size_t bytes) {
  static constexpr char kDigits[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const auto* in = static_cast<const unsigned char*>(data);
  std::string out;
  out.reserve((bytes + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 3 <= bytes; i += 3) {
    const std::uint32_t v = (std::uint32_t{in[i]} << 16) | (std::uint32_t{in[i + 1]} << 8) | in[i + 2];
    out += kDigits[(v >> 18) & 63];
    out += kDigits[(v >> 12) & 63];
    out += kDigits[(v >> 6) & 63];
    out += kDigits[v & 63];
  }
  if (bytes - i == 1) {
    const std::uint32_t v = std::uint32_t{in[i]} << 16;
    out += kDigits[(v >> 18) & 63];
    out += kDigits[(v >> 12) & 63];
    out += "==";
  } else if (bytes - i == 2) {
    const std::uint32_t v = (std::uint32_t{in[i]} << 16) | (std::uint32_t{in[i + 1]} << 8);
    out += kDigits[(v >> 18) & 63];
    out += kDigits[(v >> 12) & 63];
    out += kDigits[(v >> 6) & 63];
    out += '=';
  }
  return out;
}

std::string deflated_base64(const void* data, std::size_t bytes) {
  uLongf size = compressBound(static_cast<uLong>(bytes));
  std::vector<unsigned char> packed(size);
  if (compress2(packed.data(), &size, static_cast<const Bytef*>(data), static_cast<uLong>(bytes), 9) != Z_OK) {
    throw std::runtime_error("zlib could not compress the 3-D view's data");
  }
  return base64(packed.data(), size);
}

View3dData view3d_data(const View3dInputs& inputs) {
  const MarkTable marks = mark_table(inputs.curated_marks);
  const NearestSegment path(inputs.path_centre_W_m, inputs.path_cutting);
  // Blocks named by the vertices, each once: [file, line, N number, text] (the sample names a
  // block every few vertices: compressed, its texts are a fifth of the data).
  Json blocks = Json::array();
  std::vector<std::string> files;
  std::map<int, std::uint32_t> block_entry;
  const auto entry_of = [&](int block) -> std::uint32_t {
    const auto found = block_entry.find(block);
    if (found != block_entry.end()) return found->second;
    const View3dBlock& source = inputs.blocks.at(static_cast<std::size_t>(block));
    const auto file = std::find(files.begin(), files.end(), source.file);
    const auto file_index = static_cast<long>(file - files.begin());
    if (file == files.end()) files.push_back(source.file);
    blocks.push_back(Json::array({file_index, source.line, source.number, source.text}));
    return block_entry[block] = static_cast<std::uint32_t>(blocks.size() - 1);
  };

  std::size_t all_lines = 0;
  for (const View3dInput& view : inputs.views) {
    all_lines += static_cast<std::size_t>(view.nu) * static_cast<std::size_t>(view.nv);
  }
  Json views = Json::array(), summary_views = Json::array();
  std::vector<std::vector<std::uint32_t>> vertex_blocks;
  std::size_t data_vertices = 0;
  for (const View3dInput& view : inputs.views) {
    const std::size_t lines = static_cast<std::size_t>(view.nu) * static_cast<std::size_t>(view.nv);
    // The budget is shared by line count; a small view keeps at least a few thousand vertices.
    const std::size_t budget = std::max<std::size_t>(
        std::min<std::size_t>({lines, 2000, inputs.max_vertices}),
        static_cast<std::size_t>(static_cast<double>(inputs.max_vertices) * static_cast<double>(lines) /
                                 static_cast<double>(std::max<std::size_t>(all_lines, 1))));
    const int cell_lines = cell_lines_for(view.nu, view.nv, std::max<std::size_t>(budget, 1));
    // Below the mark threshold a deviation is no mark: such cells keep their centre line, and the
    // mesh stays regular (and evenly shaded) where there is nothing to see.
    const WorstOfCells cells = keep_worst_of_cells(view.nu, view.nv, view.rows, cell_lines,
                                                   inputs.mark_threshold_um * 1e-6);

    std::vector<unsigned char> positions, deviations, mark_bytes;
    std::vector<std::uint32_t> block_index;
    double low = 0.0, high = 0.0;
    std::size_t kept = 0;
    for (std::size_t line : cells.line) {
      const float nan = std::numeric_limits<float>::quiet_NaN();
      if (line == kNone) {
        for (int c = 0; c < 3; ++c) append_bytes(positions, nan);
        append_bytes(deviations, nan);
        append_bytes(mark_bytes, std::int16_t{-1});
        block_index.push_back(0);
        continue;
      }
      ++kept;
      const int iu = static_cast<int>(line % static_cast<std::size_t>(view.nu));
      const int iv = static_cast<int>(line / static_cast<std::size_t>(view.nu));
      const Eigen::Vector3d point = view.surface_point_W_m(iu, iv);
      for (int c = 0; c < 3; ++c) append_bytes(positions, static_cast<float>(point[c] * 1e3));
      const double deviation_um = view.deviation_m_at(iu, iv) * 1e6;
      low = std::min(low, deviation_um);
      high = std::max(high, deviation_um);
      append_bytes(deviations, static_cast<float>(deviation_um));
      int mark = -1;
      const int label = view.mark_label_at ? view.mark_label_at(iu, iv) : -1;
      if (label >= 0) {
        const auto found = marks.index.find({view.id, label});
        if (found != marks.index.end()) mark = found->second;
      }
      append_bytes(mark_bytes, static_cast<std::int16_t>(mark));
      const long end = path.nearest(point);
      const int block = end >= 0 ? inputs.path_block[static_cast<std::size_t>(end)] : -1;
      block_index.push_back(block >= 0 && static_cast<std::size_t>(block) < inputs.blocks.size()
                                ? entry_of(block) + 1  // 0: no block
                                : 0);
    }
    data_vertices += cells.line.size();
    views.push_back({{"id", view.id},
                     {"title", view.title},
                     {"cells", {cells.cells_u, cells.cells_v}},
                     {"cell_lines", cells.cell_lines},
                     {"deviation_range_um", {low, high}},
                     {"positions_mm", encoded(positions)},
                     {"deviation_um", encoded(deviations)},
                     {"mark", encoded(mark_bytes)}});
    vertex_blocks.push_back(std::move(block_index));
    summary_views.push_back({{"id", view.id},
                             {"lines", lines},
                             {"cell_lines", cells.cell_lines},
                             {"vertices", kept}});
  }
  // Program lines per vertex: two bytes while the table allows it.
  const int block_bytes = blocks.size() + 1 <= 65535 ? 2 : 4;
  for (std::size_t v = 0; v < views.size(); ++v) {
    std::vector<unsigned char> bytes;
    for (std::uint32_t index : vertex_blocks[v]) {
      if (block_bytes == 2) {
        append_bytes(bytes, static_cast<std::uint16_t>(index));
      } else {
        append_bytes(bytes, index);
      }
    }
    views[v]["block"] = encoded(bytes);
    views[v]["block_bytes"] = block_bytes;
  }
  const std::string block_text = blocks.dump();
  Json data{{"format", 1},
            {"encoding", "arrays and blocks: zlib (RFC 1950), then base64; arrays little-endian"},
            {"threshold_um", inputs.mark_threshold_um},
            {"views", views},
            {"marks", marks.entries},
            {"files", files},
            {"blocks", deflated_base64(block_text.data(), block_text.size())}};
  View3dData result;
  result.script = "// vmsim: the report's 3-D view data (see report.html, section 3-D view).\n"
                  "window.vmsimDeviationMesh = " + data.dump() + ";\n";
  result.summary = {{"views", summary_views},
                    {"vertices", data_vertices},
                    {"max_vertices", inputs.max_vertices},
                    {"data_bytes", result.script.size()}};
  return result;
}

std::optional<std::filesystem::path> vtkjs_bundle() {
  std::filesystem::path bundle;
  if (const char* given = std::getenv("VMSIM_VTKJS"); given && *given) {
    bundle = given;
  } else {
    bundle = std::filesystem::path(VMSIM_WEB_DIR) / "node_modules" / "vtk.js" / "vtk.js";
  }
  std::error_code error;
  if (!std::filesystem::is_regular_file(bundle, error)) return std::nullopt;
  return bundle;
}

const std::string& view3d_script() {
  static const std::string script = kView3dScript;
  return script;
}

Json write_view3d(const std::filesystem::path& folder, const View3dInputs& inputs,
                  const std::optional<std::filesystem::path>& bundle) {
  if (!bundle) {
    return {{"available", false},
            {"reason",
             "the viewer library (vtk.js) was not installed when this report was written. To get the "
             "view: in vmsim's source folder run 'bash scripts/setup-web.sh' (it installs vtk.js with npm "
             "into viz/web), then run simulate-part again"}};
  }
  const std::filesystem::path folder_3d = folder / "3d";
  std::filesystem::create_directories(folder_3d);
  const View3dData data = view3d_data(inputs);
  const std::string library = read_file(bundle->string());
  write_file_atomically((folder_3d / "vtk.js").string(), library);
  write_file_atomically((folder_3d / "view3d.js").string(), view3d_script());
  write_file_atomically((folder_3d / "deviation_mesh.js").string(), data.script);
  Json summary = data.summary;
  summary["available"] = true;
  summary["files"] = {{"library", "3d/vtk.js"}, {"viewer", "3d/view3d.js"}, {"data", "3d/deviation_mesh.js"}};
  summary["library_bytes"] = library.size();
  summary["viewer_bytes"] = view3d_script().size();
  return summary;
}

}  // namespace vmsim::app
