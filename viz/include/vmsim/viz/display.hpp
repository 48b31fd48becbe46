#pragma once
// The X display check that every render runs first.
//
// Debian's VTK 9.1 renders through X11 only (no OSMesa, no EGL): creating a render window without
// a reachable X display aborts the whole process, which cannot be caught (shared/DEBIAN-NOTES.md,
// trap 4). So every function of this module that renders checks for a display first, before any
// VTK window exists, and throws NoDisplayError when there is none. Run renders under
// `xvfb-run -a -s "-screen 0 1280x1024x24" <command>` on a machine without a screen.
#include <stdexcept>
#include <string>

namespace vmsim::viz {

/// A render was asked for and no usable X display is there. The message says why and what to do.
/// Not a vmsim::InputError: the input is fine, the environment is not (vmsim exits with 5).
class NoDisplayError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// True when an X display can be opened and offers GLX (OpenGL): DISPLAY is set, XOpenDisplay
/// succeeds on it and the server has the GLX extension. Otherwise false, with the reason and the
/// remedy ("run under xvfb-run -a ...") in `why_not`. VTK is not touched. The first connection
/// that passes is kept open for the life of the process (so that an X server started without
/// -noreset does not reset, refusing connections for a moment, between this check and VTK's own
/// connection); later calls with the same DISPLAY return true at once. Thread-safe.
bool display_available(std::string& why_not);

/// Throws NoDisplayError with the message of display_available() when there is no display.
void require_display();

}  // namespace vmsim::viz
