#pragma once
// File contents for an N-buffer's results. The functions return the bytes; the caller writes
// them (vmsim::write_file_atomically), so a failed run leaves no half-written file.
#include <cstddef>
#include <iosfwd>
#include <string>
#include <vector>

#include "vmsim/removal/nbuffer.hpp"

namespace vmsim::removal {

/// Text grid, mm. Z-map: a comment line "# vmsim zmap nx=.. ny=.. x0_mm=.. y0_mm=.. z0_mm=..
/// spacing_mm=.." then ny rows (y increasing) of nx heights z_mm (x increasing), comma
/// separated, shortest round-trip decimals. General buffers: a header
/// "x_mm,y_mm,z_mm,ux,uy,uz,length_mm" and one row per line (surface point, direction, length).
/// `values` (optional, row-major like NBuffer::lengths(), in m) replaces the heights, e.g. a
/// run-versus-run difference (then written in mm, Z-map layout only).
std::string heights_csv(const NBuffer& buffer, const std::vector<double>* values = nullptr);

/// Binary grid, little-endian: "VMSIMNB1", int32 nu, int32 nv, int32 zmap (1/0), 4 doubles
/// x0, y0, z0, spacing [m] (zeros for general buffers), nu*nv doubles: lengths [m], row-major
/// (index = iu + nu * iv); general buffers then nu*nv origins and nu*nv directions (3 doubles
/// each). The height of a Z-map line is z0 + length. For the viz module (.vtp).
std::string heights_binary(const NBuffer& buffer);

/// The bytes of heights_binary written to `out` row by row (O(nu) memory: for views too large
/// to hold the file whole, e.g. through vmsim::write_file_atomically's streamed form).
void write_heights_binary(const NBuffer& buffer, std::ostream& out);

/// Binary STL of the machined surface (surface points o + h u, two triangles per grid cell),
/// taking every `stride`-th line in both directions (1 = all). Frame W, millimetres.
std::string surface_stl(const NBuffer& buffer, int stride = 1);

/// The stride that keeps surface_stl under max_triangles.
int stl_stride_for(const NBuffer& buffer, std::size_t max_triangles);

}  // namespace vmsim::removal
