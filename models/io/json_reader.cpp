// Strict JSON config reading (see json_reader.h).
#include "models/io/json_reader.h"

#include <fmt/format.h>

#include <cerrno>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "runtime/errors.h"

namespace ssc {

using nlohmann::json;

static const char* type_word(const json& v) {
  if (v.is_number()) return "a number";
  if (v.is_boolean()) return "a boolean";
  if (v.is_string()) return "a string";
  if (v.is_array()) return "an array";
  if (v.is_object()) return "an object";
  return "null";
}

JsonReader::JsonReader(const json& object, std::string file, std::string path)
    : object_(object), file_(std::move(file)), path_(std::move(path)) {
  if (!object_.is_object())
    throw InputError(fmt::format("{}: {} must be a JSON object, found {}", file_, path_.empty() ? "the file" : path_,
                                 type_word(object_)));
}

std::string JsonReader::full_key(const std::string& key) const {
  if (key.empty()) return path_.empty() ? "the scene" : path_;
  return path_.empty() ? key : path_ + "." + key;
}

void JsonReader::fail(const std::string& key, const std::string& what) const {
  throw InputError(fmt::format("{}: {} {}", file_, full_key(key), what));
}

bool JsonReader::has(const std::string& key) const {
  used_.insert(key);
  return object_.contains(key);
}

const json& JsonReader::value(const std::string& key) const {
  used_.insert(key);
  auto it = object_.find(key);
  if (it == object_.end()) fail(key, "is missing");
  return *it;
}

JsonReader JsonReader::child(const std::string& key) const {
  const json& v = value(key);
  if (!v.is_object()) fail(key, fmt::format("must be an object, found {}", type_word(v)));
  return JsonReader(v, file_, full_key(key));
}

std::vector<JsonReader> JsonReader::array_of_objects(const std::string& key) const {
  const json& v = value(key);
  if (!v.is_array()) fail(key, fmt::format("must be an array of objects, found {}", type_word(v)));
  std::vector<JsonReader> out;
  for (size_t i = 0; i < v.size(); ++i) {
    if (!v[i].is_object()) fail(fmt::format("{}[{}]", key, i), fmt::format("must be an object, found {}", type_word(v[i])));
    out.emplace_back(v[i], file_, full_key(fmt::format("{}[{}]", key, i)));
  }
  return out;
}

double JsonReader::number(const std::string& key) const {
  const json& v = value(key);
  if (!v.is_number()) fail(key, fmt::format("must be a number, found {}", type_word(v)));
  const double d = v.get<double>();
  if (!std::isfinite(d)) fail(key, "must be finite");
  return d;
}

double JsonReader::number(const std::string& key, double fallback) const {
  return has(key) ? number(key) : fallback;
}

int JsonReader::integer(const std::string& key) const {
  const json& v = value(key);
  if (!v.is_number_integer()) fail(key, fmt::format("must be an integer, found {}", v.is_number() ? v.dump() : type_word(v)));
  const long long i = v.get<long long>();
  if (i < -2000000000LL || i > 2000000000LL) fail(key, "is out of range");
  return int(i);
}

int JsonReader::integer(const std::string& key, int fallback) const { return has(key) ? integer(key) : fallback; }

bool JsonReader::boolean(const std::string& key, bool fallback) const {
  if (!has(key)) return fallback;
  const json& v = value(key);
  if (!v.is_boolean()) fail(key, fmt::format("must be true or false, found {}", type_word(v)));
  return v.get<bool>();
}

std::string JsonReader::string(const std::string& key) const {
  const json& v = value(key);
  if (!v.is_string()) fail(key, fmt::format("must be a string, found {}", type_word(v)));
  return v.get<std::string>();
}

std::string JsonReader::string(const std::string& key, const std::string& fallback) const {
  return has(key) ? string(key) : fallback;
}

std::vector<double> JsonReader::numbers(const std::string& key) const {
  const json& v = value(key);
  if (!v.is_array()) fail(key, fmt::format("must be an array of numbers, found {}", type_word(v)));
  std::vector<double> out;
  for (const json& e : v) {
    if (!e.is_number()) fail(key, fmt::format("must contain only numbers, found {}", type_word(e)));
    const double d = e.get<double>();
    if (!std::isfinite(d)) fail(key, "must contain only finite numbers");
    out.push_back(d);
  }
  return out;
}

Eigen::Vector3d JsonReader::vec3(const std::string& key) const {
  const std::vector<double> v = numbers(key);
  if (v.size() != 3) fail(key, fmt::format("must have 3 numbers [x, y, z], found {}", v.size()));
  return {v[0], v[1], v[2]};
}

Eigen::Vector3d JsonReader::vec3(const std::string& key, const Eigen::Vector3d& fallback) const {
  return has(key) ? vec3(key) : fallback;
}

double JsonReader::positive(const std::string& key, double value) const {
  if (!(value > 0)) fail(key, fmt::format("must be positive, found {}", value));
  return value;
}

double JsonReader::non_negative(const std::string& key, double value) const {
  if (!(value >= 0)) fail(key, fmt::format("must not be negative, found {}", value));
  return value;
}

void JsonReader::require(bool ok, const std::string& key, const std::string& what) const {
  if (!ok) fail(key, what);
}

void JsonReader::reject_unknown_keys() const {
  for (auto it = object_.begin(); it != object_.end(); ++it) {
    if (used_.count(it.key())) continue;
    std::string known;
    for (const std::string& k : used_) known += (known.empty() ? "" : ", ") + k;
    throw InputError(fmt::format("{}: unknown key '{}'{}; known keys here: {}", file_, full_key(it.key()),
                                 path_.empty() ? "" : " in " + path_, known));
  }
}

void apply_override(json& config, const std::string& assignment, const std::string& file) {
  const size_t eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw InputError(fmt::format("--set {}: expected KEY=VALUE, e.g. --set material.youngs_modulus=3000", assignment));
  const std::string key = assignment.substr(0, eq), text = assignment.substr(eq + 1);
  json value;
  {
    // NaN, infinities and numbers beyond the double range are not JSON; say so, not "a string".
    std::string lower;
    for (char ch : text) lower += char(std::tolower(static_cast<unsigned char>(ch)));
    const std::string bare = lower.empty() || (lower[0] != '-' && lower[0] != '+') ? lower : lower.substr(1);
    char* end = nullptr;
    errno = 0;
    const double d = std::strtod(text.c_str(), &end);
    const bool numeric = !text.empty() && end == text.c_str() + text.size();
    if (bare == "nan" || bare == "inf" || bare == "infinity" || (numeric && (!std::isfinite(d) || errno == ERANGE)))
      throw InputError(fmt::format("{}: --set {}={}: not a finite number; give a value within +-1.8e308 (NaN and "
                                   "infinity are refused)", file, key, text));
  }
  try {
    value = json::parse(text);
  } catch (const json::exception&) {
    bool word = !text.empty();
    for (char ch : text) word &= std::isalnum(static_cast<unsigned char>(ch)) || ch == '_' || ch == '-' || ch == '.' || ch == '/';
    if (!word)
      throw InputError(fmt::format("--set {}: '{}' is not valid JSON (quote strings, write arrays as [1,2,3])", key, text));
    value = text;
  }
  json* node = &config;
  std::string walked;
  size_t start = 0;
  while (true) {
    const size_t dot = key.find('.', start);
    const std::string part = key.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    if (part.empty()) throw InputError(fmt::format("--set {}: empty key component", key));
    if (!node->is_object())
      throw InputError(fmt::format("--set {}: {} in {} is not an object", key, walked.empty() ? "the root" : walked, file));
    walked += (walked.empty() ? "" : ".") + part;
    if (dot == std::string::npos) {
      (*node)[part] = value;
      return;
    }
    if (!node->contains(part)) (*node)[part] = json::object();
    node = &(*node)[part];
    start = dot + 1;
  }
}

json read_json_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InputError(fmt::format("{}: is a folder, not a file; give the path of the JSON file", path));
  std::ifstream in(path);
  if (!in) throw InputError(fmt::format("{}: cannot open the file (does it exist and is it readable?)", path));
  std::stringstream buffer;
  buffer << in.rdbuf();
  try {
    return json::parse(buffer.str());
  } catch (const json::exception& e) {
    throw InputError(fmt::format("{}: not valid JSON: {}", path, e.what()));
  }
}

}  // namespace ssc
