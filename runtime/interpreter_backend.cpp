// The interpreter as a step backend (see interpreter_backend.h).
#include "runtime/interpreter_backend.h"

#include <unistd.h>

#include <stdexcept>

namespace ssc {

void InterpreterBackend::run() { in_.run(); }

void InterpreterBackend::copy_tensors(const std::vector<std::pair<int, int>>& from_to) {
  for (const auto& [from, to] : from_to) in_.store().all(to) = in_.store().all(from);
}

void InterpreterBackend::save_snapshot(int key, const std::vector<int>& tensors) {
  std::vector<std::vector<double>>& s = snapshots_[key];
  s.clear();
  for (int t : tensors) s.push_back(in_.store().all(t));
}

void InterpreterBackend::load_snapshot(int key, const std::vector<int>& tensors) {
  const auto it = snapshots_.find(key);
  if (it == snapshots_.end() || it->second.size() != tensors.size())
    throw std::logic_error("InterpreterBackend: no snapshot of these tensors under this key");
  for (size_t i = 0; i < tensors.size(); ++i) in_.store().all(tensors[i]) = it->second[i];
}

size_t InterpreterBackend::free_device_memory() const {
  const long pages = sysconf(_SC_AVPHYS_PAGES), page = sysconf(_SC_PAGESIZE);
  return pages > 0 && page > 0 ? size_t(pages) * size_t(page) : size_t(-1);
}

void InterpreterBackend::get_adjoint(int tensor, std::vector<double>& all_items) const {
  const std::vector<double>& cotangent = const_cast<Interpreter<double>&>(in_).adjoint().all(tensor);
  if (all_items.size() != cotangent.size()) throw std::logic_error("InterpreterBackend: get_adjoint size mismatch");
  all_items = cotangent;
}

void InterpreterBackend::chain_adjoints(const std::vector<std::pair<int, int>>& from_to) {
  TensorStore<double>& adj = in_.adjoint();
  std::vector<std::vector<double>> moved;
  for (const auto& [from, to] : from_to) moved.push_back(adj.all(from));
  in_.clear_adjoints(false);
  for (size_t i = 0; i < from_to.size(); ++i) adj.all(from_to[i].second) = moved[i];
}

}  // namespace ssc
