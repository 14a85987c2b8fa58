// An output folder that ssc owns, that appears complete or not at all, and that no user
// file is ever lost to.
//
// Ownership: a folder is ssc's only if it holds a manifest, ssc.json, with "ssc_output":
// true; the manifest lists the files the run wrote. The constructor refuses a target that is
// a file, a link, a folder with content but no manifest or with files the manifest does not
// list, the filesystem root, the home folder, the working folder or one of its parents, or a
// parent of (or the same path as) a protected input (the scene, its mesh, the observations).
// An empty folder is taken (nothing in it can be lost). commit() checks the target again.
// Atomicity: everything is written into the hidden sibling .NAME.ssc-tmp-PID, which holds
// its manifest (status "running", the process and host) from the start. commit() writes the
// final manifest and swaps the folder into place with renameat2(RENAME_EXCHANGE) (the old one
// is then removed), or, where the filesystem cannot exchange, by renaming the old folder
// aside (.NAME.ssc-old-PID) first.
// Concurrency: an flock on .NAME.ssc-lock keeps two runs off one target; the lock file is
// removed at the end. A .NAME.ssc-tmp-PID or .NAME.ssc-old-PID whose manifest names a
// process of this host that no longer runs is removed by the next run for the same target.
// Interruption: every unfinished temporary folder and lock is registered, and
// remove_unfinished_outputs() (called on SIGINT/SIGTERM, tools/ssc/interrupts.h)
// removes them while the command may still be writing: each folder is first renamed to
// .NAME.ssc-del-PID, so that the writer's next file fails instead of landing in it, and is
// then removed; no OutputDir finishes afterwards. Subfolders are made with make_folder (one
// level at a time), which cannot bring back a folder that was moved away.
// Ranks: in an MPI run (runtime/ranks.h) rank 0 alone writes the output; every other rank
// checks the target as rank 0 does, writes into a scratch folder of its own in the system's
// temporary folder, and commit() removes that.
#pragma once
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace ssc {

class OutputDir {
 public:
  // protected_inputs: paths the output may not be (or contain).
  explicit OutputDir(const std::string& target, const std::vector<std::string>& protected_inputs = {});
  ~OutputDir();
  OutputDir(const OutputDir&) = delete;
  OutputDir& operator=(const OutputDir&) = delete;

  const std::string& path() const { return temp_; }  // write here
  std::string file(const std::string& relative) const;
  // Creates the subfolder (and those between) and returns its path, like file().
  std::string make_folder(const std::string& relative) const;
  // What the command adds to ssc.json (scene, observations, device, warnings, ...).
  nlohmann::json& manifest() { return manifest_; }
  void commit();

 private:
  void write_manifest(const std::string& status) const;
  void release();  // removes the unfinished folder and the lock
  std::string target_, temp_, lock_;
  int lock_fd_ = -1;
  bool committed_ = false;
  nlohmann::json manifest_ = nlohmann::json::object();
};

// The manifest's file name and its ownership check (true if `folder` holds one of ssc's).
inline constexpr const char* kManifestName = "ssc.json";
bool is_ssc_output(const std::string& folder);

// Creates folder/relative one level at a time below `folder`, which must exist (so a folder
// removed meanwhile is not made again); an input/output error naming the path otherwise.
void create_folders_below(const std::string& folder, const std::string& relative);

// Removes every temporary folder and lock that a running OutputDir holds, also while another
// thread is still writing into them. hold_until_exit: and keep every OutputDir from finishing
// (committing, releasing) afterwards, for the signal-handling thread right before it ends the
// process.
void remove_unfinished_outputs(bool hold_until_exit = false);

}  // namespace ssc
