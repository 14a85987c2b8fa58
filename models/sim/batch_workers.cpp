// Sharing a batch's items among GPUs and ranks (see batch_workers.h).
#include "models/sim/batch_workers.h"

#include <fmt/format.h>

#include <atomic>
#include <exception>
#include <thread>

#include "models/io/byte_record.h"
#include "models/sim/compute_device.h"
#include "runtime/cuda_runtime.h"
#include "runtime/errors.h"
#include "runtime/nvrtc_compiler.h"
#include "runtime/ranks.h"

namespace ssc {
namespace {

// Part k of n items split into `parts` contiguous parts, the first n % parts one larger.
std::pair<int, int> part(int n, int parts, int k) {
  const int base = n / parts, extra = n % parts;
  const int begin = k * base + std::min(k, extra);
  return {begin, begin + base + (k < extra ? 1 : 0)};
}

enum class ErrorKind : char { Input = 'I', Simulation = 'S', Gpu = 'G', Other = 'X' };

// A share's outcome as bytes: 'K' and its items' strings, or 'E', the error's kind, message and
// the simulation's failed items (batch indices).
std::string encode_error(const std::exception_ptr& error, int share_begin) {
  ByteWriter w;
  w.put('E');
  ErrorKind kind = ErrorKind::Other;
  std::string what;
  std::vector<int> items;
  try {
    std::rethrow_exception(error);
  } catch (const InputError& e) {
    kind = ErrorKind::Input, what = e.what();
  } catch (const SimulationError& e) {
    kind = ErrorKind::Simulation, what = e.what();
    for (int i : e.items) items.push_back(share_begin + i);
  } catch (const GpuError& e) {
    kind = ErrorKind::Gpu, what = e.what();
  } catch (const GpuUnavailable& e) {
    kind = ErrorKind::Gpu, what = e.what();
  } catch (const NvrtcError& e) {
    kind = ErrorKind::Gpu, what = e.what();
  } catch (const std::exception& e) {
    what = e.what();
  } catch (...) {
    what = "an unknown error";
  }
  w.put(kind);
  w.put_string(ranks::host());
  w.put_string(what);
  w.put_vector(items);
  return w.bytes();
}

[[noreturn]] void throw_error(ErrorKind kind, const std::string& what, const std::vector<int>& items) {
  switch (kind) {
    case ErrorKind::Input:
      throw InputError(what);
    case ErrorKind::Simulation:
      throw SimulationError(what, items);
    case ErrorKind::Gpu:
      throw GpuError(what);
    default:
      throw std::runtime_error(what);
  }
}

// Whether a shared batch told this rank of a failure (every rank then knows of it).
std::atomic<bool> failure_shared{false};

// The first failed rank's error in outcomes, or null; the others' items are not read.
std::exception_ptr first_failure(const std::vector<std::string>& outcomes) {
  for (size_t r = 0; r < outcomes.size(); ++r) {
    ByteReader outer(outcomes[r]);
    const std::string body = outer.get_string();
    ByteReader in(body);
    if (in.get<char>() != 'E') continue;
    const ErrorKind kind = in.get<ErrorKind>();
    const std::string host = in.get_string();
    const std::string what = in.get_string();
    try {
      throw_error(kind, fmt::format("rank {} of {} (host {}): {}", r, outcomes.size(), host, what), in.get_vector<int>());
    } catch (...) {
      return std::current_exception();
    }
  }
  return nullptr;
}

}  // namespace

std::vector<BatchShare> this_rank_shares(int n, const std::string& device) {
  const auto [begin, end] = part(n, ranks::count(), ranks::rank());
  std::vector<std::string> devices;
  if (runs_on_gpu(device))
    for (int g : device_gpus(device)) devices.push_back(gpu_device(g));
  else
    devices.push_back("cpu");
  std::vector<BatchShare> shares;
  const int workers = std::max(1, std::min(int(devices.size()), end - begin));
  for (int k = 0; k < workers; ++k) {
    const auto [b, e] = part(end - begin, workers, k);
    if (e > b || (n == 0 && k == 0))
      shares.push_back(BatchShare{begin + b, begin + e, devices[size_t(k)], k, ranks::rank() == 0 && k == 0});
  }
  return shares;
}

std::vector<std::string> run_shared(int n, const std::string& device,
                                    const std::function<std::vector<std::string>(const BatchShare&)>& run) {
  const std::vector<BatchShare> shares = this_rank_shares(n, device);
  std::vector<std::vector<std::string>> results(shares.size());
  std::vector<std::exception_ptr> errors(shares.size());
  auto one = [&](size_t k) {
    try {
      results[k] = run(shares[k]);
      if (int(results[k].size()) != shares[k].end - shares[k].begin)
        throw std::logic_error("run_shared: a share returned a result count unlike its item count");
    } catch (...) {
      errors[k] = std::current_exception();
    }
  };
  if (shares.size() == 1) {
    one(0);
  } else {
    std::vector<std::thread> threads;
    for (size_t k = 0; k < shares.size(); ++k) threads.emplace_back(one, k);
    for (std::thread& t : threads) t.join();
  }
  if (ranks::count() == 1) {
    for (const std::exception_ptr& e : errors)
      if (e) {
        try {
          std::rethrow_exception(e);
        } catch (const SimulationError& s) {  // its items: indices into the whole batch
          size_t k = size_t(&e - errors.data());
          std::vector<int> items;
          for (int i : s.items) items.push_back(shares[k].begin + i);
          throw SimulationError(s.what(), items);
        }
      }
    std::vector<std::string> out;
    for (std::vector<std::string>& r : results)
      for (std::string& s : r) out.push_back(std::move(s));
    return out;
  }
  return merge_rank_outcomes(ranks::all_gather(rank_outcome(shares, results, errors)), n);
}

std::string rank_outcome(const std::vector<BatchShare>& shares, const std::vector<std::vector<std::string>>& results,
                         const std::vector<std::exception_ptr>& errors) {
  ByteWriter w;
  for (size_t k = 0; k < errors.size(); ++k)
    if (errors[k]) {
      w.put_string(encode_error(errors[k], shares[k].begin));
      return w.bytes();
    }
  ByteWriter ok;
  ok.put('K');
  for (const std::vector<std::string>& r : results)
    for (const std::string& s : r) ok.put_string(s);
  w.put_string(ok.bytes());
  return w.bytes();
}

std::vector<std::string> merge_rank_outcomes(const std::vector<std::string>& outcomes, int n) {
  if (const std::exception_ptr e = first_failure(outcomes)) {
    failure_shared = true;
    std::rethrow_exception(e);
  }
  std::vector<std::string> out;
  for (const std::string& outcome : outcomes) {
    ByteReader outer(outcome);
    const std::string body = outer.get_string();
    ByteReader in(body);
    in.get<char>();
    while (!in.at_end()) out.push_back(in.get_string());
  }
  if (int(out.size()) != n) throw std::logic_error("run_shared: the ranks returned a result count unlike the batch's");
  return out;
}

std::exception_ptr agree_on_outcome(const std::exception_ptr& mine) {
  if (ranks::count() == 1 || failure_shared) return mine;
  const BatchShare none;
  const std::exception_ptr first = first_failure(ranks::all_gather(rank_outcome({none}, {{}}, {mine})));
  return mine ? mine : first;
}

}  // namespace ssc
