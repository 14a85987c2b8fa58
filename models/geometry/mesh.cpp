#include "models/geometry/mesh.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <string_view>

#include "runtime/errors.h"

namespace ssc {

namespace {

using Eigen::Vector3d;

// ---------------------------------------------------------------------------------------
// Text helpers

std::string read_whole_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in)
    throw InputError(
        fmt::format("cannot open mesh file '{}': {}; check the path (relative "
                    "paths are taken from the working directory)",
                    path, std::strerror(errno)));
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad())
    throw InputError(fmt::format("cannot read mesh file '{}'; check its permissions", path));
  if (bytes.empty())
    throw InputError(fmt::format("mesh file '{}' is empty; export the mesh again", path));
  return bytes;
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return s;
}

bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v';
}

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> tokens;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i])) ++i;
    const std::size_t start = i;
    while (i < line.size() && !is_space(line[i])) ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
  return tokens;
}

bool parse_number(std::string_view token, double& value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  return ec == std::errc() && end == token.data() + token.size();
}

bool parse_integer(std::string_view token, long& value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  return ec == std::errc() && end == token.data() + token.size();
}

// Splits a text into lines, counting them from 1.
class LineReader {
 public:
  explicit LineReader(std::string_view text, std::size_t start = 0, int first_line = 1)
      : text_(text), pos_(start), line_number_(first_line - 1) {}
  bool next(std::string_view& line) {
    if (pos_ >= text_.size()) return false;
    std::size_t end = text_.find('\n', pos_);
    if (end == std::string_view::npos) end = text_.size();
    line = text_.substr(pos_, end - pos_);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos_ = end + 1;
    ++line_number_;
    return true;
  }
  int line_number() const { return line_number_; }
  std::size_t position() const { return pos_; }

 private:
  std::string_view text_;
  std::size_t pos_;
  int line_number_;
};

// ---------------------------------------------------------------------------------------
// Shared mesh building

[[noreturn]] void fail_at_line(const std::string& path, int line, const std::string& what) {
  throw InputError(fmt::format("mesh file '{}', line {}: {}", path, line, what));
}

void require_finite(const std::string& path, const std::string& where, const Vector3d& v) {
  if (!v.allFinite())
    throw InputError(
        fmt::format("mesh file '{}', {}: vertex coordinates ({}, {}, {}) are not "
                    "finite; repair or re-export the mesh",
                    path, where, v.x(), v.y(), v.z()));
}

void add_fan(TriangleMesh& mesh, const std::vector<int>& polygon) {
  for (std::size_t i = 1; i + 1 < polygon.size(); ++i)
    mesh.faces.emplace_back(polygon[0], polygon[i], polygon[i + 1]);
}

void require_faces(const std::string& path, const TriangleMesh& mesh) {
  if (mesh.faces.empty())
    throw InputError(
        fmt::format("mesh file '{}' has {} vertices but no faces; a point cloud "
                    "cannot be turned into a solid, export the surface with faces",
                    path, mesh.vertices.size()));
}

// ---------------------------------------------------------------------------------------
// OBJ

Vector3d parse_obj_vertex(const std::string& path, int line,
                          const std::vector<std::string_view>& tokens) {
  Vector3d v;
  if (tokens.size() < 4) fail_at_line(path, line, "a 'v' line needs three coordinates");
  for (int a = 0; a < 3; ++a)
    if (!parse_number(tokens[1 + a], v[a]))
      fail_at_line(path, line, fmt::format("'{}' is not a number", tokens[1 + a]));
  require_finite(path, fmt::format("line {}", line), v);
  return v;
}

// "7", "7/2", "7/2/5", "7//5", "-1" -> a 0-based index into the vertices read so far.
int parse_obj_index(const std::string& path, int line, std::string_view token, long vertex_count) {
  const std::string_view head = token.substr(0, token.find('/'));
  long index;
  if (!parse_integer(head, index) || index == 0)
    fail_at_line(path, line,
                 fmt::format("'{}' is not a valid face vertex (expected a non-zero "
                             "integer, optionally followed by /vt/vn)",
                             token));
  const long resolved = index > 0 ? index - 1 : vertex_count + index;
  if (resolved < 0 || resolved >= vertex_count)
    fail_at_line(path, line,
                 fmt::format("face vertex index {} is out of range: only {} vertices "
                             "are defined before this line",
                             index, vertex_count));
  return int(resolved);
}

TriangleMesh load_obj(const std::string& path, const std::string& text) {
  TriangleMesh mesh;
  LineReader reader(text);
  std::string_view line;
  std::vector<int> polygon;
  while (reader.next(line)) {
    const int number = reader.line_number();
    const auto tokens = split(line.substr(0, line.find('#')));
    if (tokens.empty()) continue;
    if (tokens[0] == "v") {
      mesh.vertices.push_back(parse_obj_vertex(path, number, tokens));
    } else if (tokens[0] == "f") {
      polygon.clear();
      for (std::size_t t = 1; t < tokens.size(); ++t)
        polygon.push_back(parse_obj_index(path, number, tokens[t], long(mesh.vertices.size())));
      if (polygon.size() < 3) fail_at_line(path, number, "a face needs at least three vertices");
      add_fan(mesh, polygon);
    }
  }
  require_faces(path, mesh);
  return mesh;
}

// ---------------------------------------------------------------------------------------
// PLY

enum class PlyFormat { Ascii, BinaryLittleEndian, BinaryBigEndian };
enum class PlyType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::Float32;
  bool is_list = false;
  PlyType count_type = PlyType::UInt8;
};

struct PlyElement {
  std::string name;
  long count = 0;
  std::vector<PlyProperty> properties;
};

struct PlyHeader {
  PlyFormat format = PlyFormat::Ascii;
  std::vector<PlyElement> elements;
  std::size_t body_start = 0;
  int body_first_line = 1;
};

bool parse_ply_type(std::string_view name, PlyType& type) {
  static const std::pair<const char*, PlyType> kTypes[] = {
      {"char", PlyType::Int8},      {"int8", PlyType::Int8},       {"uchar", PlyType::UInt8},
      {"uint8", PlyType::UInt8},    {"short", PlyType::Int16},     {"int16", PlyType::Int16},
      {"ushort", PlyType::UInt16},  {"uint16", PlyType::UInt16},   {"int", PlyType::Int32},
      {"int32", PlyType::Int32},    {"uint", PlyType::UInt32},     {"uint32", PlyType::UInt32},
      {"float", PlyType::Float32},  {"float32", PlyType::Float32}, {"double", PlyType::Float64},
      {"float64", PlyType::Float64}};
  for (const auto& [n, t] : kTypes)
    if (name == n) {
      type = t;
      return true;
    }
  return false;
}

int ply_type_bytes(PlyType type) {
  switch (type) {
    case PlyType::Int8:
    case PlyType::UInt8:
      return 1;
    case PlyType::Int16:
    case PlyType::UInt16:
      return 2;
    case PlyType::Int32:
    case PlyType::UInt32:
    case PlyType::Float32:
      return 4;
    case PlyType::Float64:
      return 8;
  }
  return 0;
}

PlyType parse_ply_type_or_fail(const std::string& path, int line, std::string_view name) {
  PlyType type;
  if (!parse_ply_type(name, type))
    fail_at_line(path, line, fmt::format("unknown PLY property type '{}'", name));
  return type;
}

void parse_ply_header_line(const std::string& path, int line,
                           const std::vector<std::string_view>& tokens, PlyHeader& header) {
  const std::string_view key = tokens[0];
  if (key == "format") {
    if (tokens.size() < 2) fail_at_line(path, line, "'format' needs a value");
    if (tokens[1] == "ascii")
      header.format = PlyFormat::Ascii;
    else if (tokens[1] == "binary_little_endian")
      header.format = PlyFormat::BinaryLittleEndian;
    else if (tokens[1] == "binary_big_endian")
      header.format = PlyFormat::BinaryBigEndian;
    else
      fail_at_line(path, line, fmt::format("unknown PLY format '{}'", tokens[1]));
  } else if (key == "element") {
    long count;
    if (tokens.size() < 3 || !parse_integer(tokens[2], count) || count < 0)
      fail_at_line(path, line, "expected 'element <name> <count>'");
    header.elements.push_back({std::string(tokens[1]), count, {}});
  } else if (key == "property") {
    if (header.elements.empty()) fail_at_line(path, line, "'property' before any 'element'");
    PlyProperty property;
    if (tokens.size() >= 5 && tokens[1] == "list") {
      property.is_list = true;
      property.count_type = parse_ply_type_or_fail(path, line, tokens[2]);
      property.type = parse_ply_type_or_fail(path, line, tokens[3]);
      property.name = std::string(tokens[4]);
    } else if (tokens.size() >= 3) {
      property.type = parse_ply_type_or_fail(path, line, tokens[1]);
      property.name = std::string(tokens[2]);
    } else {
      fail_at_line(path, line, "expected 'property <type> <name>'");
    }
    header.elements.back().properties.push_back(property);
  }
  // comment, obj_info and unknown keywords carry nothing we need.
}

PlyHeader parse_ply_header(const std::string& path, const std::string& text) {
  PlyHeader header;
  LineReader reader(text);
  std::string_view line;
  if (!reader.next(line) || line != "ply")
    throw InputError(
        fmt::format("mesh file '{}' does not start with 'ply'; it is not a PLY "
                    "file, export it again or fix its extension",
                    path));
  while (reader.next(line)) {
    const auto tokens = split(line);
    if (tokens.empty()) continue;
    if (tokens[0] == "end_header") {
      header.body_start = reader.position();
      header.body_first_line = reader.line_number() + 1;
      return header;
    }
    parse_ply_header_line(path, reader.line_number(), tokens, header);
  }
  throw InputError(
      fmt::format("mesh file '{}': the PLY header has no 'end_header'; the file "
                  "is truncated, export it again",
                  path));
}

// Reads one element instance per line.
class PlyAsciiSource {
 public:
  PlyAsciiSource(const std::string& path, const std::string& text, const PlyHeader& header)
      : path_(path), reader_(text, header.body_start, header.body_first_line) {}
  void begin(const std::string& element, long index) {
    std::string_view line;
    do {
      if (!reader_.next(line))
        throw InputError(
            fmt::format("mesh file '{}' ends before {} {} (of those its header "
                        "declares); the file is truncated, export it again",
                        path_, element, index));
      tokens_ = split(line);
    } while (tokens_.empty());
    next_ = 0;
  }
  double next(PlyType) {
    if (next_ >= tokens_.size())
      fail_at_line(path_, reader_.line_number(), "fewer values than the header's properties");
    double value;
    if (!parse_number(tokens_[next_], value))
      fail_at_line(path_, reader_.line_number(),
                   fmt::format("'{}' is not a number", tokens_[next_]));
    ++next_;
    return value;
  }
  std::string where(const std::string&, long) const {
    return fmt::format("line {}", reader_.line_number());
  }

 private:
  const std::string& path_;
  LineReader reader_;
  std::vector<std::string_view> tokens_;
  std::size_t next_ = 0;
};

class PlyBinarySource {
 public:
  PlyBinarySource(const std::string& path, const std::string& bytes, const PlyHeader& header)
      : path_(path),
        bytes_(bytes),
        pos_(header.body_start),
        swap_(header.format == PlyFormat::BinaryBigEndian) {}
  void begin(const std::string& element, long index) {
    element_ = &element;
    index_ = index;
  }
  double next(PlyType type) {
    const int n = ply_type_bytes(type);
    if (pos_ + n > bytes_.size())
      throw InputError(
          fmt::format("mesh file '{}' ends inside {} {} (of those its header "
                      "declares); the file is truncated, export it again",
                      path_, *element_, index_));
    unsigned char raw[8];
    std::memcpy(raw, bytes_.data() + pos_, n);
    pos_ += n;
    if (swap_) std::reverse(raw, raw + n);
    return decode(type, raw);
  }
  std::string where(const std::string& element, long index) const {
    return fmt::format("{} {}", element, index);
  }

 private:
  template <typename T>
  static double as(const unsigned char* raw) {
    T v;
    std::memcpy(&v, raw, sizeof(T));
    return double(v);
  }
  static double decode(PlyType type, const unsigned char* raw) {
    switch (type) {
      case PlyType::Int8:
        return as<std::int8_t>(raw);
      case PlyType::UInt8:
        return as<std::uint8_t>(raw);
      case PlyType::Int16:
        return as<std::int16_t>(raw);
      case PlyType::UInt16:
        return as<std::uint16_t>(raw);
      case PlyType::Int32:
        return as<std::int32_t>(raw);
      case PlyType::UInt32:
        return as<std::uint32_t>(raw);
      case PlyType::Float32:
        return as<float>(raw);
      case PlyType::Float64:
        return as<double>(raw);
    }
    return 0;
  }
  const std::string& path_;
  const std::string& bytes_;
  std::size_t pos_;
  bool swap_;
  const std::string* element_ = nullptr;
  long index_ = 0;
};

long property_index(const PlyElement& element, std::initializer_list<const char*> names) {
  for (std::size_t p = 0; p < element.properties.size(); ++p)
    for (const char* name : names)
      if (element.properties[p].name == name) return long(p);
  return -1;
}

long declared_vertex_count(const PlyHeader& header) {
  for (const auto& e : header.elements)
    if (e.name == "vertex") return e.count;
  return 0;
}

void validate_ply_elements(const std::string& path, const PlyHeader& header) {
  for (const auto& e : header.elements) {
    if (e.name == "vertex") {
      for (const char* axis : {"x", "y", "z"})
        if (property_index(e, {axis}) < 0)
          throw InputError(
              fmt::format("mesh file '{}': the PLY vertex element has no '{}' "
                          "property; export positions as x, y, z",
                          path, axis));
    } else if (e.name == "face") {
      const long p = property_index(e, {"vertex_indices", "vertex_index"});
      if (p < 0 || !e.properties[p].is_list)
        throw InputError(
            fmt::format("mesh file '{}': the PLY face element has no list "
                        "property 'vertex_indices' (or 'vertex_index')",
                        path));
    }
  }
}

template <typename Source>
void read_ply_instance(const std::string& path, const PlyElement& element, long index,
                       Source& source, long vertex_count, TriangleMesh& mesh,
                       std::vector<int>& polygon) {
  source.begin(element.name, index);
  const bool is_vertex = element.name == "vertex", is_face = element.name == "face";
  Vector3d position(0, 0, 0);
  for (const PlyProperty& property : element.properties) {
    if (!property.is_list) {
      const double value = source.next(property.type);
      if (is_vertex && property.name.size() == 1 && property.name[0] >= 'x' &&
          property.name[0] <= 'z')
        position[property.name[0] - 'x'] = value;
      continue;
    }
    const double count = source.next(property.count_type);
    if (!(count >= 0) || count > 1e6)
      throw InputError(fmt::format("mesh file '{}', {}: list length {} is invalid", path,
                                   source.where(element.name, index), count));
    const bool indices =
        is_face && (property.name == "vertex_indices" || property.name == "vertex_index");
    if (indices) polygon.clear();
    for (long c = 0; c < long(count); ++c) {
      const double value = source.next(property.type);
      if (!indices) continue;
      if (!(value >= 0 && value < vertex_count) || value != std::floor(value))
        throw InputError(
            fmt::format("mesh file '{}', {}: vertex index {} is out of range "
                        "(the file declares {} vertices)",
                        path, source.where(element.name, index), value, vertex_count));
      polygon.push_back(int(value));
    }
    if (indices && polygon.size() < 3)
      throw InputError(fmt::format("mesh file '{}', {}: a face needs at least three vertices", path,
                                   source.where(element.name, index)));
    if (indices) add_fan(mesh, polygon);
  }
  if (is_vertex) {
    require_finite(path, source.where(element.name, index), position);
    mesh.vertices.push_back(position);
  }
}

template <typename Source>
TriangleMesh read_ply_body(const std::string& path, const PlyHeader& header, Source& source) {
  TriangleMesh mesh;
  const long vertex_count = declared_vertex_count(header);
  std::vector<int> polygon;
  for (const PlyElement& element : header.elements)
    for (long i = 0; i < element.count; ++i)
      read_ply_instance(path, element, i, source, vertex_count, mesh, polygon);
  return mesh;
}

TriangleMesh load_ply(const std::string& path, const std::string& bytes) {
  const PlyHeader header = parse_ply_header(path, bytes);
  validate_ply_elements(path, header);
  TriangleMesh mesh;
  if (header.format == PlyFormat::Ascii) {
    PlyAsciiSource source(path, bytes, header);
    mesh = read_ply_body(path, header, source);
  } else {
    PlyBinarySource source(path, bytes, header);
    mesh = read_ply_body(path, header, source);
  }
  require_faces(path, mesh);
  return mesh;
}

// ---------------------------------------------------------------------------------------
// STL (triangle soup; identical corner positions are merged into one vertex)

class VertexWelder {
 public:
  explicit VertexWelder(TriangleMesh& mesh) : mesh_(mesh) {}
  int add(const Vector3d& v) {
    const auto [it, inserted] = ids_.try_emplace({v.x(), v.y(), v.z()}, int(mesh_.vertices.size()));
    if (inserted) mesh_.vertices.push_back(v);
    return it->second;
  }

 private:
  TriangleMesh& mesh_;
  std::map<std::array<double, 3>, int> ids_;
};

bool is_binary_stl(const std::string& bytes) {
  if (bytes.size() < 84) return false;
  std::uint32_t count;
  std::memcpy(&count, bytes.data() + 80, 4);  // little endian hosts only (x86, ARM)
  return bytes.size() == 84 + 50 * std::uint64_t(count);
}

TriangleMesh load_binary_stl(const std::string& path, const std::string& bytes) {
  TriangleMesh mesh;
  VertexWelder welder(mesh);
  const std::size_t count = (bytes.size() - 84) / 50;
  for (std::size_t t = 0; t < count; ++t) {
    const char* record = bytes.data() + 84 + 50 * t + 12;  // skip the normal
    Eigen::Vector3i face;
    for (int c = 0; c < 3; ++c) {
      float xyz[3];
      std::memcpy(xyz, record + 12 * c, 12);
      const Vector3d v(xyz[0], xyz[1], xyz[2]);
      require_finite(path, fmt::format("triangle {}", t), v);
      face[c] = welder.add(v);
    }
    mesh.faces.push_back(face);
  }
  return mesh;
}

TriangleMesh load_ascii_stl(const std::string& path, const std::string& text) {
  TriangleMesh mesh;
  VertexWelder welder(mesh);
  LineReader reader(text);
  std::string_view line;
  std::vector<int> polygon;
  while (reader.next(line)) {
    const auto tokens = split(line);
    if (tokens.empty()) continue;
    if (tokens[0] == "outer") {
      polygon.clear();
    } else if (tokens[0] == "vertex") {
      Vector3d v;
      if (tokens.size() < 4) fail_at_line(path, reader.line_number(), "'vertex' needs x y z");
      for (int a = 0; a < 3; ++a)
        if (!parse_number(tokens[1 + a], v[a]))
          fail_at_line(path, reader.line_number(),
                       fmt::format("'{}' is not a number", tokens[1 + a]));
      require_finite(path, fmt::format("line {}", reader.line_number()), v);
      polygon.push_back(welder.add(v));
    } else if (tokens[0] == "endloop") {
      if (polygon.size() < 3)
        fail_at_line(path, reader.line_number(), "a facet needs at least three vertices");
      add_fan(mesh, polygon);
      polygon.clear();
    }
  }
  return mesh;
}

TriangleMesh load_stl(const std::string& path, const std::string& bytes) {
  TriangleMesh mesh;
  if (is_binary_stl(bytes)) {
    mesh = load_binary_stl(path, bytes);
  } else if (bytes.compare(0, 5, "solid") == 0) {
    mesh = load_ascii_stl(path, bytes);
  } else {
    throw InputError(fmt::format(
        "mesh file '{}' is neither ASCII STL (starting with 'solid') nor binary STL (84 + 50 "
        "bytes per triangle, it has {} bytes); the file is truncated or not an STL file",
        path, bytes.size()));
  }
  require_faces(path, mesh);
  return mesh;
}

std::string extension_of(const std::string& path) {
  const std::size_t slash = path.find_last_of("/\\");
  const std::size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  return lower(path.substr(dot));
}

}  // namespace

TriangleMesh load_mesh(const std::string& path) {
  const std::string extension = extension_of(path);
  if (extension != ".obj" && extension != ".ply" && extension != ".stl")
    throw InputError(
        fmt::format("mesh file '{}' has an unsupported extension '{}'; supported "
                    "are .obj, .ply and .stl (or give an .sdf file instead)",
                    path, extension));
  const std::string bytes = read_whole_file(path);
  if (extension == ".obj") return load_obj(path, bytes);
  if (extension == ".ply") return load_ply(path, bytes);
  return load_stl(path, bytes);
}

}  // namespace ssc
