#pragma once
// The report's interactive 3-D view (report.html, section "3-D view"): each surface view's
// production surface, decimated, coloured by its deviation from the reference surface, shown in
// the browser with vtk.js (rotate, zoom, pick a point: its deviation, position and program line).
// It works offline from the result folder alone. Files, in the folder's 3d/:
//  - vtk.js: the library's browser build (UMD), copied from where scripts/setup-web.sh installed
//    it (npm, viz/web/); absent there: no 3-D view, the page says how to get it;
//  - view3d.js: vmsim's viewer (viz/web/view3d.js, built into the program);
//  - deviation_mesh.js: the data, a script that sets one global (a page opened from file://
//    cannot fetch a JSON file beside it); its arrays and program lines compressed (zlib) and
//    base64-encoded, unpacked in the browser (DecompressionStream).
// Decimation: each view's grid of lines is cut into square cells of cell_lines x cell_lines
// lines, and each cell keeps its line of largest |deviation| (its own surface point, not the
// cell's centre), so a mark never vanishes and its deepest line stays where it is; cells with
// nothing beyond the mark threshold keep their centre line (the mesh stays regular there).
#include <Eigen/Core>
#include <cstddef>
#include <filesystem>
#include <cstdint>
#include <functional>
#include <span>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace vmsim::app {

/// Vertices of all views together at most: 20 bytes each (position, deviation, mark, program
/// line), about 8 once compressed (zlib) and base64-encoded; with the program lines they name,
/// about 1.3 MB of data for sample part 1.
inline constexpr std::size_t kView3dMaxVertices = 120000;

/// The decimated grid of one view.
struct WorstOfCells {
  int cells_u = 0, cells_v = 0;
  int cell_lines = 1;             ///< lines per cell side
  std::vector<std::size_t> line;  ///< per cell (cu + cells_u * cv): the line kept (iu + nu * iv)
};

/// The smallest cell side (in lines) that leaves at most max_cells cells on an nu x nv grid.
int cell_lines_for(int nu, int nv, std::size_t max_cells);

/// Cells of cell_lines x cell_lines lines (the last row and column may be narrower), each
/// keeping the line of largest |deviation_m| among those `usable` (nullptr: all), a deviation
/// of at most `significant_m` counting as 0; on ties the line nearest the cell's centre. A cell
/// without a usable line keeps none (line = SIZE_MAX). Throws std::invalid_argument on a size
/// mismatch or cell_lines < 1.
WorstOfCells keep_worst_of_cells(int nu, int nv, const std::vector<double>& deviation_m, int cell_lines,
                                 const std::vector<bool>* usable = nullptr, double significant_m = 0.0);

/// A view's rows, for views too large to hold whole: fills row iv's deviations [m] and usable
/// flags (1: usable), nu of each. Called with iv = 0, 1, ... in order.
using ViewRowReader = std::function<void(int iv, std::span<double> deviation_m, std::span<std::uint8_t> usable)>;

/// The same cells, the rows read one at a time (one row and one cell row's choices held).
WorstOfCells keep_worst_of_cells(int nu, int nv, const ViewRowReader& rows, int cell_lines,
                                 double significant_m = 0.0);

/// The programmed path as segments, for "the nearest path point" of a picked point: segment k
/// runs from point k-1 to point k (the motion of block block[k]). Points are where the tool's
/// corner centre is (tip + corner radius along the axis: on a ball end the distance from it to a
/// point the tool cut is the radius, whatever the slope), in W [m].
class NearestSegment {
 public:
  /// `cutting[k]`: the motion ending at point k is a cut (rapids never count).
  NearestSegment(std::vector<Eigen::Vector3d> points_W_m, std::vector<bool> cutting);
  /// The end point index k of the cutting segment nearest `point_W_m` (3-D distance), or -1
  /// when there is none.
  long nearest(const Eigen::Vector3d& point_W_m) const;

 private:
  std::vector<Eigen::Vector3d> points_;
  std::vector<long> segments_;  ///< end point indices of the cutting segments
  // A uniform grid in x, y over the segments' bounds: each cell lists the segments whose box
  // meets it, and the z range of those boxes; a query searches rings of cells outwards until no
  // nearer segment can be found, and skips a cell whose box (x, y of the cell, its z range) is
  // further than the nearest segment found (a ball's centre path runs a radius above the
  // surface: without it every query would test every segment within a radius).
  double x0_ = 0.0, y0_ = 0.0, cell_m_ = 1.0;
  int cells_x_ = 0, cells_y_ = 0;
  std::vector<std::vector<long>> cells_;
  std::vector<double> cell_z_min_, cell_z_max_;
};

/// `bytes` as base64 (RFC 4648, with padding).
std::string base64(const void* data, std::size_t bytes);

/// `bytes` compressed in the zlib format (RFC 1950: what a browser's
/// DecompressionStream("deflate") reads), then base64.
std::string deflated_base64(const void* data, std::size_t bytes);

/// One surface view, as simulate-part holds it.
struct View3dInput {
  std::string id, title;
  int nu = 0, nv = 0;
  std::function<Eigen::Vector3d(int iu, int iv)> surface_point_W_m;  ///< production surface
  /// Production minus reference [m] of line (iu, iv).
  std::function<double(int iu, int iv)> deviation_m_at;
  /// The rows in order: deviations (as deviation_m_at) and usable = 1 where the stock reached.
  ViewRowReader rows;
  /// The view's mark index of line (iu, iv), or -1; empty: no marks.
  std::function<int(int iu, int iv)> mark_label_at;
};

/// A program block, as the marks table shows it.
struct View3dBlock {
  std::string file;  ///< file name, no folder
  int line = 0;
  long number = -1;  ///< N number, -1: none
  std::string text;  ///< as written
};

/// What the 3-D view needs besides the views.
struct View3dInputs {
  std::vector<View3dInput> views;
  /// The programmed path: per point, where the corner centre is [W, m], its block (-1: none),
  /// whether the motion ending there cuts.
  std::vector<Eigen::Vector3d> path_centre_W_m;
  std::vector<int> path_block;
  std::vector<bool> path_cutting;
  std::vector<View3dBlock> blocks;  ///< by block index
  /// The curated marks (report_marks.hpp: {"marks": [...], "specks": {"list": [...]}}); each
  /// entry's "view" and "view_mark_index" place it.
  nlohmann::json curated_marks;
  double mark_threshold_um = 0.0;
  std::size_t max_vertices = kView3dMaxVertices;
};

/// The data script's text (deviation_mesh.js) and its summary for report.json's "view_3d":
/// per view its cells, lines per cell and vertices; bytes of data.
struct View3dData {
  std::string script;
  nlohmann::json summary;
};
View3dData view3d_data(const View3dInputs& inputs);

/// The vtk.js browser build: $VMSIM_VTKJS when set (a file), else where scripts/setup-web.sh
/// installs it (viz/web/node_modules/vtk.js/vtk.js in the source tree vmsim was built from);
/// nullopt when not there.
std::optional<std::filesystem::path> vtkjs_bundle();

/// The viewer script (viz/web/view3d.js).
const std::string& view3d_script();

/// Writes folder/3d/ (vtk.js copied from `bundle`, view3d.js, deviation_mesh.js) and returns
/// report.json's "view_3d": {"available": true, "files", "bytes", "views": [...]} ; without a
/// bundle writes nothing and returns {"available": false, "reason"}.
nlohmann::json write_view3d(const std::filesystem::path& folder, const View3dInputs& inputs,
                            const std::optional<std::filesystem::path>& bundle);

}  // namespace vmsim::app
