// Building one code fragment (a Snippet, op_snippets.h): the kernel parameters it binds
// and the $name substitutions of its source text. Internal to codegen/: op_snippets.cpp
// (forward and adjoint fragments) and solver_snippets.cpp (solver stages) use it.
#pragma once
#include <fmt/format.h>

#include <cctype>
#include <map>
#include <stdexcept>
#include <string>

#include "codegen/op_snippets.h"

namespace ssc {
namespace snippet {

inline std::string count_expr(Domain d) {
  switch (d) {
    case Domain::Scalar: return "1";
    case Domain::Cell: return "n_cell";
    case Domain::Node: return "n_node";
    case Domain::Point: return "n_point";
    case Domain::Band: return "n_band";
  }
  return "1";
}

// Builds the parameter list and the $name substitutions of one fragment.
class Builder {
 public:
  Builder(const Graph& g, int op, std::string label, Extent extent) : g_(g), op_(op) {
    s_.label = std::move(label);
    s_.op = op;
    s_.extent = extent;
  }
  // Forward value of an op slot (input or output): $slot.
  Builder& t(const std::string& slot, bool write = false, bool gather = false) {
    const int id = tensor_of(slot);
    add(KernelParam::Kind::Tensor, "t_" + g_.tensor(id).name, "Real", write, gather, id);
    subst_[slot] = "t_" + g_.tensor(id).name;
    return *this;
  }
  // Cotangent of an op slot: $d_slot.
  Builder& a(const std::string& slot, bool write = true, bool gather = false) {
    const int id = tensor_of(slot);
    add(KernelParam::Kind::Adjoint, "a_" + g_.tensor(id).name, "Real", write, gather, id);
    subst_["d_" + slot] = "a_" + g_.tensor(id).name;
    return *this;
  }
  Builder& grid(const std::string& name, const std::string& type, bool gather = false) {
    add(KernelParam::Kind::Grid, "g_" + name, type, false, gather, -1);
    return *this;
  }
  // Scratch buffer, per batch item count(domain) * components; $key names it.
  Builder& scratch(const std::string& key, const std::string& name, const std::string& type, Domain d, int comps,
                   bool write, bool gather = false, const std::string& stride = "") {
    KernelParam& p = add(KernelParam::Kind::Scratch, "s_" + name, type, write, gather, -1);
    p.domain = d;
    p.components = comps;
    p.stride = d == Domain::Scalar ? std::to_string(comps) : fmt::format("{} * {}", count_expr(d), comps);
    if (!stride.empty()) p.stride = stride;
    subst_[key] = "s_" + name;
    return *this;
  }
  // Solver vector bound per launch (length `stride` per batch item).
  Builder& vec(const std::string& name, bool write, const std::string& stride, bool gather = false) {
    KernelParam& p = add(KernelParam::Kind::Vector, "v_" + name, "Real", write, gather, -1);
    p.stride = stride;
    return *this;
  }
  Builder& value(const std::string& name, const std::string& type) {
    add(KernelParam::Kind::Value, name, type, false, false, -1);
    return *this;
  }
  Builder& stage(const std::string& s, bool shared = false) {
    s_.stage = s;
    s_.barrier = true;
    s_.shared = shared;
    return *this;
  }
  Builder& barrier() {
    s_.barrier = true;
    return *this;
  }
  Snippet code(const std::string& text) {
    s_.code = substitute(text);
    return s_;
  }

 private:
  int tensor_of(const std::string& slot) const {
    const OpNode& o = g_.ops().at(op_);
    for (const OpArg& x : o.inputs)
      if (x.slot == slot) return x.tensor;
    for (const OpArg& x : o.outputs)
      if (x.slot == slot) return x.tensor;
    throw std::logic_error(fmt::format("codegen: op {} ({}) has no slot '{}'", op_, o.name(), slot));
  }
  KernelParam& add(KernelParam::Kind kind, const std::string& name, const std::string& type, bool write, bool gather,
                   int tensor) {
    for (KernelParam& p : s_.params)
      if (p.name == name) {
        p.write |= write;
        p.gather |= gather;
        return p;
      }
    KernelParam p;
    p.kind = kind;
    p.name = name;
    p.type = type;
    p.write = write;
    p.gather = gather;
    p.tensor = tensor;
    if (tensor >= 0) {
      const TensorInfo& t = g_.tensor(tensor);
      p.domain = t.domain;
      p.components = t.components;
      p.stride = t.domain == Domain::Scalar ? std::to_string(t.components)
                                            : fmt::format("{} * {}", count_expr(t.domain), t.components);
    }
    s_.params.push_back(p);
    return s_.params.back();
  }
  std::string substitute(const std::string& text) const {
    std::string out;
    for (size_t k = 0; k < text.size(); ++k) {
      if (text[k] != '$') {
        out += text[k];
        continue;
      }
      size_t e = k + 1;
      while (e < text.size() && (std::isalnum(static_cast<unsigned char>(text[e])) || text[e] == '_')) ++e;
      const std::string key = text.substr(k + 1, e - k - 1);
      auto it = subst_.find(key);
      if (it == subst_.end()) throw std::logic_error("codegen: fragment " + s_.label + " uses unbound $" + key);
      out += it->second;
      k = e - 1;
    }
    return out;
  }

  const Graph& g_;
  int op_;
  Snippet s_;
  std::map<std::string, std::string> subst_;
};

inline bool has_slot(const OpNode& o, const char* slot) {
  for (const OpArg& a : o.inputs)
    if (a.slot == slot) return true;
  return false;
}

inline const char* const kCoefficients =
    "const ops::NewmarkCoefficients<Real> c = ops::newmark_coefficients($dt[0], $theta[0], $mass_damping[0], "
    "$stiffness_damping[0]);\n";

inline Builder& newmark_scalars(Builder& b) { return b.t("dt").t("theta").t("mass_damping").t("stiffness_damping"); }

}  // namespace snippet
}  // namespace ssc
