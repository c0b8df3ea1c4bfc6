#include "gl/png_io.hpp"

#include <fmt/format.h>
#include <png.h>
#include <unistd.h>

#include <csetjmp>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <system_error>

namespace sculpt::view {

namespace {

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

// libpng reports errors by longjmp. The jumps stay inside the two C-style
// functions below (no C++ object with a destructor lives in them); their
// callers turn the message into an exception.
struct PngError {
  char message[256];
};

void png_error_fn(png_structp png, png_const_charp message) {
  auto* err = static_cast<PngError*>(png_get_error_ptr(png));
  std::snprintf(err->message, sizeof err->message, "%s", message);
  png_longjmp(png, 1);
}
void png_warn_fn(png_structp, png_const_charp) {}

// Returns false with err->message set.
bool png_write_rows(std::FILE* f, const std::uint8_t* rgba, int width, int height, PngError* err) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, err, png_error_fn, png_warn_fn);
  if (png == nullptr) return false;
  png_infop info = png_create_info_struct(png);
  if (info == nullptr || setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_init_io(png, f);
  png_set_compression_level(png, 1);  // fast: frame sequences are written at video rates
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height), 8, PNG_COLOR_TYPE_RGBA,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  const std::size_t row = static_cast<std::size_t>(width) * 4;
  for (int y = 0; y < height; ++y) png_write_row(png, const_cast<png_bytep>(rgba + row * static_cast<std::size_t>(y)));
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

// Two calls: first with out == nullptr to learn the size, then to fill `out`.
bool png_read_rows(std::FILE* f, std::uint8_t* out, int* width, int* height, PngError* err) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, err, png_error_fn, png_warn_fn);
  if (png == nullptr) return false;
  png_infop info = png_create_info_struct(png);
  if (info == nullptr || setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  png_init_io(png, f);
  png_read_info(png, info);
  png_set_expand(png);  // palette, low-bit grey, tRNS -> 8-bit channels
  png_set_strip_16(png);
  png_set_gray_to_rgb(png);
  png_set_add_alpha(png, 0xff, PNG_FILLER_AFTER);
  png_read_update_info(png, info);
  *width = static_cast<int>(png_get_image_width(png, info));
  *height = static_cast<int>(png_get_image_height(png, info));
  const std::size_t row = static_cast<std::size_t>(*width) * 4;
  if (png_get_rowbytes(png, info) != row) {
    std::snprintf(err->message, sizeof err->message, "unexpected row layout");
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  if (out != nullptr) {
    for (int y = 0; y < *height; ++y) png_read_row(png, out + row * static_cast<std::size_t>(y), nullptr);
    png_read_end(png, nullptr);
  }
  png_destroy_read_struct(&png, &info, nullptr);
  return true;
}

}  // namespace

void write_png(const std::filesystem::path& file, const Image& image) {
  if (image.width <= 0 || image.height <= 0 ||
      image.rgba.size() != static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height) * 4) {
    throw std::runtime_error(fmt::format("{}: not writing an empty or inconsistent image", file.string()));
  }
  const std::string name = file.string();
  const std::filesystem::path tmp = file.string() + fmt::format(".tmp{}", ::getpid());
  File f(std::fopen(tmp.c_str(), "wb"));
  if (!f) {
    throw std::runtime_error(
        fmt::format("{}: cannot write: {}", name, std::generic_category().message(errno)));
  }
  PngError err{};
  if (!png_write_rows(f.get(), image.rgba.data(), image.width, image.height, &err)) {
    f.reset();
    std::filesystem::remove(tmp);
    throw std::runtime_error(fmt::format("{}: PNG error: {}", name, err.message));
  }
  const bool flushed = std::fflush(f.get()) == 0;
  f.reset();
  std::error_code ec;
  if (flushed) std::filesystem::rename(tmp, file, ec);
  if (!flushed || ec) {
    std::filesystem::remove(tmp, ec);
    throw std::runtime_error(fmt::format("{}: cannot write (disk full?)", name));
  }
}

Image read_png(const std::filesystem::path& file) {
  const std::string name = file.string();
  File f(std::fopen(file.c_str(), "rb"));
  if (!f) throw std::runtime_error(fmt::format("{}: cannot open: {}", name, std::generic_category().message(errno)));
  Image image;
  PngError err{};
  if (!png_read_rows(f.get(), nullptr, &image.width, &image.height, &err)) {
    throw std::runtime_error(fmt::format("{}: not a readable PNG: {}", name, err.message));
  }
  image.rgba.resize(static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height) * 4);
  std::rewind(f.get());
  if (!png_read_rows(f.get(), image.rgba.data(), &image.width, &image.height, &err)) {
    throw std::runtime_error(fmt::format("{}: not a readable PNG: {}", name, err.message));
  }
  return image;
}

}  // namespace sculpt::view
