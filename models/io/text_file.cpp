// Whole-file writes (see text_file.h).
#include "models/io/text_file.h"

#include <cerrno>
#include <cstdio>

#include "models/io/write_error.h"

namespace ssc {

void write_text_file(const std::string& path, const std::string& text) {
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (!file) throw_write_error(path, errno, "create the file");
  errno = 0;
  const bool wrote = std::fwrite(text.data(), 1, text.size(), file) == text.size() && std::fflush(file) == 0;
  const int err = errno;
  if (std::fclose(file) != 0 || !wrote) throw_write_error(path, wrote ? errno : err);
}

}  // namespace ssc
