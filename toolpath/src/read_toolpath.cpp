#include <algorithm>
#include <cctype>
#include <filesystem>

#include "vmsim/common/errors.hpp"
#include "vmsim/toolpath/heidenhain_reader.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath {

Toolpath read_toolpath(const std::string& path, const ReaderOptions& options) {
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension == ".apt" || extension == ".cl" || extension == ".cls") {
    return read_apt(path, options);
  }
  // .ptp: NX Post Builder's default; .eia .cnc: other posts' names for ISO programs.
  if (extension == ".nc" || extension == ".ngc" || extension == ".gcode" || extension == ".mpf" ||
      extension == ".tap" || extension == ".iso" || extension == ".ptp" || extension == ".eia" ||
      extension == ".cnc") {
    return read_gcode(path, options);
  }
  // .h: Heidenhain TNC conversational (Klartext) programs.
  if (extension == ".h") return read_heidenhain(path, options);
  throw InputError(located_message(
      path, 0, 0,
      "unknown tool path extension '" + extension +
          "': use .apt/.cl/.cls for APT/CL or .nc/.ngc/.gcode/.mpf/.tap/.iso/.ptp/.eia/.cnc for G-code or .h for Heidenhain TNC conversational"));
}

}  // namespace vmsim::toolpath
