// Whole-file writes (see text_file.h).
#include "models/io/text_file.h"

#include <fmt/format.h>

#include <fstream>

#include "runtime/errors.h"

namespace ssc {

void write_text_file(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  out.close();
  if (!out) throw InputError(fmt::format("{}: cannot write the file; check that the folder is writable and the disk not full", path));
}

}  // namespace ssc
