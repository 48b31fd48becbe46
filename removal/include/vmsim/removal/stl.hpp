#pragma once
// Closed triangle meshes read from STL files: stock shapes for the N-buffer
// (NBuffer::zmap(const TriangleMesh&, spacing)). Frame W, SI (m) inside; files in mm unless a
// unit is given.
#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "vmsim/removal/tool.hpp"

namespace vmsim::removal {

/// A closed, consistently oriented triangle mesh (outward normals by the right-hand rule on
/// the vertex order). Vertices are shared (STL's repeated corners are welded when bit-equal).
struct TriangleMesh {
  std::vector<Eigen::Vector3d> vertices_m;   ///< [m], frame W
  std::vector<std::array<int, 3>> triangles;  ///< indices into vertices_m
  /// Where each triangle came from, for messages: the file's line of its "facet" (ASCII) or 0.
  std::vector<int> source_lines;

  Box bounds() const;   ///< bounding box [m]
  double volume_m3() const;  ///< signed volume (> 0 for outward normals)
};

/// Parses binary or ASCII STL bytes (`name` is the file name for messages), scales by unit_m
/// (1e-3: the file is in mm), welds bit-equal corners and checks the mesh is closed: every edge
/// shared by exactly two triangles that run it in opposite directions. A mesh whose normals all
/// point inwards (negative volume) is turned outwards. Throws vmsim::InputError naming the file
/// and the triangle (and line, for ASCII): truncated binary file, bad token, non-finite
/// coordinate, degenerate triangle, open or non-manifold edge, inconsistent orientation.
TriangleMesh parse_stl(const std::string& bytes, const std::string& name, double unit_m = 1e-3);

/// Reads and parses an STL file (see parse_stl).
TriangleMesh read_stl(const std::string& path, double unit_m = 1e-3);

/// Binary STL bytes of a mesh (mm if unit_m = 1e-3), e.g. for tests and exports.
std::string mesh_stl(const TriangleMesh& mesh, double unit_m = 1e-3);

/// Where a vertical line (x, y) crosses a closed mesh: the lowest entry and the highest exit
/// [m], and the number of crossings (2 for a line that passes through the solid once; 0 when it
/// misses). Crossings on shared edges and vertices count once (consistent tie-breaking).
struct VerticalCrossing {
  double z_entry_m = 0.0;
  double z_exit_m = 0.0;
  int crossings = 0;
};

/// Vertical lines on a grid x = x0 + i spacing (i < nx), y = y0 + j spacing (j < ny), against
/// a closed mesh: one VerticalCrossing per line, row-major (index = i + nx * j).
std::vector<VerticalCrossing> vertical_crossings(const TriangleMesh& mesh, double x0_m, double y0_m,
                                                 double spacing_m, int nx, int ny);

}  // namespace vmsim::removal
