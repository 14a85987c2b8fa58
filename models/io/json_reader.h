// Strict reading of JSON config objects: every key is looked up by name, typed and
// range-checked, unknown keys are rejected, and every error names the file and the full
// dotted key (for example "scene.json: material.poisson_ratio must be in [0, 0.5)").
#pragma once
#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

namespace ssc {

class JsonReader {
 public:
  JsonReader(const nlohmann::json& object, std::string file, std::string path);

  bool has(const std::string& key) const;
  JsonReader child(const std::string& key) const;              // required object
  std::vector<JsonReader> array_of_objects(const std::string& key) const;

  double number(const std::string& key) const;
  double number(const std::string& key, double fallback) const;
  int integer(const std::string& key) const;
  int integer(const std::string& key, int fallback) const;
  bool boolean(const std::string& key, bool fallback) const;
  std::string string(const std::string& key) const;
  std::string string(const std::string& key, const std::string& fallback) const;
  Eigen::Vector3d vec3(const std::string& key) const;
  Eigen::Vector3d vec3(const std::string& key, const Eigen::Vector3d& fallback) const;
  std::vector<double> numbers(const std::string& key) const;

  // Range checks, throwing with the key's full name.
  double positive(const std::string& key, double value) const;
  double non_negative(const std::string& key, double value) const;
  void require(bool ok, const std::string& key, const std::string& what) const;

  // Throws if the object has keys that were never asked for.
  void reject_unknown_keys() const;
  [[noreturn]] void fail(const std::string& key, const std::string& what) const;
  std::string full_key(const std::string& key) const;
  const std::string& file() const { return file_; }

 private:
  const nlohmann::json& value(const std::string& key) const;
  const nlohmann::json& object_;
  std::string file_, path_;
  mutable std::set<std::string> used_;
};

// Applies "a.b.c=VALUE" (VALUE is JSON; a bare word is taken as a string) to a config.
// Missing intermediate objects are created; the scene parser then rejects keys it does
// not know, so a misspelt key is still reported.
void apply_override(nlohmann::json& config, const std::string& assignment, const std::string& file);

// Reads a JSON file; InputError with the parser's message and position on failure.
nlohmann::json read_json_file(const std::string& path);

}  // namespace ssc
