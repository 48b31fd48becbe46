#pragma once
// Private to viz: shared steps of the renders (VTK types allowed here, never in public headers).
#include <string>

class vtkRenderWindow;
class vtkTextProperty;

namespace vmsim::viz::detail {

/// Renders `window` (already set off-screen and sized), reads its pixels back and writes them as
/// a PNG to `png_path` atomically. Throws vmsim::InputError naming the path on failure.
void write_window_png(vtkRenderWindow* window, const std::string& png_path);

/// Sets the font of `text` to DejaVu Sans (bold or regular after text's bold flag) from the Debian
/// package fonts-dejavu-core, or to VTK's embedded Times when that file is missing. Not VTK's
/// default "Arial": Debian's VTK 9.1 embeds a free substitute whose '[' and ']' are drawn as '('
/// and ')', which turns the units in "s [mm]" into "s (mm)". Call after setting the bold flag.
void apply_font(vtkTextProperty* text);

/// Writes bytes to `path` atomically (through vmsim::write_file_atomically).
void write_bytes_atomically(const std::string& path, const unsigned char* data, std::size_t size);

}  // namespace vmsim::viz::detail
