#include <algorithm>
#include <cctype>
#include <filesystem>

#include "vmsim/common/errors.hpp"
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
  if (extension == ".src") return read_krl(path, options);  // KUKA KRL
  throw InputError(located_message(
      path, 0, 0,
      "unknown tool path extension '" + extension +
          "': use .apt/.cl/.cls for APT/CL or .nc/.ngc/.gcode/.mpf/.tap/.iso/.ptp/.eia/.cnc for G-code, .src for KUKA KRL"));
}

}  // namespace vmsim::toolpath
