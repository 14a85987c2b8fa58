// The workers a batch's independent items are shared among. Under MPI (runtime/ranks.h) each
// rank takes a contiguous share of the items, in rank order; within a rank each GPU the device
// names (models/sim/compute_device.h) takes a contiguous part of that share, on a host thread
// of its own; on the CPU the rank is one worker, whose OpenMP threads share its items. An
// item's result does not depend on which items run beside it (every solve, reduction and
// convergence test is per item), so a run split over GPUs or ranks gives the items the bits one
// GPU gives them, as long as each GPU keeps the blocks per item it would choose for the whole
// batch (runtime/cuda_runtime.cpp, grid_blocks: true unless the batch fills the GPU).
#pragma once
#include <exception>
#include <functional>
#include <string>
#include <vector>

namespace ssc {

struct BatchShare {
  int begin = 0, end = 0;  // items [begin, end) of the batch
  std::string device;      // "cpu" or "cuda:K"
  int worker = 0;          // this rank's worker: the same GPU (or the CPU) in every call
  bool reports = false;    // the worker whose progress stands for the run's (rank 0's first)
};

// This rank's parts of a batch of n items, one per worker that has any.
std::vector<BatchShare> this_rank_shares(int n, const std::string& device);

// Runs run(share) for each of this rank's shares, one host thread per share where there are
// several; run returns one string per item of its share. Returns every item's string, in item
// order, on every rank. An exception in a share is rethrown after every share ended, on every
// rank, as the same type (InputError, SimulationError with its items as indices into the whole
// batch, GpuError, else std::runtime_error), its message prefixed with the rank and host where
// there are several ranks.
std::vector<std::string> run_shared(int n, const std::string& device,
                                    const std::function<std::vector<std::string>(const BatchShare&)>& run);

// The two halves of run_shared's exchange, apart for tests. A rank's outcome as bytes: its
// shares' strings in order, or the first failed share's error (kind, host, message, items).
std::string rank_outcome(const std::vector<BatchShare>& shares, const std::vector<std::vector<std::string>>& results,
                         const std::vector<std::exception_ptr>& errors);
// Every rank's outcome, in rank order, as the n items' strings; a failed rank's error is
// thrown as its type, the message prefixed "rank R of K (host H): ".
std::vector<std::string> merge_rank_outcomes(const std::vector<std::string>& outcomes, int n);

// The end of a run of several ranks, on every rank: unless a shared batch already told every
// rank of a failure, each rank posts its own outcome (null: success) once more, so that a rank
// that failed on its own leaves no other waiting for it in a batch. Returns this rank's error,
// else the first failed rank's (named, as merge_rank_outcomes names it), else null.
std::exception_ptr agree_on_outcome(const std::exception_ptr& mine);

}  // namespace ssc
