// 16-bit grayscale PNG I/O for depth images with libpng.
//
// libpng reports errors by longjmp to the setjmp point of the caller. longjmp must not
// skip C++ destructors and must not leave modified non-volatile locals behind, so every
// setjmp lives in a tiny function (read_header, read_rows, write_all) whose only locals
// are plain pointers and whose state lives in a struct owned by the caller; the error
// callback copies libpng's message into that struct. The C++ code around these functions
// turns a `false` return into an InputError that names the file.
#include "models/observation/depth_png.h"

#include <png.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fmt/format.h>

#include "models/io/write_error.h"
#include "runtime/errors.h"

namespace ssc {

namespace {

constexpr png_uint_32 kMaxDepthImageSide = 16384;  // pixels; real depth sensors stay far below

constexpr const char* kFixHint =
    "depth images must be 16-bit single-channel grayscale PNGs (value * depth_scale = metres)";

struct PngError {
  char message[512] = {0};
};

[[noreturn]] void on_png_error(png_structp png, png_const_charp msg) {
  auto* err = static_cast<PngError*>(png_get_error_ptr(png));
  if (err) std::snprintf(err->message, sizeof err->message, "%s", msg ? msg : "unknown error");
  png_longjmp(png, 1);
}

void on_png_warning(png_structp, png_const_charp) {}  // ancillary-chunk noise, not our concern

// ---- reading -------------------------------------------------------------------------

struct PngReadState {
  std::FILE* file = nullptr;
  png_structp png = nullptr;
  png_infop info = nullptr;
  PngError error;
  ~PngReadState() {
    if (png) png_destroy_read_struct(&png, info ? &info : nullptr, nullptr);
    if (file) std::fclose(file);
  }
};

bool read_header(PngReadState* s) {
  if (setjmp(png_jmpbuf(s->png))) return false;
  png_init_io(s->png, s->file);
  png_set_sig_bytes(s->png, 8);
  png_read_info(s->png, s->info);
  return true;
}

bool prepare_rows(PngReadState* s) {
  if (setjmp(png_jmpbuf(s->png))) return false;
  png_set_interlace_handling(s->png);
  png_read_update_info(s->png, s->info);
  return true;
}

bool read_rows(PngReadState* s, png_bytepp rows) {
  if (setjmp(png_jmpbuf(s->png))) return false;
  png_read_image(s->png, rows);
  png_read_end(s->png, nullptr);
  return true;
}

[[noreturn]] void read_failure(const std::string& path, const PngError& err) {
  throw InputError(fmt::format(
      "{}: corrupt or truncated PNG (libpng: {}); re-export the file; {}", path, err.message, kFixHint));
}

std::string describe_png_type(int color_type, int bit_depth) {
  const char* kind = "unknown colour type";
  switch (color_type) {
    case PNG_COLOR_TYPE_GRAY: kind = "grayscale"; break;
    case PNG_COLOR_TYPE_GRAY_ALPHA: kind = "grayscale+alpha"; break;
    case PNG_COLOR_TYPE_RGB: kind = "RGB"; break;
    case PNG_COLOR_TYPE_RGB_ALPHA: kind = "RGBA"; break;
    case PNG_COLOR_TYPE_PALETTE: kind = "palette"; break;
  }
  return fmt::format("{}-bit {}", bit_depth, kind);
}

void open_for_reading(PngReadState& s, const std::string& path) {
  s.file = std::fopen(path.c_str(), "rb");
  if (!s.file)
    throw InputError(fmt::format("{}: cannot open depth image ({}); check the path and that the file "
                                 "exists", path, std::strerror(errno)));
  png_byte signature[8];
  if (std::fread(signature, 1, 8, s.file) != 8 || png_sig_cmp(signature, 0, 8) != 0)
    throw InputError(fmt::format("{}: not a PNG file (bad or missing PNG signature); {}", path, kFixHint));
  s.png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &s.error, on_png_error, on_png_warning);
  if (s.png) s.info = png_create_info_struct(s.png);
  if (!s.png || !s.info) throw InputError(fmt::format("{}: libpng could not allocate a reader", path));
}

DepthImage decode_rows(const std::vector<png_byte>& bytes, int width, int height, std::size_t stride,
                       double depth_scale) {
  DepthImage image;
  image.width = width;
  image.height = height;
  image.depth.resize(std::size_t(width) * height);
  for (int v = 0; v < height; ++v) {
    const png_byte* row = bytes.data() + stride * v;
    for (int u = 0; u < width; ++u) {
      const unsigned value = (unsigned(row[2 * u]) << 8) | row[2 * u + 1];  // PNG is big-endian
      image.depth[std::size_t(v) * width + u] = double(value) * depth_scale;
    }
  }
  return image;
}

void check_scale(double depth_scale, const std::string& path) {
  if (!(depth_scale > 0) || !std::isfinite(depth_scale))
    throw InputError(fmt::format("{}: depth_scale {} must be a positive number of metres per PNG unit "
                                 "(e.g. 0.001 for millimetres)", path, depth_scale));
}

// ---- writing -------------------------------------------------------------------------

struct PngWriteState {
  std::FILE* file = nullptr;
  png_structp png = nullptr;
  png_infop info = nullptr;
  PngError error;
  ~PngWriteState() {
    if (png) png_destroy_write_struct(&png, info ? &info : nullptr);
    if (file) std::fclose(file);
  }
};

bool write_all(PngWriteState* s, png_uint_32 width, png_uint_32 height, png_bytepp rows) {
  if (setjmp(png_jmpbuf(s->png))) return false;
  png_init_io(s->png, s->file);
  png_set_IHDR(s->png, s->info, width, height, 16, PNG_COLOR_TYPE_GRAY, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(s->png, s->info);
  png_write_image(s->png, rows);
  png_write_end(s->png, nullptr);
  return true;
}

void check_image(const DepthImage& image, const std::string& path) {
  if (image.width <= 0 || image.height <= 0 ||
      image.depth.size() != std::size_t(image.width) * image.height)
    throw InputError(fmt::format("{}: depth image {}x{} holds {} values, expected width*height > 0",
                                 path, image.width, image.height, image.depth.size()));
}

std::uint16_t encode_depth(double d, double depth_scale, int u, int v, const std::string& path) {
  const double max_depth = 65535.0 * depth_scale;
  if (!(d >= 0) || !(d <= max_depth))
    throw InputError(fmt::format(
        "{}: pixel (u={}, v={}) has depth {} m, which a 16-bit PNG with depth_scale {} cannot hold "
        "(valid: 0 or up to {} m); mark missing or invalid depths with 0, or use a larger depth_scale",
        path, u, v, d, depth_scale, max_depth));
  return std::uint16_t(std::round(d / depth_scale));
}

std::vector<png_byte> encode_rows(const DepthImage& image, double depth_scale, const std::string& path) {
  std::vector<png_byte> bytes(std::size_t(image.width) * image.height * 2);
  for (int v = 0; v < image.height; ++v)
    for (int u = 0; u < image.width; ++u) {
      const std::size_t i = std::size_t(v) * image.width + u;
      const std::uint16_t value = encode_depth(image.depth[i], depth_scale, u, v, path);
      bytes[2 * i] = png_byte(value >> 8);
      bytes[2 * i + 1] = png_byte(value & 0xff);
    }
  return bytes;
}

void write_png_file(const std::string& file_path, const std::string& shown_path, const DepthImage& image,
                    std::vector<png_byte>& bytes) {
  PngWriteState s;
  s.file = std::fopen(file_path.c_str(), "wb");
  if (!s.file) throw_write_error(shown_path, errno, "create the file");
  s.png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &s.error, on_png_error, on_png_warning);
  if (s.png) s.info = png_create_info_struct(s.png);
  if (!s.png || !s.info) throw InputError(fmt::format("{}: libpng could not allocate a writer", shown_path));
  std::vector<png_bytep> rows(image.height);
  for (int v = 0; v < image.height; ++v) rows[v] = bytes.data() + std::size_t(v) * image.width * 2;
  if (!write_all(&s, png_uint_32(image.width), png_uint_32(image.height), rows.data()))
    throw InputError(fmt::format("{}: writing the PNG failed (libpng: {})", shown_path, s.error.message));
  std::FILE* file = s.file;
  s.file = nullptr;
  if (std::fclose(file) != 0) throw_write_error(shown_path, errno);
}

}  // namespace

DepthImage quantize_depth(const DepthImage& image, double depth_scale) {
  DepthImage out = image;
  for (double& d : out.depth)
    if (d >= 0 && d <= 65535.0 * depth_scale)  // others are write errors; leave them as they are
      d = double(std::uint16_t(std::round(d / depth_scale))) * depth_scale;
  return out;
}

void write_depth_png(const std::string& path, const DepthImage& image, double depth_scale) {
  check_scale(depth_scale, path);
  check_image(image, path);
  std::vector<png_byte> bytes = encode_rows(image, depth_scale, path);
  const std::string tmp = fmt::format("{}.tmp-{}", path, long(::getpid()));
  try {
    write_png_file(tmp, path, image, bytes);
  } catch (...) {
    std::remove(tmp.c_str());
    throw;
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    std::remove(tmp.c_str());
    throw_write_error(path, err, "move the written PNG into place");
  }
}

DepthImage read_depth_png(const std::string& path, double depth_scale) {
  check_scale(depth_scale, path);
  PngReadState s;
  open_for_reading(s, path);
  if (!read_header(&s)) read_failure(path, s.error);
  // The size from the header, before any pixel memory is taken (16-bit rows and metres).
  const png_uint_32 header_width = png_get_image_width(s.png, s.info);
  const png_uint_32 header_height = png_get_image_height(s.png, s.info);
  if (header_width > kMaxDepthImageSide || header_height > kMaxDepthImageSide)
    throw InputError(fmt::format("{}: the PNG is {} x {} pixels (from its header), too large for a depth image: ssc reads "
                                 "at most {} pixels a side (this one would take {:.1f} GB of memory). Check that it is "
                                 "the right file, or downscale it (and its camera's fx, fy, cx, cy in cameras.json)",
                                 path, header_width, header_height, kMaxDepthImageSide,
                                 10.0 * double(header_width) * double(header_height) / 1e9));
  const int color_type = png_get_color_type(s.png, s.info);
  const int bit_depth = png_get_bit_depth(s.png, s.info);
  if (color_type != PNG_COLOR_TYPE_GRAY || bit_depth != 16)
    throw InputError(fmt::format("{}: is a {} PNG; {}", path, describe_png_type(color_type, bit_depth),
                                 kFixHint));
  if (!prepare_rows(&s)) read_failure(path, s.error);
  const png_uint_32 width = png_get_image_width(s.png, s.info);
  const png_uint_32 height = png_get_image_height(s.png, s.info);
  const std::size_t stride = png_get_rowbytes(s.png, s.info);
  if (width == 0 || height == 0 || width > 1u << 20 || height > 1u << 20 || stride < 2 * std::size_t(width))
    throw InputError(fmt::format("{}: implausible PNG size {}x{}; {}", path, width, height, kFixHint));
  std::vector<png_byte> bytes(stride * height);
  std::vector<png_bytep> rows(height);
  for (png_uint_32 v = 0; v < height; ++v) rows[v] = bytes.data() + stride * v;
  if (!read_rows(&s, rows.data())) read_failure(path, s.error);
  return decode_rows(bytes, int(width), int(height), stride, depth_scale);
}

}  // namespace ssc
