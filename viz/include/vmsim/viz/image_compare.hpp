#pragma once
// Comparison of two PNG images (image tests against stored baselines). Needs no display.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace vmsim::viz {

/// The difference of two images as computed by vtkImageDifference (RGB, 3x3 averaging, shifts of
/// up to 2 pixels allowed, the per-pixel threshold `threshold` in levels of 0-255).
struct ImageDifference {
  int width_px = 0;   ///< of the first image
  int height_px = 0;
  bool same_size = false;   ///< false: the errors below are not computed (left at 0)
  double error = 0.0;  ///< vtkImageDifference::GetError (not 0 even for equal images: use the next)
  double thresholded_error = 0.0;  ///< vtkImageDifference::GetThresholdedError
};

/// Reads both PNG files and compares them. Throws vmsim::InputError when a file cannot be read
/// as a PNG.
ImageDifference compare_png_files(const std::string& png_path, const std::string& baseline_path,
                                  int threshold = 16);

/// A PNG's pixels as 8-bit RGB, row by row from the top left (as an image viewer shows it), for
/// tests that look at where things are drawn.
struct RgbImage {
  int width_px = 0;
  int height_px = 0;
  std::vector<std::uint8_t> rgb;  ///< 3 width_px height_px values
  const std::uint8_t* at(int x_px, int y_px) const {
    return rgb.data() + 3 * (static_cast<std::size_t>(x_px) + static_cast<std::size_t>(width_px) * y_px);
  }
};

/// Reads a PNG file. Throws vmsim::InputError when it cannot be read as a PNG.
RgbImage read_png_rgb(const std::string& png_path);

}  // namespace vmsim::viz
