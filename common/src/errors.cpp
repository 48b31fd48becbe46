#include "vmsim/common/errors.hpp"

#include <sstream>

namespace vmsim {

std::string located_message(const std::string& file, int line, int column,
                            const std::string& message) {
  // A stream rather than string concatenation: g++ 12 reports a false -Wrestrict on the latter.
  std::ostringstream where;
  where << file;
  if (line > 0) {
    where << ':' << line;
    if (column > 0) where << ':' << column;
  }
  where << ": " << message;
  return where.str();
}

}  // namespace vmsim
