#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>

#include "vmsim/common/errors.hpp"
#include "vmsim/toolpath/heidenhain_reader.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath {
namespace {

/// A Siemens program under an ISO extension, told by what no ISO program holds: the 840D's
/// `%_N_NAME_MPF` header or a CYCLE832 / CYCLE800 call in the first 64 KiB.
bool looks_like_siemens(const std::string& path) {
  // Only a regular file is looked into (a FIFO would block here; the reader refuses it).
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) return false;
  std::ifstream in(path, std::ios::binary);
  std::string head(64 * 1024, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(in.gcount()));
  std::transform(head.begin(), head.end(), head.begin(),
                 [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  return head.find("%_N_") != std::string::npos || head.find("CYCLE832(") != std::string::npos ||
         head.find("CYCLE800(") != std::string::npos;
}

}  // namespace

Toolpath read_toolpath(const std::string& path, const ReaderOptions& options) {
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension == ".apt" || extension == ".cl" || extension == ".cls") {
    return read_apt(path, options);
  }
  if (extension == ".mpf" || extension == ".spf") return read_siemens(path, options);
  // .ptp: NX Post Builder's default; .eia .cnc: other posts' names for ISO programs.
  if (extension == ".nc" || extension == ".ngc" || extension == ".gcode" || extension == ".tap" ||
      extension == ".iso" || extension == ".ptp" || extension == ".eia" || extension == ".cnc") {
    if (looks_like_siemens(path)) return read_siemens(path, options);
    return read_gcode(path, options);
  }
  // .h: Heidenhain TNC conversational (Klartext) programs.
  if (extension == ".h") return read_heidenhain(path, options);
  if (extension == ".src") return read_krl(path, options);  // KUKA KRL
  throw InputError(located_message(
      path, 0, 0,
      "unknown tool path extension '" + extension +
          "': use .apt/.cl/.cls for APT/CL, .mpf/.spf for Siemens 840D, .h for Heidenhain TNC conversational, .src for KUKA KRL or .nc/.ngc/.gcode/.tap/.iso/.ptp/.eia/.cnc for G-code"));
}

}  // namespace vmsim::toolpath
