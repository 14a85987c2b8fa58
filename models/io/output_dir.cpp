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
#include <optional>
#include <algorithm>
#include <set>
#include <thread>
#include <chrono>

#include "runtime/errors.h"
#include "runtime/ranks.h"
#include "models/io/run_record.h"
#include "models/io/text_file.h"
#include "models/io/write_error.h"

namespace ssc {
namespace fs = std::filesystem;
namespace {

// Unfinished temporary folders and lock files of this process, for the signal handler. The
// mutex is also held while commit() swaps folders, so that an interrupt never falls between
// moving the old output aside and moving the new one in.
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

std::string host_name() {
  char host[256] = {0};
  return gethostname(host, sizeof host - 1) == 0 ? host : "";
}

fs::path absolute_normal(const std::string& p) {
  std::error_code ec;
  fs::path a = fs::weakly_canonical(fs::absolute(p, ec), ec);
  if (ec) a = fs::absolute(p, ec).lexically_normal();
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

[[noreturn]] void refuse(const std::string& target, const std::string& why) {
  throw InputError(fmt::format("--out {}: {}; ssc writes only into a new folder, an empty one, or a folder an "
                               "earlier ssc run made (it holds {}): choose another --out",
                               target, why, kManifestName));
}

std::optional<nlohmann::json> read_manifest(const fs::path& folder) {
  std::ifstream in(folder / kManifestName);
  if (!in) return std::nullopt;
  try {
    nlohmann::json j = nlohmann::json::parse(in);
    if (j.is_object() && j.value("ssc_output", false) == true) return j;
  } catch (const nlohmann::json::exception&) {
  }
  return std::nullopt;
}

// Every regular file under `folder`, relative, sorted; the manifest itself left out.
std::vector<std::string> files_under(const fs::path& folder) {
  std::vector<std::string> files;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(folder, ec); !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (it->is_directory(ec)) continue;
    const std::string rel = fs::relative(it->path(), folder, ec).generic_string();
    if (rel != kManifestName) files.push_back(rel);
  }
  std::sort(files.begin(), files.end());
  return files;
}

// Empty if `t` may be replaced by an output: absent, an empty folder, or an ssc output
// holding only the files its manifest lists; else why not.
std::string why_not_replaceable(const fs::path& t) {
  std::error_code ec;
  const fs::file_status status = fs::symlink_status(t, ec);
  if (!fs::exists(status)) return "";
  if (fs::is_symlink(status)) return "is a symbolic link";
  if (!fs::is_directory(status)) return "is a file, not a folder";
  if (fs::is_empty(t, ec)) return "";
  const std::optional<nlohmann::json> manifest = read_manifest(t);
  if (!manifest) return fmt::format("is a folder that ssc did not make (no {} in it)", kManifestName);
  if (!manifest->contains("files")) return "";  // an output of an ssc that did not list its files
  const std::vector<std::string> listed = manifest->at("files").get<std::vector<std::string>>();
  for (const std::string& f : files_under(t))
    if (!std::binary_search(listed.begin(), listed.end(), f))
      return fmt::format("holds {}, which ssc did not write (move it out first)", f);
  return "";
}

void check_target(const std::string& target, const fs::path& given, const fs::path& t,
                  const std::vector<std::string>& protected_inputs) {
  std::error_code ec;
  if (fs::is_symlink(fs::symlink_status(given, ec))) refuse(target, "is a symbolic link");
  if (t == t.root_path()) refuse(target, "is the root of the filesystem");
  if (const char* home = std::getenv("HOME"); home && *home && t == absolute_normal(home)) refuse(target, "is your home folder");
  const fs::path cwd = fs::current_path(ec);
  if (!ec && is_same_or_parent(t, absolute_normal(cwd.string()))) refuse(target, "is the working folder or one of its parents");
  for (const std::string& input : protected_inputs) {
    if (input.empty()) continue;
    const fs::path in = absolute_normal(input);
    if (is_same_or_parent(t, in)) refuse(target, fmt::format("holds the input {}", input));
    if (fs::is_directory(in, ec) && is_same_or_parent(in, t))
      refuse(target, fmt::format("is inside the input folder {} (the run would add its output to what it reads)", input));
  }
  if (const std::string why = why_not_replaceable(t); !why.empty()) refuse(target, why);
}

bool process_alive(long pid) { return pid > 0 && (::kill(pid_t(pid), 0) == 0 || errno == EPERM); }

// Removes .NAME.ssc-tmp-PID, .NAME.ssc-old-PID and .NAME.ssc-del-PID left by a process of
// this host that no longer runs: only folders whose manifest names that process and host.
void remove_stale_siblings(const fs::path& t) {
  std::error_code ec;
  const std::string name = t.filename().string();
  const std::string host = host_name();
  for (auto it = fs::directory_iterator(t.parent_path(), ec); !ec && it != fs::directory_iterator(); it.increment(ec)) {
    const std::string n = it->path().filename().string();
    for (const char* tag : {".ssc-tmp-", ".ssc-old-", ".ssc-del-"}) {
      const std::string prefix = "." + name + tag;
      if (n.rfind(prefix, 0) != 0) continue;
      char* end = nullptr;
      const long pid = std::strtol(n.c_str() + prefix.size(), &end, 10);
      const std::optional<nlohmann::json> m = read_manifest(it->path());
      if (*end != 0 || process_alive(pid) || !m || m->value("pid", -1L) != pid || m->value("host", std::string()) != host) continue;
      std::error_code rm;
      fs::remove_all(it->path(), rm);
      if (!rm) std::fprintf(stderr, "ssc: removed %s, left by an ssc run (pid %ld) that ended early\n", it->path().c_str(), pid);
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

bool is_ssc_output(const std::string& folder) { return read_manifest(folder).has_value(); }

void remove_unfinished_outputs(bool hold_until_exit) {
  registry_mutex.lock();
  for (const std::string& p : unfinished) {
    std::error_code ec;
    if (!fs::is_directory(fs::symlink_status(p, ec))) {
      fs::remove(p, ec);  // a lock file
      continue;
    }
    // The writer may still be adding files: move the folder away in one step, so that its
    // next write fails (its path is gone) instead of landing in a folder being removed.
    std::string aside = p;
    const size_t tag = aside.rfind(".ssc-tmp-");
    aside = tag == std::string::npos ? aside + ".ssc-del" : aside.replace(tag, 9, ".ssc-del-");
    fs::rename(p, aside, ec);
    const fs::path gone = ec ? fs::path(p) : fs::path(aside);
    // A file whose creation was under way during the rename may still appear: try again.
    for (int attempt = 0; attempt < 200 && fs::exists(fs::symlink_status(gone, ec)); ++attempt) {
      if (attempt > 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
      fs::remove_all(gone, ec);
    }
  }
  unfinished.clear();
  if (!hold_until_exit) registry_mutex.unlock();  // else never: no OutputDir finishes any more
}

OutputDir::OutputDir(const std::string& target, const std::vector<std::string>& protected_inputs) : target_(target) {
  if (target.empty()) throw InputError("--out: the output folder name is empty; give a folder to write");
  std::error_code ec;
  fs::path given = fs::absolute(target, ec).lexically_normal();
  if (!given.has_filename() && given != given.root_path()) given = given.parent_path();
  const fs::path t = absolute_normal(target);
  check_target(target, given, t, protected_inputs);
  if (ranks::rank() > 0) {  // rank 0 writes the output; another rank's copy goes to scratch and away
    const fs::path scratch = fs::temp_directory_path(ec);
    if (ec)
      throw InputError(fmt::format("no temporary folder for this rank's scratch copy of the output ({}); set TMPDIR "
                                   "to a writable folder", ec.message()));
    temp_ = (scratch / fmt::format("ssc-rank-{}-{}", ranks::rank(), long(::getpid()))).string();
    register_unfinished(temp_);
    fs::remove_all(temp_, ec);
    fs::create_directories(temp_, ec);
    if (ec) throw InputError(fmt::format("cannot create this rank's scratch folder {}: {}", temp_, ec.message()));
    return;
  }
  fs::create_directories(t.parent_path(), ec);
  if (ec) throw InputError(fmt::format("--out {}: cannot create the parent folder: {}", target, ec.message()));

  const std::string hidden = (t.parent_path() / ("." + t.filename().string())).string();
  lock_ = hidden + ".ssc-lock";
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
  target_ = t.string();
  temp_ = fmt::format("{}.ssc-tmp-{}", hidden, long(::getpid()));
  try {
    check_target(target, given, t, protected_inputs);  // again, now that no other ssc run can change it
    remove_stale_siblings(t);
    register_unfinished(temp_);
    fs::remove_all(temp_, ec);
    fs::create_directories(temp_, ec);
    if (ec) throw InputError(fmt::format("--out {}: cannot create the output folder: {}", target, ec.message()));
    write_manifest("running");
  } catch (...) {
    release();
    throw;
  }
}

OutputDir::~OutputDir() { release(); }

void OutputDir::release() {
  std::error_code ec;
  if (!committed_ && !temp_.empty()) fs::remove_all(temp_, ec);
  forget_unfinished(temp_);
  if (lock_fd_ >= 0) {
    fs::remove(lock_, ec);
    ::close(lock_fd_);
    lock_fd_ = -1;
  }
  forget_unfinished(lock_);
}

std::string OutputDir::file(const std::string& relative) const { return (fs::path(temp_) / relative).string(); }

std::string OutputDir::make_folder(const std::string& relative) const {
  create_folders_below(temp_, relative);
  return file(relative);
}

void create_folders_below(const std::string& folder, const std::string& relative) {
  fs::path p(folder);
  for (const fs::path& part : fs::path(relative).lexically_normal()) {
    p /= part;
    std::error_code ec;
    if (!fs::create_directory(p, ec) && ec) throw_write_error(p.string(), ec.value(), "create the folder");
  }
}

void OutputDir::write_manifest(const std::string& status) const {
  nlohmann::json j = run_provenance();
  j["ssc_output"] = true;
  j["status"] = status;
  j["pid"] = long(::getpid());
  j["host"] = host_name();
  for (const auto& [key, value] : manifest_.items()) j[key] = value;
  j["warnings"] = warnings_json();
  if (status == "complete") {
    j["ended"] = utc_time_now();
    j["exit_status"] = 0;
    j["files"] = files_under(temp_);
  }
  write_text_file(file(kManifestName), j.dump(2) + "\n");
}

void OutputDir::commit() {
  write_manifest("complete");
  if (ranks::rank() > 0) {
    release();  // not committed: the scratch copy goes
    return;
  }
  const fs::path target(target_), temp(temp_);
  // What is there now may have changed since the run began (a user's file copied in).
  if (const std::string why = why_not_replaceable(target); !why.empty()) refuse(target_, why);
  std::lock_guard<std::mutex> no_interrupt(registry_mutex);
  std::error_code ec;
  if (fs::exists(fs::symlink_status(target, ec)) && exchange(temp, target)) {
    fs::remove_all(temp, ec);  // the previous output
  } else if (fs::exists(fs::symlink_status(target, ec))) {
    const fs::path old = fmt::format("{}.ssc-old-{}", (target.parent_path() / ("." + target.filename().string())).string(),
                                     long(::getpid()));
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
  unfinished.erase(temp_);
}

}  // namespace ssc
