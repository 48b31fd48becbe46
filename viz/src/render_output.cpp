#include "render_output.hpp"

#include <vtkPNGWriter.h>
#include <vtkRenderWindow.h>
#include <vtkSmartPointer.h>
#include <vtkTextProperty.h>
#include <vtkUnsignedCharArray.h>
#include <vtkWindowToImageFilter.h>

#include <filesystem>

#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"

namespace vmsim::viz::detail {

void write_bytes_atomically(const std::string& path, const unsigned char* data, std::size_t size) {
  // One copy into a string: the atomic writer of common takes text, and PNGs are small.
  write_file_atomically(path, std::string(reinterpret_cast<const char*>(data), size));
}

void apply_font(vtkTextProperty* text) {
  static const bool dejavu =
      std::filesystem::exists("/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf") &&
      std::filesystem::exists("/usr/share/fonts/truetype/dejavu/DejaVuSans-Bold.ttf");
  if (dejavu) {
    text->SetFontFamily(VTK_FONT_FILE);
    text->SetFontFile(text->GetBold() ? "/usr/share/fonts/truetype/dejavu/DejaVuSans-Bold.ttf"
                                      : "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf");
  } else {
    text->SetFontFamilyToTimes();
  }
}

void write_window_png(vtkRenderWindow* window, const std::string& png_path) {
  window->Render();
  auto grab = vtkSmartPointer<vtkWindowToImageFilter>::New();
  grab->SetInput(window);
  grab->SetInputBufferTypeToRGB();
  grab->ReadFrontBufferOff();  // off-screen: the image is in the back buffer
  grab->Update();

  auto writer = vtkSmartPointer<vtkPNGWriter>::New();
  writer->SetInputConnection(grab->GetOutputPort());
  writer->WriteToMemoryOn();
  writer->Write();
  vtkUnsignedCharArray* bytes = writer->GetResult();
  if (bytes == nullptr || bytes->GetNumberOfValues() == 0) {
    throw InputError(png_path + ": the render produced no image");
  }
  write_bytes_atomically(png_path, bytes->GetPointer(0),
                         static_cast<std::size_t>(bytes->GetNumberOfValues()));
}

}  // namespace vmsim::viz::detail
