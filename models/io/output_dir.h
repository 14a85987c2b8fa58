// An output folder that appears complete or not at all: everything is written into a
// sibling temporary folder, which replaces the target only when commit() is called.
// Destroying an uncommitted OutputDir removes the temporary folder.
#pragma once
#include <string>

namespace ssc {

class OutputDir {
 public:
  explicit OutputDir(const std::string& target);
  ~OutputDir();
  OutputDir(const OutputDir&) = delete;
  OutputDir& operator=(const OutputDir&) = delete;

  const std::string& path() const { return temp_; }  // write here
  std::string file(const std::string& relative) const;
  void commit();

 private:
  std::string target_, temp_;
  bool committed_ = false;
};

}  // namespace ssc
