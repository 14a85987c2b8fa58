// Reads a CalculiX reference of tests/data/calculix/ (made by tools/calculix/make-references.sh).
#pragma once
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

namespace ssc {

inline nlohmann::json read_calculix_reference(const std::string& name) {
  std::ifstream in(std::string(SSC_TEST_DATA_DIR) + "/calculix/" + name + ".json");
  EXPECT_TRUE(in.good()) << name;
  return nlohmann::json::parse(in);
}

}  // namespace ssc
