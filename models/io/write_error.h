// The one error for a file or folder that could not be written or created: a full disk
// (ENOSPC), an I/O error (EIO), no permission, a short write. It is the user's to fix, like an
// input (exit 2), and names the path, the system's reason and the usual fixes; it is never an
// internal error.
#pragma once
#include <filesystem>
#include <string>
#include <system_error>

namespace ssc {

// "PATH: cannot WHAT (REASON); ..." ; err: the errno of the failure (0: unknown, said as EIO).
std::string write_error_message(const std::string& path, int err, const std::string& what = "write the file");
[[noreturn]] void throw_write_error(const std::string& path, int err, const std::string& what = "write the file");
// A std::filesystem failure (creating, renaming, removing) as the same message, naming its path.
std::string filesystem_error_message(const std::filesystem::filesystem_error& e);

}  // namespace ssc
