// The display check: Xlib directly, so that no VTK window (whose creation aborts without a
// display) exists before it has passed.
//
// The connection that passed the check stays open for the life of the process. An X server
// started without -noreset (xvfb-run's default) resets when its last client disconnects and
// refuses connections for a moment while it does: closing the check's connection made the
// next XOpenDisplay fail now and then, and VTK's own XOpenDisplay right after the check could
// have failed the same way, which aborts the process. Holding one connection prevents resets.
#include "vmsim/viz/display.hpp"

#include <X11/Xlib.h>

#include <cstdlib>
#include <map>
#include <mutex>

namespace vmsim::viz {
namespace {

constexpr const char* kRemedy =
    "run the command under a virtual X server: xvfb-run -a -s \"-screen 0 1280x1024x24\" "
    "<command> (Debian packages xvfb, xauth, libgl1-mesa-dri)";

}  // namespace

bool display_available(std::string& why_not) {
  const char* name = std::getenv("DISPLAY");
  if (name == nullptr || *name == '\0') {
    why_not = std::string("no X display for the render: DISPLAY is not set; ") + kRemedy;
    return false;
  }
  static std::mutex mutex;
  static std::map<std::string, Display*> held;  // by DISPLAY value; never closed (see above)
  const std::lock_guard<std::mutex> lock(mutex);
  if (held.count(name) != 0) {
    why_not.clear();
    return true;
  }
  Display* display = XOpenDisplay(name);
  if (display == nullptr) {
    why_not = std::string("no X display for the render: cannot open DISPLAY=") + name + "; " +
              kRemedy;
    return false;
  }
  int opcode = 0, first_event = 0, first_error = 0;
  const bool glx = XQueryExtension(display, "GLX", &opcode, &first_event, &first_error) != 0;
  if (!glx) {
    XCloseDisplay(display);
    why_not = std::string("no OpenGL for the render: the X display ") + name +
              " has no GLX extension; " + kRemedy;
    return false;
  }
  held[name] = display;
  why_not.clear();
  return true;
}

void require_display() {
  std::string why_not;
  if (!display_available(why_not)) throw NoDisplayError(why_not);
}

}  // namespace vmsim::viz
