// RGBA8 images to and from PNG files (libpng), top row first.
#pragma once

#include <cstdint>
#include <filesystem>
#include <vector>

namespace sculpt::view {

struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgba;  // width*height*4, top row first
};

// Writes atomically (a temporary file renamed into place), so a reader never
// sees half an image. Throws std::runtime_error naming the file.
void write_png(const std::filesystem::path& file, const Image& image);

// Any PNG libpng reads, converted to RGBA8. Throws std::runtime_error naming the file.
Image read_png(const std::filesystem::path& file);

}  // namespace sculpt::view
