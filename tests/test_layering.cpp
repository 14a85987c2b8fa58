// The engine sits below the model: nothing under graph/, ops/, runtime/ or codegen/ includes
// a header from models/ (the engine takes runtime/static_arrays.h, never the model's grid).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace {

TEST(Layering, TheEngineIncludesNothingFromTheModel) {
  namespace fs = std::filesystem;
  int files = 0;
  for (const char* folder : {"graph", "ops", "runtime", "codegen"}) {
    for (const fs::directory_entry& e : fs::recursive_directory_iterator(fs::path(SSC_SOURCE_DIR) / folder)) {
      if (!e.is_regular_file()) continue;
      ++files;
      std::ifstream in(e.path());
      std::string line;
      for (int n = 1; std::getline(in, line); ++n)
        EXPECT_EQ(line.find("#include \"models/"), std::string::npos) << e.path().string() << ":" << n << ": " << line;
    }
  }
  EXPECT_GT(files, 20);
}

}  // namespace
