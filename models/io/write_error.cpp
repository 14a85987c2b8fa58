// Write failures as input/output errors (see write_error.h).
#include "models/io/write_error.h"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>

#include "runtime/errors.h"

namespace ssc {
namespace {

std::string fix_for(int err) {
  switch (err) {
    case ENOSPC:
    case EDQUOT: return "free disk space or choose an --out on another disk";
    case EACCES:
    case EPERM:
    case EROFS: return "check that the folder is writable, or choose another --out";
    default: return "check the disk and that the folder is writable, or choose another --out";
  }
}

}  // namespace

std::string write_error_message(const std::string& path, int err, const std::string& what) {
  if (err == 0) err = EIO;
  return fmt::format("{}: cannot {} ({}); {}", path, what, std::strerror(err), fix_for(err));
}

void throw_write_error(const std::string& path, int err, const std::string& what) {
  throw InputError(write_error_message(path, err, what));
}

std::string filesystem_error_message(const std::filesystem::filesystem_error& e) {
  const std::string path = e.path1().empty() ? std::string("a file or folder") : e.path1().string();
  const int err = e.code().category() == std::generic_category() || e.code().category() == std::system_category()
                      ? e.code().value()
                      : 0;
  return write_error_message(path, err, "complete the file operation");
}

}  // namespace ssc
