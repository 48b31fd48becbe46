#pragma once
// Comparison of two PNG images (image tests against stored baselines). Needs no display.
#include <string>

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

}  // namespace vmsim::viz
