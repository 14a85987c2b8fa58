#include "models/geometry/sdf_file.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>

#include "runtime/errors.h"

namespace ssc {

namespace {

constexpr std::size_t kHeaderBytes = 7 * 4;

struct SdfHeader {
  std::int32_t r;
  std::array<std::int32_t, 3> offset;
  std::array<std::int32_t, 3> size;
};

std::uint32_t read_u32_le(const unsigned char* p) {
  return std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16 |
         std::uint32_t(p[3]) << 24;
}

std::int32_t read_i32_le(const unsigned char* p) {
  const std::uint32_t u = read_u32_le(p);
  std::int32_t v;
  std::memcpy(&v, &u, 4);
  return v;
}

float read_f32_le(const unsigned char* p) {
  const std::uint32_t u = read_u32_le(p);
  float v;
  std::memcpy(&v, &u, 4);
  return v;
}

void write_u32_le(std::string& out, std::uint32_t u) {
  for (int b = 0; b < 4; ++b) out.push_back(char((u >> (8 * b)) & 0xff));
}

void write_i32_le(std::string& out, std::int32_t v) {
  std::uint32_t u;
  std::memcpy(&u, &v, 4);
  write_u32_le(out, u);
}

void write_f32_le(std::string& out, float v) {
  std::uint32_t u;
  std::memcpy(&u, &v, 4);
  write_u32_le(out, u);
}

std::string read_whole_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw InputError(
        fmt::format("cannot open SDF file '{}': {}; check the path (relative "
                    "paths are taken from the working directory)",
                    path, std::strerror(errno)));
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad())
    throw InputError(fmt::format("cannot read SDF file '{}'; check its permissions", path));
  return bytes;
}

SdfHeader parse_header(const std::string& path, const std::string& bytes) {
  if (bytes.size() < kHeaderBytes)
    throw InputError(fmt::format(
        "SDF file '{}' has {} bytes, fewer than the 28-byte header (int32 r, offset[3], "
        "size[3]); the file is truncated or not an .sdf file, regenerate it",
        path, bytes.size()));
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  SdfHeader h;
  h.r = read_i32_le(p);
  for (int a = 0; a < 3; ++a) h.offset[a] = read_i32_le(p + 4 + 4 * a);
  for (int a = 0; a < 3; ++a) h.size[a] = read_i32_le(p + 16 + 4 * a);
  return h;
}

void validate_header(const std::string& path, const SdfHeader& h, std::size_t file_bytes) {
  if (h.r <= 0)
    throw InputError(fmt::format(
        "SDF file '{}' has resolution r = {} (voxels per world unit); it must be positive. "
        "The file is corrupt or not an .sdf file, regenerate it",
        path, h.r));
  for (int a = 0; a < 3; ++a) {
    if (h.size[a] <= 0 || h.size[a] > kMaxSdfFileNodesPerAxis)
      throw InputError(fmt::format(
          "SDF file '{}' declares a grid of {} x {} x {} nodes; every size must be between 1 "
          "and {}. The file is corrupt or not an .sdf file, regenerate it",
          path, h.size[0], h.size[1], h.size[2], kMaxSdfFileNodesPerAxis));
  }
  const std::uint64_t nodes = std::uint64_t(h.size[0]) * h.size[1] * h.size[2];
  const std::uint64_t expected = kHeaderBytes + 4 * nodes;
  if (file_bytes != expected)
    throw InputError(
        fmt::format("SDF file '{}' has {} bytes but its header (size {} x {} x {}) needs {} bytes "
                    "(28 + 4 per node); the file is truncated or corrupt, regenerate it",
                    path, file_bytes, h.size[0], h.size[1], h.size[2], expected));
}

std::vector<double> read_values(const std::string& path, const std::string& bytes, long count) {
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data()) + kHeaderBytes;
  std::vector<double> values(count);
  long non_finite = 0, first_non_finite = -1;
  for (long n = 0; n < count; ++n) {
    values[n] = read_f32_le(p + 4 * n);
    if (!std::isfinite(values[n])) {
      if (non_finite++ == 0) first_non_finite = n;
    }
  }
  if (non_finite > 0)
    throw InputError(fmt::format(
        "SDF file '{}' contains {} NaN or infinite values (the first at node index {}); "
        "regenerate the SDF from a clean mesh",
        path, non_finite, first_non_finite));
  return values;
}

void require_inside(const std::string& path, const std::vector<double>& values) {
  for (double v : values)
    if (v < 0) return;
  throw InputError(fmt::format(
      "SDF file '{}' has no negative value, so nothing is inside the shape; the sign may be "
      "flipped (ssc expects negative inside) or the grid misses the object, regenerate it",
      path));
}

// An integer n with |value - n| small relative to max(1, |value|), or nothing.
bool nearly_integer(double value, long& n) {
  n = std::lround(value);
  return std::abs(value - double(n)) <= 1e-6 * std::max(1.0, std::abs(value));
}

SdfHeader header_for(const std::string& path, const SdfGrid& grid) {
  SdfHeader h;
  long r;
  if (!(grid.cell_size > 0) || !nearly_integer(1.0 / grid.cell_size, r) || r <= 0 || r > INT32_MAX)
    throw InputError(fmt::format(
        "cannot write '{}': cell size {} m is not 1/r for an integer r, which the .sdf format "
        "needs; choose a cell_size like 0.01 or 1/64",
        path, grid.cell_size));
  h.r = std::int32_t(r);
  for (int a = 0; a < 3; ++a) {
    long o;
    if (!nearly_integer(grid.origin[a] * r, o) || std::abs(o) > INT32_MAX)
      throw InputError(fmt::format(
          "cannot write '{}': grid origin ({}, {}, {}) is not on integer multiples of the cell "
          "size {}, which the .sdf format needs; place the grid with make_grid_for_bounds",
          path, grid.origin.x(), grid.origin.y(), grid.origin.z(), grid.cell_size));
    h.offset[a] = std::int32_t(o);
    h.size[a] = grid.size[a];
  }
  return h;
}

std::string encode(const SdfHeader& h, const SdfGrid& grid) {
  std::string out;
  out.reserve(kHeaderBytes + 4 * grid.phi.size());
  write_i32_le(out, h.r);
  for (int a = 0; a < 3; ++a) write_i32_le(out, h.offset[a]);
  for (int a = 0; a < 3; ++a) write_i32_le(out, h.size[a]);
  for (double v : grid.phi) write_f32_le(out, float(v * h.r));
  return out;
}

void write_atomically(const std::string& path, const std::string& bytes) {
  const std::string tmp = fmt::format("{}.tmp-{}", path, long(::getpid()));
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), std::streamsize(bytes.size()));
    out.close();
    if (!out) {
      std::remove(tmp.c_str());
      throw InputError(
          fmt::format("cannot write SDF file '{}' (via '{}'): {}; check that the "
                      "folder exists and is writable",
                      path, tmp, std::strerror(errno)));
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    std::remove(tmp.c_str());
    throw InputError(
        fmt::format("cannot move '{}' onto '{}': {}; check that the folder is "
                    "writable",
                    tmp, path, reason));
  }
}

}  // namespace

SdfGrid load_sdf_file(const std::string& path, double scale, const Eigen::Vector3d& translation) {
  if (!(scale > 0) || !std::isfinite(scale))
    throw InputError(
        fmt::format("scale for SDF file '{}' must be a positive number, got {}", path, scale));
  const std::string bytes = read_whole_file(path);
  const SdfHeader h = parse_header(path, bytes);
  validate_header(path, h, bytes.size());

  SdfGrid grid;
  grid.cell_size = scale / h.r;
  grid.size = Eigen::Vector3i(h.size[0], h.size[1], h.size[2]);
  for (int a = 0; a < 3; ++a) grid.origin[a] = scale * h.offset[a] / h.r + translation[a];
  grid.phi = read_values(path, bytes, grid.node_count());
  require_inside(path, grid.phi);
  for (double& v : grid.phi) v *= scale / h.r;
  return grid;
}

void save_sdf_file(const std::string& path, const SdfGrid& grid) {
  if (grid.size.minCoeff() <= 0 || long(grid.phi.size()) != grid.node_count())
    throw InputError(
        fmt::format("cannot write '{}': the grid has size {} x {} x {} but {} "
                    "values",
                    path, grid.size.x(), grid.size.y(), grid.size.z(), grid.phi.size()));
  const long non_finite =
      std::count_if(grid.phi.begin(), grid.phi.end(), [](double v) { return !std::isfinite(v); });
  if (non_finite > 0)
    throw InputError(
        fmt::format("cannot write '{}': {} grid values are NaN or infinite; fill "
                    "every node before saving",
                    path, non_finite));
  write_atomically(path, encode(header_for(path, grid), grid));
}

}  // namespace ssc
