// Graph construction, validation and listing (see graph.h).
#include "graph/graph.h"

#include <fmt/format.h>

#include <stdexcept>

namespace ssc {

static int find_slot(const std::vector<OpArg>& args, const std::string& slot, const std::string& op) {
  for (const OpArg& a : args)
    if (a.slot == slot) return a.tensor;
  throw std::logic_error(fmt::format("op {} has no argument '{}'", op, slot));
}

int OpNode::input(const std::string& slot) const { return find_slot(inputs, slot, name()); }
int OpNode::output(const std::string& slot) const { return find_slot(outputs, slot, name()); }
bool OpNode::bound(const std::string& slot) const {
  for (const std::vector<OpArg>* args : {&inputs, &outputs})
    for (const OpArg& a : *args)
      if (a.slot == slot) return true;
  return false;
}

int scratch_components(const Graph& g, const OpNode& op, const ScratchSpec& s) {
  if (s.components > 0) return s.components;
  return op.bound(s.like_slot) ? g.tensor(op.input(s.like_slot)).components : 1;
}

int Graph::add_tensor(const std::string& name, Domain domain, int components, TensorInfo::Role role,
                      DType dtype) {
  if (find_tensor(name) >= 0) throw std::logic_error("duplicate tensor name " + name);
  TensorInfo t;
  t.name = name;
  t.domain = domain;
  t.components = components;
  t.role = role;
  t.dtype = dtype;
  tensors_.push_back(t);
  return int(tensors_.size()) - 1;
}

int Graph::add_op(const std::string& name, std::vector<OpArg> inputs, const std::vector<NewOutput>& outputs) {
  const OpSpec& spec = op_spec(name);
  OpNode op{&spec, spec.domain, std::move(inputs), {}};
  const Domain domain = spec.domain;
  for (OpArg& a : op.inputs) {
    const SlotSpec* s = spec.slot(a.slot);
    if (!s || s->output) throw std::logic_error(fmt::format("op {} has no input slot '{}'", name, a.slot));
    a.access = s->access;
  }
  for (const SlotSpec& s : spec.slots) {
    bool given = false;
    for (const OpArg& a : op.inputs) given |= a.slot == s.name;
    for (const NewOutput& o : outputs) given |= o.slot == s.name;
    if (!given && !s.optional) throw std::logic_error(fmt::format("op {}: slot '{}' is not bound", name, s.name));
  }
  const int index = int(ops_.size());
  for (const NewOutput& o : outputs) {
    const SlotSpec* s = spec.slot(o.slot);
    if (!s || !s->output) throw std::logic_error(fmt::format("op {} has no output slot '{}'", name, o.slot));
    const int id = add_tensor(o.name, o.domain, o.components, TensorInfo::Role::Intermediate);
    tensors_[id].producer = index;
    op.outputs.push_back({o.slot, id, o.domain == domain ? Access::Pointwise : Access::Opaque});
  }
  ops_.push_back(std::move(op));
  return index;
}

int Graph::find_tensor(const std::string& name) const {
  for (size_t i = 0; i < tensors_.size(); ++i)
    if (tensors_[i].name == name) return int(i);
  return -1;
}

void Graph::validate() const {
  for (size_t o = 0; o < ops_.size(); ++o) {
    const OpNode& op = ops_[o];
    for (const OpArg& a : op.inputs) {
      if (a.tensor < 0 || a.tensor >= int(tensors_.size()))
        throw std::logic_error(fmt::format("op {} ({}): input '{}' is unbound", o, op.name(), a.slot));
      const TensorInfo& t = tensors_[a.tensor];
      if (t.role == TensorInfo::Role::Intermediate && t.producer >= int(o))
        throw std::logic_error(fmt::format("op {} ({}) reads '{}' before op {} writes it", o,
                                           op.name(), t.name, t.producer));
      if (a.access == Access::Pointwise && t.domain != op.domain && t.domain != Domain::Scalar)
        throw std::logic_error(fmt::format("op {} ({}) reads '{}' ({}) pointwise over domain {}", o,
                                           op.name(), t.name, domain_name(t.domain),
                                           domain_name(op.domain)));
    }
    for (const OpArg& a : op.outputs) {
      const TensorInfo& t = tensors_[a.tensor];
      if (t.producer != int(o))
        throw std::logic_error(fmt::format("tensor '{}' is written by op {} but owned by op {}", t.name, o,
                                           t.producer));
    }
  }
}

std::string Graph::describe() const {
  std::string s = "tensors:\n";
  for (size_t i = 0; i < tensors_.size(); ++i) {
    const TensorInfo& t = tensors_[i];
    const char* role = t.role == TensorInfo::Role::Input ? "input" : t.role == TensorInfo::Role::State ? "state" : "value";
    s += fmt::format("  %{:<3} {:<22} {:<6} x{} {}\n", i, t.name, domain_name(t.domain), t.components, role);
  }
  s += "ops:\n";
  for (size_t o = 0; o < ops_.size(); ++o) {
    const OpNode& op = ops_[o];
    s += fmt::format("  [{}] {} over {}\n", o, op.name(), domain_name(op.domain));
    for (const OpArg& a : op.inputs)
      s += fmt::format("      in  {:<12} %{} {} ({})\n", a.slot, a.tensor, tensors_[a.tensor].name, access_name(a.access));
    for (const OpArg& a : op.outputs)
      s += fmt::format("      out {:<12} %{} {}\n", a.slot, a.tensor, tensors_[a.tensor].name);
  }
  return s;
}

}  // namespace ssc
