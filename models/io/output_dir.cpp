// Atomic output folders (see output_dir.h).
#include "models/io/output_dir.h"

#include <fmt/format.h>
#include <unistd.h>

#include <filesystem>

#include "models/io/errors.h"

namespace ssc {
namespace fs = std::filesystem;

OutputDir::OutputDir(const std::string& target) : target_(target) {
  if (target.empty()) throw InputError("--out: the output folder must not be empty");
  const fs::path t = fs::absolute(target).lexically_normal();
  fs::path parent = t.parent_path();
  std::error_code ec;
  fs::create_directories(parent, ec);
  if (ec) throw InputError(fmt::format("{}: cannot create the parent folder: {}", target, ec.message()));
  temp_ = (parent / (t.filename().string() + fmt::format(".tmp-{}", getpid()))).string();
  fs::remove_all(temp_, ec);
  fs::create_directories(temp_, ec);
  if (ec) throw InputError(fmt::format("{}: cannot create the output folder: {}", target, ec.message()));
}

OutputDir::~OutputDir() {
  if (!committed_) {
    std::error_code ec;
    fs::remove_all(temp_, ec);
  }
}

std::string OutputDir::file(const std::string& relative) const { return (fs::path(temp_) / relative).string(); }

void OutputDir::commit() {
  std::error_code ec;
  if (fs::exists(target_)) {
    fs::remove_all(target_, ec);
    if (ec) throw InputError(fmt::format("{}: cannot replace the existing folder: {}", target_, ec.message()));
  }
  fs::rename(temp_, target_, ec);
  if (ec) throw InputError(fmt::format("{}: cannot move the finished output into place: {}", target_, ec.message()));
  committed_ = true;
}

}  // namespace ssc
