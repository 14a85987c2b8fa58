// libpng's longjmp error handling is confined to write_rows, whose locals are plain pointers
// (as in models/observation/depth_png.cpp).
#include "models/io/rgb_png.h"

#include <fmt/format.h>
#include <png.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <filesystem>

#include "models/io/write_error.h"
#include "runtime/errors.h"

namespace ssc {

namespace {

struct WriteState {
  std::FILE* file = nullptr;
  png_structp png = nullptr;
  png_infop info = nullptr;
  char message[256] = {0};
  ~WriteState() {
    if (png) png_destroy_write_struct(&png, info ? &info : nullptr);
    if (file) std::fclose(file);
  }
};

[[noreturn]] void on_error(png_structp png, png_const_charp msg) {
  auto* s = static_cast<WriteState*>(png_get_error_ptr(png));
  std::snprintf(s->message, sizeof s->message, "%s", msg ? msg : "unknown error");
  png_longjmp(png, 1);
}

void on_warning(png_structp, png_const_charp) {}

bool write_rows(WriteState* s, png_uint_32 w, png_uint_32 h, png_bytepp rows) {
  if (setjmp(png_jmpbuf(s->png))) return false;
  png_init_io(s->png, s->file);
  png_set_IHDR(s->png, s->info, w, h, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_write_info(s->png, s->info);
  png_write_image(s->png, rows);
  png_write_end(s->png, nullptr);
  return true;
}

}  // namespace

void write_rgb_png(const std::string& path, const RgbImage& image) {
  const std::string temp = path + fmt::format(".tmp-{}", getpid());
  {
    WriteState s;
    s.file = std::fopen(temp.c_str(), "wb");
    if (!s.file) throw_write_error(path, errno, "create the file");
    s.png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &s, on_error, on_warning);
    if (s.png) s.info = png_create_info_struct(s.png);
    if (!s.png || !s.info) throw InputError(fmt::format("{}: libpng could not allocate a writer", path));
    std::vector<png_bytep> rows(std::size_t(image.height));
    std::vector<std::uint8_t> bytes = image.rgb;
    for (int v = 0; v < image.height; ++v) rows[std::size_t(v)] = bytes.data() + std::size_t(v) * image.width * 3;
    if (!write_rows(&s, png_uint_32(image.width), png_uint_32(image.height), rows.data()))
      throw InputError(fmt::format("{}: writing the PNG failed (libpng: {})", path, s.message));
    std::FILE* f = s.file;
    s.file = nullptr;
    if (std::fclose(f) != 0) throw_write_error(path, errno);
  }
  std::filesystem::rename(temp, path);
}

}  // namespace ssc
