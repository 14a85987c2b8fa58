// Binary PLY writer (see ply_writer.h). The whole file is encoded into one byte buffer
// (explicit little-endian packing), then written to a temporary file with stdio, flushed,
// closed and renamed; any failure removes the temporary and reports errno.
#include "models/io/ply_writer.h"

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <unistd.h>

#include "models/io/write_error.h"

namespace ssc {
namespace {

void put_u32(std::string& buf, std::uint32_t v) {
  for (int b = 0; b < 4; ++b) buf.push_back(char((v >> (8 * b)) & 0xFF));
}

void put_float(std::string& buf, double value) {
  const float f = static_cast<float>(value);
  std::uint32_t bits;
  std::memcpy(&bits, &f, sizeof bits);
  put_u32(buf, bits);
}

std::string encode(const std::vector<Eigen::Vector3d>& vertices,
                   const std::vector<std::array<int, 3>>& triangles) {
  std::string buf =
      "ply\nformat binary_little_endian 1.0\ncomment written by ssc\nelement vertex " +
      std::to_string(vertices.size()) +
      "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
      std::to_string(triangles.size()) + "\nproperty list uchar int vertex_indices\nend_header\n";
  buf.reserve(buf.size() + 12 * vertices.size() + 13 * triangles.size());
  for (const Eigen::Vector3d& v : vertices)
    for (int a = 0; a < 3; ++a) put_float(buf, v[a]);
  for (const auto& t : triangles) {
    buf.push_back(char(3));
    for (int idx : t) put_u32(buf, static_cast<std::uint32_t>(idx));
  }
  return buf;
}

void check_indices(const std::vector<Eigen::Vector3d>& vertices,
                   const std::vector<std::array<int, 3>>& triangles) {
  for (size_t f = 0; f < triangles.size(); ++f)
    for (int idx : triangles[f])
      if (idx < 0 || size_t(idx) >= vertices.size())
        throw std::invalid_argument("write_ply: triangle " + std::to_string(f) +
                                    " uses vertex " + std::to_string(idx) + " of " +
                                    std::to_string(vertices.size()));
}

[[noreturn]] void fail(const std::string& what, const std::string& path, int err,
                       const std::string& tmp) {
  std::remove(tmp.c_str());
  throw_write_error(path, err, what);
}

}  // namespace

void write_ply(const std::string& path, const std::vector<Eigen::Vector3d>& vertices,
               const std::vector<std::array<int, 3>>& triangles) {
  check_indices(vertices, triangles);
  const std::string data = encode(vertices, triangles);
  const std::string tmp = path + ".tmp-" + std::to_string(long(::getpid()));
  std::FILE* file = std::fopen(tmp.c_str(), "wb");
  if (!file) {
    const int err = errno;
    fail("create its temporary file", path, err, tmp);
  }
  errno = 0;
  const bool wrote =
      std::fwrite(data.data(), 1, data.size(), file) == data.size() && std::fflush(file) == 0;
  if (!wrote) {
    const int err = errno != 0 ? errno : EIO;
    std::fclose(file);
    fail("write the file", path, err, tmp);
  }
  if (std::fclose(file) != 0) {
    const int err = errno;
    fail("finish writing its temporary file", path, err, tmp);
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    fail("move its temporary file into place", path, err, tmp);
  }
}

}  // namespace ssc
