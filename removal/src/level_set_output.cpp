// The .vtp file of a triangle mesh (level_set.hpp); kept apart from level_set.cpp (OpenVDB).

#include "vmsim/common/files.hpp"
#include "vmsim/removal/level_set.hpp"

namespace vmsim::removal {

std::string mesh_vtp(const TriangleMesh& mesh, const std::vector<double>* point_values, const std::string& values_name) {
  const std::size_t np = mesh.vertices_m.size(), nt = mesh.triangles.size();
  std::string out = "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
                    "<PolyData>\n<Piece NumberOfPoints=\"" + std::to_string(np) + "\" NumberOfPolys=\"" +
                    std::to_string(nt) + "\">\n";
  if (point_values && point_values->size() == np) {
    out += "<PointData Scalars=\"" + values_name + "\">\n<DataArray type=\"Float64\" Name=\"" + values_name +
           "\" format=\"ascii\">\n";
    for (double v : *point_values) out += format_double(v) + '\n';
    out += "</DataArray>\n</PointData>\n";
  }
  out += "<Points>\n<DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">\n";
  for (const auto& p : mesh.vertices_m) {
    out += format_double(p.x()) + ' ' + format_double(p.y()) + ' ' + format_double(p.z()) + '\n';
  }
  out += "</DataArray>\n</Points>\n<Polys>\n<DataArray type=\"Int64\" Name=\"connectivity\" format=\"ascii\">\n";
  for (const auto& t : mesh.triangles) {
    out += std::to_string(t[0]) + ' ' + std::to_string(t[1]) + ' ' + std::to_string(t[2]) + '\n';
  }
  out += "</DataArray>\n<DataArray type=\"Int64\" Name=\"offsets\" format=\"ascii\">\n";
  for (std::size_t i = 0; i < nt; ++i) out += std::to_string(3 * (i + 1)) + '\n';
  out += "</DataArray>\n</Polys>\n</Piece>\n</PolyData>\n</VTKFile>\n";
  return out;
}

}  // namespace vmsim::removal
