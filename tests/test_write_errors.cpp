// A file ssc cannot write (a full disk, a folder gone) is an input/output error that names
// the path and the reason, never an internal error; /dev/full fails every write with ENOSPC.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "expect_input_error.h"
#include "models/io/output_dir.h"
#include "models/io/ply_writer.h"
#include "models/io/text_file.h"
#include "models/io/write_error.h"

namespace ssc {
namespace {
namespace fs = std::filesystem;

const std::string kNoSpace = std::strerror(ENOSPC);

TEST(WriteErrors, AFullDiskNamesTheFileAndTheReason) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full";
  expect_input_error([] { write_text_file("/dev/full", std::string(1 << 16, 'x')); },
                     {"/dev/full", kNoSpace, "free disk space"});
}

TEST(WriteErrors, APlyThatCannotBeWrittenIsAnInputError) {
  const std::string path = (fs::temp_directory_path() / ("ssc_no_such_folder_" + std::to_string(::getpid())) / "f.ply").string();
  expect_input_error([&] { write_ply(path, {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}}); },
                     {path, std::strerror(ENOENT)});
}

TEST(WriteErrors, AFilesystemFailureNamesItsPath) {
  const fs::filesystem_error e("create_directories", fs::path("/data/run/frames"),
                               std::make_error_code(std::errc::no_space_on_device));
  const std::string message = filesystem_error_message(e);
  EXPECT_NE(message.find("/data/run/frames"), std::string::npos) << message;
  EXPECT_NE(message.find(kNoSpace), std::string::npos) << message;
}

TEST(WriteErrors, FoldersBelowAFolderThatIsGoneAreNotMadeAgain) {
  const fs::path gone = fs::temp_directory_path() / ("ssc_gone_" + std::to_string(::getpid()));
  fs::remove_all(gone);
  expect_input_error([&] { create_folders_below(gone.string(), "cam0/sub"); }, {gone.string() + "/cam0"});
  EXPECT_FALSE(fs::exists(gone));
  fs::create_directories(gone);
  create_folders_below(gone.string(), "cam0/sub");
  EXPECT_TRUE(fs::is_directory(gone / "cam0" / "sub"));
  fs::remove_all(gone);
}

}  // namespace
}  // namespace ssc
