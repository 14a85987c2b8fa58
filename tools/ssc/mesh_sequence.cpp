// Mesh frame lists and frame times for `ssc render` (see mesh_sequence.h).
#include "tools/ssc/mesh_sequence.h"

#include <fmt/format.h>
#include <glob.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "runtime/errors.h"

namespace ssc {
namespace fs = std::filesystem;
namespace {

bool is_ply(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext == ".ply";
}

// Natural order of file names: digit runs compare by value, the rest by character.
bool name_before(const std::string& a, const std::string& b) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (std::isdigit((unsigned char)a[i]) && std::isdigit((unsigned char)b[j])) {
      size_t i2 = i, j2 = j;
      while (i2 < a.size() && std::isdigit((unsigned char)a[i2])) ++i2;
      while (j2 < b.size() && std::isdigit((unsigned char)b[j2])) ++j2;
      std::string x = a.substr(i, i2 - i), y = b.substr(j, j2 - j);
      x.erase(0, std::min(x.find_first_not_of('0'), x.size()));
      y.erase(0, std::min(y.find_first_not_of('0'), y.size()));
      if (x.size() != y.size()) return x.size() < y.size();
      if (x != y) return x < y;
      i = i2;
      j = j2;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i;
      ++j;
    }
  }
  return a.size() - i < b.size() - j || (a.size() - i == b.size() - j && a < b);
}

std::vector<std::string> glob_files(const std::string& pattern) {
  glob_t g{};
  const int rc = glob(pattern.c_str(), 0, nullptr, &g);
  std::vector<std::string> out;
  if (rc == 0)
    for (size_t i = 0; i < g.gl_pathc; ++i) out.emplace_back(g.gl_pathv[i]);
  globfree(&g);
  return out;
}

std::vector<double> parse_times(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw InputError(fmt::format("--times {}: cannot open the file", file));
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string text = buffer.str();
  std::vector<double> times;
  const size_t start = text.find_first_not_of(" \t\r\n");
  if (start != std::string::npos && text[start] == '[') {
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(text);
    } catch (const nlohmann::json::parse_error& e) {
      throw InputError(fmt::format("--times {}: malformed JSON ({})", file, e.what()));
    }
    for (const auto& v : j) {
      if (!v.is_number()) throw InputError(fmt::format("--times {}: {} is not a number of seconds", file, v.dump()));
      times.push_back(v.get<double>());
    }
    return times;
  }
  std::istringstream lines(text);
  std::string line;
  for (int n = 1; std::getline(lines, line); ++n) {
    line = line.substr(0, line.find('#'));
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::istringstream in(line);
    double t = 0;
    std::string rest;
    if (!(in >> t) || (in >> rest) || !std::isfinite(t))
      throw InputError(fmt::format("--times {}, line {}: '{}' is not one time in seconds", file, n, line));
    times.push_back(t);
  }
  return times;
}

}  // namespace

std::vector<std::string> list_mesh_frames(const std::vector<std::string>& arguments) {
  std::vector<std::string> files;
  for (const std::string& arg : arguments) {
    std::error_code ec;
    if (fs::is_directory(arg, ec)) {
      size_t found = 0;
      for (const auto& entry : fs::directory_iterator(arg, ec))
        if (entry.is_regular_file() && is_ply(entry.path())) {
          files.push_back(entry.path().string());
          ++found;
        }
      if (found == 0)
        throw InputError(fmt::format("{}: the folder holds no .ply file; give the folder of the mesh frames "
                                     "(one triangle-mesh PLY per frame)", arg));
    } else if (fs::exists(arg, ec)) {
      if (!is_ply(arg))
        throw InputError(fmt::format("{}: not a .ply file; ssc render reads one triangle-mesh PLY per frame", arg));
      files.push_back(arg);
    } else if (arg.find_first_of("*?[") != std::string::npos) {
      std::vector<std::string> matched = glob_files(arg);
      matched.erase(std::remove_if(matched.begin(), matched.end(), [](const std::string& f) { return !is_ply(f); }),
                    matched.end());
      if (matched.empty())
        throw InputError(fmt::format("{}: the pattern matches no .ply file; quote it so that ssc expands it, "
                                     "and check the folder", arg));
      files.insert(files.end(), matched.begin(), matched.end());
    } else {
      throw InputError(fmt::format("{}: no such file or folder; give the mesh frames as PLY files, a folder "
                                   "of them or a quoted glob pattern", arg));
    }
  }
  std::sort(files.begin(), files.end(), [](const std::string& a, const std::string& b) {
    return name_before(fs::path(a).filename().string(), fs::path(b).filename().string());
  });
  std::set<std::string> seen;
  for (const std::string& f : files)
    if (!seen.insert(fs::weakly_canonical(f).string()).second)
      throw InputError(fmt::format("{}: named twice among the mesh frames; give each frame once", f));
  return files;
}

FrameTimes frame_times(int frames, double fps, double dt, const std::string& times_file, double first) {
  const int given = (fps != 0) + (dt != 0) + !times_file.empty();
  if (given != 1)
    throw InputError("give the frames' times with exactly one of --fps F, --dt S or --times FILE");
  if (!std::isfinite(first)) throw InputError("--first-time must be a finite number of seconds");
  if (fps != 0) {
    if (!(fps > 0) || !std::isfinite(fps)) throw InputError(fmt::format("--fps {}: must be a positive frame rate (1/s)", fps));
    return {first, 1.0 / fps};
  }
  if (dt != 0) {
    if (!(dt > 0) || !std::isfinite(dt)) throw InputError(fmt::format("--dt {}: must be a positive time step (s)", dt));
    return {first, dt};
  }
  const std::vector<double> t = parse_times(times_file);
  if (int(t.size()) != frames)
    throw InputError(fmt::format("--times {}: lists {} times for {} mesh frames; give one time per frame", times_file,
                                 t.size(), frames));
  if (frames == 1) return {t[0], 1.0};
  const double step = (t.back() - t.front()) / (frames - 1);
  if (!(step > 0)) throw InputError(fmt::format("--times {}: the times must increase", times_file));
  for (int f = 0; f < frames; ++f)
    if (std::abs(t[f] - (t[0] + f * step)) > 1e-6 * step)
      throw InputError(fmt::format("--times {}: frame {} is at {} s, not at {} s of evenly spaced frames; the "
                                   "observation format (ssc-depth-v1) holds evenly spaced frames only: resample "
                                   "the meshes, or give --dt",
                                   times_file, f, t[f], t[0] + f * step));
  return {t[0], step};
}

}  // namespace ssc
