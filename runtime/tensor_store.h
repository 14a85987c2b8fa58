// Storage for every tensor of a graph: one contiguous array per tensor, batch-major
// ((b * count + i) * components + k), sized from the graph's domains.
#pragma once
#include <vector>

#include "graph/graph.h"

namespace ssc {

struct DomainSizes {
  int cell = 0, node = 0, point = 0, band = 0;
  int count(Domain d) const {
    switch (d) {
      case Domain::Scalar: return 1;
      case Domain::Cell: return cell;
      case Domain::Node: return node;
      case Domain::Point: return point;
      case Domain::Band: return band;
    }
    return 0;
  }
};

template <class Real>
class TensorStore {
 public:
  TensorStore(const Graph& graph, const DomainSizes& sizes, int batch) : batch_(batch) {
    for (const TensorInfo& t : graph.tensors()) {
      const size_t stride = size_t(sizes.count(t.domain)) * t.components;
      strides_.push_back(stride);
      data_.emplace_back(stride * batch, Real(0));
    }
  }
  int batch() const { return batch_; }
  int tensor_count() const { return int(data_.size()); }
  size_t stride(int tensor) const { return strides_[tensor]; }
  Real* data(int tensor, int b) { return data_[tensor].data() + strides_[tensor] * b; }
  const Real* data(int tensor, int b) const { return data_[tensor].data() + strides_[tensor] * b; }
  std::vector<Real>& all(int tensor) { return data_[tensor]; }
  const std::vector<Real>& all(int tensor) const { return data_[tensor]; }

 private:
  int batch_;
  std::vector<size_t> strides_;
  std::vector<std::vector<Real>> data_;
};

}  // namespace ssc
