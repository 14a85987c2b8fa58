// Owned, atomic, locked output folders (see output_dir.h).
#include "models/io/output_dir.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <signal.h>
#include <stdio.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <set>

#include "models/io/errors.h"
#include "models/io/run_record.h"

namespace ssc {
namespace fs = std::filesystem;
namespace {

// Unfinished temporary folders and lock files of this process, for the signal handler.
std::mutex registry_mutex;
std::set<std::string> unfinished;

void register_unfinished(const std::string& p) {
  std::lock_guard<std::mutex> lock(registry_mutex);
  unfinished.insert(p);
}
void forget_unfinished(const std::string& p) {
  std::lock_guard<std::mutex> lock(registry_mutex);
  unfinished.erase(p);
}

fs::path absolute_normal(const std::string& p) {
  std::error_code ec;
  fs::path a = fs::weakly_canonical(fs::absolute(p), ec);
  if (ec) a = fs::absolute(p).lexically_normal();
  if (!a.has_filename() && a.has_parent_path() && a != a.root_path()) a = a.parent_path();  // "out/" -> "out"
  return a;
}

// True if `parent` is `child` or one of its ancestors.
bool is_same_or_parent(const fs::path& parent, const fs::path& child) {
  auto p = parent.begin(), c = child.begin();
  for (; p != parent.end(); ++p, ++c)
    if (c == child.end() || *p != *c) return false;
  return true;
}

void refuse(const std::string& target, const std::string& why) {
  throw InputError(fmt::format("--out {}: {}; ssc writes only into a new folder, an empty one, or a folder an "
                               "earlier ssc run made (it holds {}): choose another --out",
                               target, why, kManifestName));
}

void check_target(const std::string& target, const fs::path& t, const std::vector<std::string>& protected_inputs) {
  if (t == t.root_path()) refuse(target, "is the root of the filesystem");
  if (const char* home = std::getenv("HOME"); home && *home && t == absolute_normal(home)) refuse(target, "is your home folder");
  if (is_same_or_parent(t, absolute_normal(fs::current_path().string())))
    refuse(target, "is the working folder or one of its parents");
  for (const std::string& input : protected_inputs)
    if (!input.empty() && is_same_or_parent(t, absolute_normal(input)))
      refuse(target, fmt::format("holds the input {}", input));
  std::error_code ec;
  const fs::file_status link = fs::symlink_status(t, ec);
  if (fs::is_symlink(link)) refuse(target, "is a symbolic link");
  if (!fs::exists(link)) return;
  if (!fs::is_directory(link)) refuse(target, "is a file, not a folder");
  if (fs::is_empty(t, ec)) return;
  if (!is_ssc_output(t.string())) refuse(target, fmt::format("is a folder that ssc did not make (no {} in it)", kManifestName));
}

bool process_alive(long pid) { return pid > 0 && (::kill(pid_t(pid), 0) == 0 || errno == EPERM); }

// Removes NAME.tmp-PID and NAME.old-PID left by processes that no longer run.
void remove_stale_siblings(const fs::path& t) {
  std::error_code ec;
  const std::string name = t.filename().string();
  for (const fs::directory_entry& e : fs::directory_iterator(t.parent_path(), ec)) {
    const std::string n = e.path().filename().string();
    for (const char* tag : {".tmp-", ".old-"}) {
      const std::string prefix = name + tag;
      if (n.rfind(prefix, 0) != 0) continue;
      char* end = nullptr;
      const long pid = std::strtol(n.c_str() + prefix.size(), &end, 10);
      if (*end != 0 || process_alive(pid) || !is_ssc_output(e.path().string())) continue;
      std::error_code rm;
      fs::remove_all(e.path(), rm);
      if (!rm) std::fprintf(stderr, "ssc: removed %s, left by an ssc run (pid %ld) that ended early\n", e.path().c_str(), pid);
    }
  }
}

// Swaps two paths atomically; false where the filesystem cannot.
bool exchange(const fs::path& a, const fs::path& b) {
#ifdef RENAME_EXCHANGE
  return ::renameat2(AT_FDCWD, a.c_str(), AT_FDCWD, b.c_str(), RENAME_EXCHANGE) == 0;
#else
  return false;
#endif
}

}  // namespace

bool is_ssc_output(const std::string& folder) {
  std::ifstream in(fs::path(folder) / kManifestName);
  if (!in) return false;
  try {
    const nlohmann::json j = nlohmann::json::parse(in);
    return j.is_object() && j.value("ssc_output", false) == true;
  } catch (const nlohmann::json::exception&) {
    return false;
  }
}

void remove_unfinished_outputs() {
  std::lock_guard<std::mutex> lock(registry_mutex);
  for (const std::string& p : unfinished) {
    std::error_code ec;
    fs::remove_all(p, ec);
  }
  unfinished.clear();
}

OutputDir::OutputDir(const std::string& target, const std::vector<std::string>& protected_inputs) : target_(target) {
  if (target.empty()) throw InputError("--out: the output folder name is empty; give a folder to write");
  fs::path given = fs::absolute(target).lexically_normal();
  if (!given.has_filename() && given != given.root_path()) given = given.parent_path();
  std::error_code link_ec;
  if (fs::is_symlink(fs::symlink_status(given, link_ec))) refuse(target, "is a symbolic link");
  const fs::path t = absolute_normal(target);
  check_target(target, t, protected_inputs);
  std::error_code ec;
  fs::create_directories(t.parent_path(), ec);
  if (ec) throw InputError(fmt::format("--out {}: cannot create the parent folder: {}", target, ec.message()));

  lock_ = t.string() + ".lock";
  lock_fd_ = ::open(lock_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (lock_fd_ < 0) throw InputError(fmt::format("--out {}: cannot create the lock file {}; is the folder writable?", target, lock_));
  struct stat held {}, named {};
  // The lock must be on the file that still has the name (an ending run removes its lock file).
  if (::flock(lock_fd_, LOCK_EX | LOCK_NB) != 0 || ::fstat(lock_fd_, &held) != 0 || ::stat(lock_.c_str(), &named) != 0 ||
      held.st_ino != named.st_ino) {
    ::close(lock_fd_);
    lock_fd_ = -1;
    throw InputError(fmt::format("--out {}: another ssc run is writing this folder (it holds {}); wait for it to end or "
                                 "choose another --out", target, lock_));
  }
  register_unfinished(lock_);
  check_target(target, t, protected_inputs);  // again, now that no other run can change it
  remove_stale_siblings(t);

  target_ = t.string();
  temp_ = fmt::format("{}.tmp-{}", target_, long(::getpid()));
  register_unfinished(temp_);
  fs::remove_all(temp_, ec);
  fs::create_directories(temp_, ec);
  if (ec) throw InputError(fmt::format("--out {}: cannot create the output folder: {}", target, ec.message()));
  write_manifest("running");
}

OutputDir::~OutputDir() {
  std::error_code ec;
  if (!committed_) fs::remove_all(temp_, ec);
  forget_unfinished(temp_);
  if (lock_fd_ >= 0) {
    fs::remove(lock_, ec);
    ::close(lock_fd_);
  }
  forget_unfinished(lock_);
}

std::string OutputDir::file(const std::string& relative) const { return (fs::path(temp_) / relative).string(); }

void OutputDir::write_manifest(const std::string& status) const {
  nlohmann::json j = run_provenance();
  j["ssc_output"] = true;
  j["status"] = status;
  for (const auto& [key, value] : manifest_.items()) j[key] = value;
  j["warnings"] = warnings_json();
  if (status == "complete") {
    j["ended"] = utc_time_now();
    j["exit_status"] = 0;
  }
  const std::string path = file(kManifestName);
  std::ofstream f(path);
  f << j.dump(2) << "\n";
  f.close();
  if (!f) throw InputError(fmt::format("{}: cannot write the manifest; is the disk full?", path));
}

void OutputDir::commit() {
  write_manifest("complete");
  std::error_code ec;
  const fs::path target(target_), temp(temp_);
  if (fs::exists(fs::symlink_status(target, ec)) && exchange(temp, target)) {
    // temp_ now holds the previous output.
    fs::remove_all(temp, ec);
  } else if (fs::exists(fs::symlink_status(target, ec))) {
    const fs::path old = fmt::format("{}.old-{}", target_, long(::getpid()));
    fs::rename(target, old, ec);
    if (ec) throw InputError(fmt::format("{}: cannot move the previous output aside: {}", target_, ec.message()));
    fs::rename(temp, target, ec);
    if (ec) {
      std::error_code back;
      fs::rename(old, target, back);
      throw InputError(fmt::format("{}: cannot move the finished output into place: {}", target_, ec.message()));
    }
    fs::remove_all(old, ec);
  } else {
    fs::rename(temp, target, ec);
    if (ec) throw InputError(fmt::format("{}: cannot move the finished output into place: {}", target_, ec.message()));
  }
  committed_ = true;
  forget_unfinished(temp_);
}

}  // namespace ssc
