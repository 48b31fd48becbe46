#include "vmsim/removal/stl.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <sstream>
#include <unordered_map>

#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"

namespace vmsim::removal {
namespace {

struct RawTriangle {
  std::array<Eigen::Vector3d, 3> p{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  int line = 0;  // ASCII: line of "facet"; binary: 0
};

std::string where(const std::string& name, std::size_t triangle, int line) {
  return located_message(name, line, 0, "triangle " + std::to_string(triangle + 1));
}

// The size a binary STL with the triangle count of its header has (bytes.size() >= 84).
bool binary_size_matches(const std::string& bytes) {
  std::uint32_t n = 0;
  std::memcpy(&n, bytes.data() + 80, 4);
  return 84 + 50ull * n == bytes.size();
}

bool looks_binary(const std::string& bytes) {
  if (bytes.size() < 84) return bytes.rfind("solid", 0) != 0;
  // Many binary files also start with "solid": the size decides.
  if (binary_size_matches(bytes)) return true;
  return bytes.rfind("solid", 0) != 0;
}

std::vector<RawTriangle> parse_binary(const std::string& bytes, const std::string& name) {
  if (bytes.size() < 84) {
    throw InputError(name + ": truncated binary STL: " + std::to_string(bytes.size()) +
                     " bytes, the header alone takes 84");
  }
  std::uint32_t n = 0;
  std::memcpy(&n, bytes.data() + 80, 4);
  const std::size_t need = 84 + 50ull * n;
  if (bytes.size() < need) {
    const std::size_t whole = (bytes.size() - 84) / 50;
    throw InputError(name + ": truncated binary STL: the header announces " + std::to_string(n) +
                     " triangles (" + std::to_string(need) + " bytes), the file has " +
                     std::to_string(bytes.size()) + " bytes: triangle " + std::to_string(whole + 1) +
                     " is incomplete");
  }
  std::vector<RawTriangle> out(n);
  for (std::size_t k = 0; k < n; ++k) {
    const char* record = bytes.data() + 84 + 50 * k + 12;  // skip the normal
    for (int v = 0; v < 3; ++v) {
      float xyz[3];
      std::memcpy(xyz, record + 12 * v, 12);
      out[k].p[v] = Eigen::Vector3d(xyz[0], xyz[1], xyz[2]);
    }
  }
  return out;
}

std::vector<RawTriangle> parse_ascii(const std::string& bytes, const std::string& name) {
  std::vector<RawTriangle> out;
  std::istringstream in(bytes);
  std::string text;
  int line = 0, facet_line = 0, corner = 0;
  bool in_facet = false, saw_solid = false, saw_end = false;
  auto fail = [&](const std::string& message) { throw InputError(located_message(name, line, 0, message)); };
  while (std::getline(in, text)) {
    ++line;
    std::istringstream words(text);
    std::string word;
    if (!(words >> word)) continue;
    if (word == "solid") {
      if (saw_solid) fail("a second \"solid\" (only one solid per file is read)");
      saw_solid = true;
    } else if (word == "facet") {
      if (in_facet) fail("\"facet\" inside a facet (missing \"endfacet\")");
      in_facet = true;
      facet_line = line;
      corner = 0;
      out.emplace_back();
      out.back().line = line;
    } else if (word == "vertex") {
      if (!in_facet) fail("\"vertex\" outside a facet");
      if (corner == 3) fail("a fourth vertex in triangle " + std::to_string(out.size()));
      std::string xyz[3];
      if (!(words >> xyz[0] >> xyz[1] >> xyz[2])) fail("\"vertex\" needs three coordinates");
      for (int i = 0; i < 3; ++i) {
        double value = 0.0;
        std::size_t used = 0;
        try {
          value = std::stod(xyz[i], &used);
        } catch (const std::exception&) {
          used = 0;
        }
        if (used != xyz[i].size()) fail("vertex coordinate \"" + xyz[i] + "\" is not a number");
        if (!std::isfinite(value)) fail("vertex coordinate " + xyz[i] + " is not finite");
        out.back().p[corner][i] = value;
      }
      ++corner;
    } else if (word == "endfacet") {
      if (!in_facet) fail("\"endfacet\" without \"facet\"");
      if (corner != 3) {
        fail("triangle " + std::to_string(out.size()) + " (facet at line " + std::to_string(facet_line) +
             ") has " + std::to_string(corner) + " vertices, needs 3");
      }
      in_facet = false;
    } else if (word == "endsolid") {
      saw_end = true;
      break;
    } else if (word != "outer" && word != "endloop") {
      fail("unexpected \"" + word + "\" in an ASCII STL");
    }
  }
  if (in_facet) fail("the file ends inside a facet (truncated?)");
  if (!saw_end) fail("no \"endsolid\": the file is truncated");
  return out;
}

struct VertexKey {
  double x, y, z;
  bool operator==(const VertexKey& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct VertexHash {
  std::size_t operator()(const VertexKey& k) const {
    const std::hash<double> h;
    return h(k.x) ^ (h(k.y) * 0x9e3779b97f4a7c15ull) ^ (h(k.z) * 0xc2b2ae3d27d4eb4full);
  }
};

std::string point_mm(const Eigen::Vector3d& p, double unit_m) {
  return "(" + format_double(p.x() / unit_m) + ", " + format_double(p.y() / unit_m) + ", " +
         format_double(p.z() / unit_m) + ")";
}

}  // namespace

Box TriangleMesh::bounds() const {
  Box b{Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()),
        Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity())};
  for (const Eigen::Vector3d& v : vertices_m) {
    b.min_W_m = b.min_W_m.cwiseMin(v);
    b.max_W_m = b.max_W_m.cwiseMax(v);
  }
  return b;
}

double TriangleMesh::volume_m3() const {
  if (vertices_m.empty()) return 0.0;
  const Eigen::Vector3d ref = vertices_m.front();  // near the mesh: less cancellation than 0
  double six_v = 0.0;
  for (const auto& t : triangles) {
    six_v += (vertices_m[t[0]] - ref).dot((vertices_m[t[1]] - ref).cross(vertices_m[t[2]] - ref));
  }
  return six_v / 6.0;
}

TriangleMesh parse_stl(const std::string& bytes, const std::string& name, double unit_m) {
  // A UTF-8 byte-order mark can only start an ASCII STL (as in every text reader, it is
  // skipped); a binary STL's 80-byte header may start with anything and is left alone.
  const std::string_view unmarked = strip_utf8_bom(bytes);
  const bool ascii_after_mark = unmarked.size() != bytes.size() && unmarked.substr(0, 5) == "solid" &&
                                !(bytes.size() >= 84 && binary_size_matches(bytes));
  const bool binary = !ascii_after_mark && looks_binary(bytes);
  const std::vector<RawTriangle> raw =
      binary ? parse_binary(bytes, name)
             : parse_ascii(ascii_after_mark ? std::string(unmarked) : bytes, name);
  if (raw.empty()) throw InputError(name + ": the STL holds no triangle");
  TriangleMesh mesh;
  std::unordered_map<VertexKey, int, VertexHash> ids;
  for (std::size_t k = 0; k < raw.size(); ++k) {
    std::array<int, 3> tri{};
    for (int v = 0; v < 3; ++v) {
      const Eigen::Vector3d p = raw[k].p[v] * unit_m;
      if (!p.allFinite()) {
        throw InputError(where(name, k, raw[k].line) + ": vertex " + std::to_string(v + 1) +
                         " has a non-finite coordinate (NaN or infinity)");
      }
      const auto [it, added] = ids.emplace(VertexKey{p.x(), p.y(), p.z()}, static_cast<int>(mesh.vertices_m.size()));
      if (added) mesh.vertices_m.push_back(p);
      tri[v] = it->second;
    }
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2]) {
      throw InputError(where(name, k, raw[k].line) + ": degenerate (two corners coincide at " +
                       point_mm(raw[k].p[tri[0] == tri[1] || tri[0] == tri[2] ? 0 : 1] * unit_m, unit_m) + ")");
    }
    mesh.triangles.push_back(tri);
    mesh.source_lines.push_back(raw[k].line);
  }
  // Closed and consistently oriented: every directed edge once, and its reverse once.
  std::map<std::pair<int, int>, std::pair<int, std::size_t>> edges;  // directed edge -> (uses, first triangle)
  for (std::size_t k = 0; k < mesh.triangles.size(); ++k) {
    const auto& t = mesh.triangles[k];
    for (int e = 0; e < 3; ++e) {
      auto& entry = edges[{t[e], t[(e + 1) % 3]}];
      if (entry.first++ > 0) {
        throw InputError(where(name, k, mesh.source_lines[k]) + ": edge " +
                         point_mm(mesh.vertices_m[t[e]], unit_m) + "-" +
                         point_mm(mesh.vertices_m[t[(e + 1) % 3]], unit_m) + " runs the same way as in triangle " +
                         std::to_string(entry.second + 1) +
                         ": the mesh is not consistently oriented or an edge has more than two triangles");
      }
      entry.second = k;
    }
  }
  for (const auto& [edge, use] : edges) {
    if (edges.find({edge.second, edge.first}) == edges.end()) {
      const std::size_t k = use.second;
      throw InputError(where(name, k, mesh.source_lines[k]) + ": edge " + point_mm(mesh.vertices_m[edge.first], unit_m) +
                       "-" + point_mm(mesh.vertices_m[edge.second], unit_m) +
                       " belongs to this triangle only: the mesh is not closed");
    }
  }
  if (mesh.volume_m3() < 0.0) {
    for (auto& t : mesh.triangles) std::swap(t[1], t[2]);
  }
  return mesh;
}

TriangleMesh read_stl(const std::string& path, double unit_m) { return parse_stl(read_file(path), path, unit_m); }

std::string mesh_stl(const TriangleMesh& mesh, double unit_m) {
  std::string out(80, '\0');
  const std::string header = "vmsim mesh";
  std::copy(header.begin(), header.end(), out.begin());
  const auto n = static_cast<std::uint32_t>(mesh.triangles.size());
  out.append(reinterpret_cast<const char*>(&n), 4);
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d& a = mesh.vertices_m[t[0]];
    const Eigen::Vector3d normal = (mesh.vertices_m[t[1]] - a).cross(mesh.vertices_m[t[2]] - a).normalized();
    float record[12];
    for (int i = 0; i < 3; ++i) record[i] = static_cast<float>(normal[i]);
    for (int v = 0; v < 3; ++v) {
      for (int i = 0; i < 3; ++i) record[3 + 3 * v + i] = static_cast<float>(mesh.vertices_m[t[v]][i] / unit_m);
    }
    out.append(reinterpret_cast<const char*>(record), sizeof record);
    out.append(2, '\0');
  }
  return out;
}

namespace {

// Edge function of (px, py) against the edge a -> b in the plane, computed with the endpoints
// in a canonical (lexicographic) order so that the two triangles sharing an edge get exactly
// opposite values; a zero is broken by a symbolic perturbation of the point (simulation of
// simplicity), so that a line through an edge or a vertex crosses the surface exactly once.
double edge_function(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double px, double py) {
  const bool flip = std::make_pair(b.x(), b.y()) < std::make_pair(a.x(), a.y());
  const Eigen::Vector3d& p = flip ? b : a;
  const Eigen::Vector3d& q = flip ? a : b;
  double e = (q.x() - p.x()) * (py - p.y()) - (q.y() - p.y()) * (px - p.x());
  if (e == 0.0) e = q.y() != p.y() ? std::copysign(1e-300, p.y() - q.y()) : 1e-300;  // the perturbation's sign
  return flip ? -e : e;
}

}  // namespace

std::vector<VerticalCrossing> vertical_crossings(const TriangleMesh& mesh, double x0_m, double y0_m,
                                                 double spacing_m, int nx, int ny) {
  std::vector<VerticalCrossing> out(static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny));
  for (auto& c : out) {
    c.z_entry_m = std::numeric_limits<double>::infinity();
    c.z_exit_m = -std::numeric_limits<double>::infinity();
  }
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d& a = mesh.vertices_m[t[0]];
    const Eigen::Vector3d& b = mesh.vertices_m[t[1]];
    const Eigen::Vector3d& c = mesh.vertices_m[t[2]];
    const double xmin = std::min({a.x(), b.x(), c.x()}), xmax = std::max({a.x(), b.x(), c.x()});
    const double ymin = std::min({a.y(), b.y(), c.y()}), ymax = std::max({a.y(), b.y(), c.y()});
    const int i0 = std::max(0, static_cast<int>(std::floor((xmin - x0_m) / spacing_m)));
    const int i1 = std::min(nx - 1, static_cast<int>(std::ceil((xmax - x0_m) / spacing_m)));
    const int j0 = std::max(0, static_cast<int>(std::floor((ymin - y0_m) / spacing_m)));
    const int j1 = std::min(ny - 1, static_cast<int>(std::ceil((ymax - y0_m) / spacing_m)));
    for (int j = j0; j <= j1; ++j) {
      const double y = y0_m + j * spacing_m;
      for (int i = i0; i <= i1; ++i) {
        const double x = x0_m + i * spacing_m;
        const double wa = edge_function(b, c, x, y), wb = edge_function(c, a, x, y), wc = edge_function(a, b, x, y);
        const bool up = wa > 0.0 && wb > 0.0 && wc > 0.0;  // counter-clockwise seen from above
        if (!up && !(wa < 0.0 && wb < 0.0 && wc < 0.0)) continue;
        // Height on the triangle's plane by barycentric weights (all of one sign: no cancellation).
        const double z = (wa * a.z() + wb * b.z() + wc * c.z()) / (wa + wb + wc);
        VerticalCrossing& v = out[static_cast<std::size_t>(i) + static_cast<std::size_t>(nx) * j];
        ++v.crossings;
        // Outward normal up: the line leaves the solid here; down: it enters.
        if (up) v.z_exit_m = std::max(v.z_exit_m, z);
        else v.z_entry_m = std::min(v.z_entry_m, z);
      }
    }
  }
  for (auto& c : out) {
    if (c.crossings == 0) c.z_entry_m = c.z_exit_m = 0.0;
  }
  return out;
}

}  // namespace vmsim::removal
