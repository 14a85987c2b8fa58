// Folder fingerprints (see folder_hash.h).
#include "models/io/folder_hash.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <vector>

#include "runtime/errors.h"

namespace ssc {
namespace fs = std::filesystem;

namespace {
void mix(std::uint64_t& h, const char* data, size_t n) {
  for (size_t i = 0; i < n; ++i) {
    h ^= static_cast<unsigned char>(data[i]);
    h *= 1099511628211ull;
  }
}
}  // namespace

nlohmann::json folder_fingerprint(const std::string& folder) {
  std::vector<fs::path> files;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(folder, ec); !ec && it != fs::recursive_directory_iterator(); it.increment(ec))
    if (it->is_regular_file()) files.push_back(fs::relative(it->path(), folder));
  if (ec) throw InputError(fmt::format("{}: cannot list the folder: {}", folder, ec.message()));
  std::sort(files.begin(), files.end());
  std::uint64_t h = 14695981039346656037ull;
  std::uintmax_t bytes = 0;
  std::vector<char> buffer(1 << 16);
  for (const fs::path& rel : files) {
    const std::string name = rel.generic_string();
    mix(h, name.c_str(), name.size() + 1);
    std::ifstream in(fs::path(folder) / rel, std::ios::binary);
    while (in) {
      in.read(buffer.data(), std::streamsize(buffer.size()));
      mix(h, buffer.data(), size_t(in.gcount()));
      bytes += std::uintmax_t(in.gcount());
    }
  }
  return {{"path", fs::absolute(folder).lexically_normal().string()},
          {"files", files.size()},
          {"bytes", bytes},
          {"fnv1a64", fmt::format("{:016x}", h)}};
}

}  // namespace ssc
