#include "vmsim/viz/image_compare.hpp"

#include <vtkImageData.h>
#include <vtkImageDifference.h>
#include <vtkImageExtractComponents.h>
#include <vtkPNGReader.h>
#include <vtkSmartPointer.h>

#include <filesystem>

#include "vmsim/common/errors.hpp"

namespace vmsim::viz {
namespace {

// The image as RGB (an alpha channel, if any, dropped).
vtkSmartPointer<vtkImageData> read_rgb(const std::string& path) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) {
    throw InputError(path + ": no such file (a PNG image was expected)");
  }
  auto reader = vtkSmartPointer<vtkPNGReader>::New();
  if (reader->CanReadFile(path.c_str()) == 0) throw InputError(path + ": not a PNG image");
  reader->SetFileName(path.c_str());
  reader->Update();
  vtkImageData* image = reader->GetOutput();
  if (image == nullptr || image->GetNumberOfPoints() == 0 ||
      image->GetNumberOfScalarComponents() < 3) {
    throw InputError(path + ": cannot be read as an RGB PNG image");
  }
  auto rgb = vtkSmartPointer<vtkImageExtractComponents>::New();
  rgb->SetInputData(image);
  rgb->SetComponents(0, 1, 2);
  rgb->Update();
  vtkSmartPointer<vtkImageData> result = rgb->GetOutput();
  return result;
}

}  // namespace

RgbImage read_png_rgb(const std::string& png_path) {
  const auto image = read_rgb(png_path);
  int dims[3];
  image->GetDimensions(dims);
  RgbImage result;
  result.width_px = dims[0];
  result.height_px = dims[1];
  result.rgb.resize(3 * static_cast<std::size_t>(dims[0]) * static_cast<std::size_t>(dims[1]));
  // VTK's rows start at the bottom.
  for (int y = 0; y < dims[1]; ++y) {
    for (int x = 0; x < dims[0]; ++x) {
      for (int c = 0; c < 3; ++c) {
        result.rgb[3 * (static_cast<std::size_t>(x) + static_cast<std::size_t>(dims[0]) * (dims[1] - 1 - y)) + c] =
            static_cast<std::uint8_t>(image->GetScalarComponentAsDouble(x, y, 0, c));
      }
    }
  }
  return result;
}

ImageDifference compare_png_files(const std::string& png_path, const std::string& baseline_path,
                                  int threshold) {
  const auto image = read_rgb(png_path);
  const auto baseline = read_rgb(baseline_path);
  ImageDifference result;
  int image_dims[3], baseline_dims[3];
  image->GetDimensions(image_dims);
  baseline->GetDimensions(baseline_dims);
  result.width_px = image_dims[0];
  result.height_px = image_dims[1];
  result.same_size = image_dims[0] == baseline_dims[0] && image_dims[1] == baseline_dims[1];
  if (!result.same_size) return result;

  auto difference = vtkSmartPointer<vtkImageDifference>::New();
  difference->SetInputData(image);
  difference->SetImageData(baseline);
  difference->SetThreshold(threshold);
  difference->AllowShiftOn();
  difference->AveragingOn();
  difference->Update();
  result.error = difference->GetError();
  result.thresholded_error = difference->GetThresholdedError();
  return result;
}

}  // namespace vmsim::viz
