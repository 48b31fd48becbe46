#include "vmsim/removal/output.hpp"

#include <Eigen/Geometry>
#include <algorithm>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <ostream>

#include "vmsim/common/files.hpp"

namespace vmsim::removal {
namespace {

template <class T>
void put(std::string& out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  out.append(bytes, sizeof(T));
}

}  // namespace

std::string heights_csv(const NBuffer& b, const std::vector<double>* values) {
  std::string out;
  auto value = [&](int iu, int iv) {
    if (values) return (*values)[static_cast<std::size_t>(iu) + static_cast<std::size_t>(b.nu()) * iv];
    return b.zmap_origin_m().z() + b.length(iu, iv);
  };
  if (b.is_zmap() || values) {
    const Eigen::Vector3d o = b.zmap_origin_m();
    out += "# vmsim zmap nx=" + std::to_string(b.nu()) + " ny=" + std::to_string(b.nv()) +
           " x0_mm=" + format_double(o.x() * 1e3) + " y0_mm=" + format_double(o.y() * 1e3) +
           " z0_mm=" + format_double(o.z() * 1e3) + " spacing_mm=" + format_double(b.spacing_m() * 1e3) +
           (values ? " values=difference_mm\n" : " values=z_mm\n");
    for (int iv = 0; iv < b.nv(); ++iv) {
      for (int iu = 0; iu < b.nu(); ++iu) {
        if (iu) out += ',';
        out += format_double(value(iu, iv) * 1e3);
      }
      out += '\n';
    }
    return out;
  }
  out += "x_mm,y_mm,z_mm,ux,uy,uz,length_mm\n";
  for (int iv = 0; iv < b.nv(); ++iv) {
    for (int iu = 0; iu < b.nu(); ++iu) {
      const Eigen::Vector3d p = b.surface_point(iu, iv), u = b.direction(iu, iv);
      out += format_double(p.x() * 1e3) + ',' + format_double(p.y() * 1e3) + ',' + format_double(p.z() * 1e3) +
             ',' + format_double(u.x()) + ',' + format_double(u.y()) + ',' + format_double(u.z()) + ',' +
             format_double(b.length(iu, iv) * 1e3) + '\n';
    }
  }
  return out;
}

std::string heights_binary(const NBuffer& b) {
  // Sized once and filled line by line: no copy of the lengths, no doubling of the string (the
  // writing of the surfaces held about three times the file in memory).
  const std::size_t lines = b.line_count();
  std::string out;
  out.reserve(8 + 3 * 4 + 4 * 8 + lines * 8 * (b.is_zmap() ? 1 : 7));
  out += "VMSIMNB1";
  put<std::int32_t>(out, b.nu());
  put<std::int32_t>(out, b.nv());
  put<std::int32_t>(out, b.is_zmap() ? 1 : 0);
  const Eigen::Vector3d o = b.is_zmap() ? b.zmap_origin_m() : Eigen::Vector3d::Zero();
  put(out, o.x());
  put(out, o.y());
  put(out, o.z());
  put(out, b.is_zmap() ? b.spacing_m() : 0.0);
  for (int iv = 0; iv < b.nv(); ++iv) {
    for (int iu = 0; iu < b.nu(); ++iu) put(out, b.length(iu, iv));
  }
  if (!b.is_zmap()) {
    for (int pass = 0; pass < 2; ++pass) {
      for (int iv = 0; iv < b.nv(); ++iv) {
        for (int iu = 0; iu < b.nu(); ++iu) {
          const Eigen::Vector3d v = pass == 0 ? b.origin(iu, iv) : b.direction(iu, iv);
          put(out, v.x());
          put(out, v.y());
          put(out, v.z());
        }
      }
    }
  }
  return out;
}

void write_heights_binary(const NBuffer& b, std::ostream& out) {
  std::string piece = "VMSIMNB1";
  put<std::int32_t>(piece, b.nu());
  put<std::int32_t>(piece, b.nv());
  put<std::int32_t>(piece, b.is_zmap() ? 1 : 0);
  const Eigen::Vector3d o = b.is_zmap() ? b.zmap_origin_m() : Eigen::Vector3d::Zero();
  put(piece, o.x());
  put(piece, o.y());
  put(piece, o.z());
  put(piece, b.is_zmap() ? b.spacing_m() : 0.0);
  out.write(piece.data(), static_cast<std::streamsize>(piece.size()));
  // One row at a time.
  auto write_rows = [&](const auto& put_line) {
    for (int iv = 0; iv < b.nv(); ++iv) {
      piece.clear();
      for (int iu = 0; iu < b.nu(); ++iu) put_line(iu, iv);
      out.write(piece.data(), static_cast<std::streamsize>(piece.size()));
    }
  };
  write_rows([&](int iu, int iv) { put(piece, b.length(iu, iv)); });
  if (b.is_zmap()) return;
  auto put_vector = [&](const Eigen::Vector3d& v) {
    put(piece, v.x());
    put(piece, v.y());
    put(piece, v.z());
  };
  write_rows([&](int iu, int iv) { put_vector(b.origin(iu, iv)); });
  write_rows([&](int iu, int iv) { put_vector(b.direction(iu, iv)); });
}

int stl_stride_for(const NBuffer& b, std::size_t max_triangles) {
  int stride = 1;
  while (true) {
    const std::size_t cu = static_cast<std::size_t>((b.nu() - 1) / stride), cv = static_cast<std::size_t>((b.nv() - 1) / stride);
    if (2 * cu * cv <= max_triangles || stride > b.nu() || stride > b.nv()) return stride;
    ++stride;
  }
}

std::string surface_stl(const NBuffer& b, int stride) {
  stride = std::max(1, stride);
  const int cu = (b.nu() - 1) / stride, cv = (b.nv() - 1) / stride;
  const std::uint32_t count = static_cast<std::uint32_t>(2 * std::max(0, cu) * std::max(0, cv));
  std::string out(80, ' ');
  std::memcpy(out.data(), "vmsim removal: machined surface, mm", 35);
  put(out, count);
  out.reserve(out.size() + count * 50u);
  auto vertex = [&](const Eigen::Vector3d& p) {
    put(out, static_cast<float>(p.x() * 1e3));
    put(out, static_cast<float>(p.y() * 1e3));
    put(out, static_cast<float>(p.z() * 1e3));
  };
  auto triangle = [&](const Eigen::Vector3d& a, const Eigen::Vector3d& c, const Eigen::Vector3d& d) {
    Eigen::Vector3d n = (c - a).cross(d - a);
    if (n.norm() > 0.0) n.normalize();
    put(out, static_cast<float>(n.x()));
    put(out, static_cast<float>(n.y()));
    put(out, static_cast<float>(n.z()));
    vertex(a), vertex(c), vertex(d);
    put<std::uint16_t>(out, 0);
  };
  for (int jv = 0; jv < cv; ++jv) {
    for (int ju = 0; ju < cu; ++ju) {
      const int u0 = ju * stride, u1 = u0 + stride, v0 = jv * stride, v1 = v0 + stride;
      const Eigen::Vector3d p00 = b.surface_point(u0, v0), p10 = b.surface_point(u1, v0);
      const Eigen::Vector3d p01 = b.surface_point(u0, v1), p11 = b.surface_point(u1, v1);
      triangle(p00, p10, p11);
      triangle(p00, p11, p01);
    }
  }
  return out;
}

}  // namespace vmsim::removal
