// Kernel planning (see kernel_plan.h).
#include "codegen/kernel_plan.h"

#include <fmt/format.h>

#include <regex>
#include <set>
#include <stdexcept>

#include "codegen/cuda_source.h"
#include "codegen/sha256.h"

namespace ssc {
namespace {

const KernelParam* find_param(const std::vector<KernelParam>& ps, const std::string& name) {
  for (const KernelParam& p : ps)
    if (p.name == name) return &p;
  return nullptr;
}

// Why fragment `s` cannot join kernel `k`; empty if it can.
std::string cut_reason(const PlannedKernel& k, const Snippet& s, const Graph& g) {
  const Snippet& first = k.parts.front();
  auto barrier_reason = [&](const Snippet& x) {
    if (!x.stage.empty())
      return fmt::format("opaque op {} (op {}): solver stage", g.ops()[x.op].name(), x.op);
    return std::string("reduction (ordered sum into scalars)");
  };
  if (first.barrier) return barrier_reason(first);
  if (s.barrier) return "next: " + barrier_reason(s);
  if (s.extent != k.extent) return fmt::format("domain change ({} -> {})", extent_name(k.extent), extent_name(s.extent));
  for (const KernelParam& p : s.params) {
    const KernelParam* q = find_param(k.params, p.name);
    if (!q) continue;
    if (p.gather && q->write)
      return fmt::format("gather of {} written in this kernel (read-after-write across threads)", p.name);
    if (p.write && q->gather)
      return fmt::format("write of {} gathered in this kernel (write-after-read across threads)", p.name);
  }
  return "";
}

void merge_params(std::vector<KernelParam>& into, const std::vector<KernelParam>& from) {
  for (const KernelParam& p : from) {
    bool found = false;
    for (KernelParam& q : into)
      if (q.name == p.name) {
        q.write |= p.write;
        q.gather |= p.gather;
        found = true;
      }
    if (!found) into.push_back(p);
  }
}

std::string join_labels(const PlannedKernel& k) {
  std::string s;
  std::set<std::string> seen;
  int n = 0;
  for (const Snippet& p : k.parts) {
    if (!seen.insert(p.label).second) continue;
    if (n == 3) {
      s += "_etc";
      break;
    }
    if (!s.empty()) s += "_";
    s += p.label;
    ++n;
  }
  return s;
}

void finish(PlannedKernel& k) {
  const bool shared = k.parts.front().shared;
  const std::string base = fmt::format("{}_{}_{}", shared ? "slv" : k.prefix, extent_name(k.extent), join_labels(k));
  const std::string hash = sha256_hex(kernel_signature_and_body(k, "KERNEL")).substr(0, 8);
  k.name = base + "__" + hash;
  k.stage = k.parts.front().stage;
  for (const Snippet& p : k.parts)
    if (k.ops.empty() || k.ops.back() != p.op) k.ops.push_back(p.op);
}

std::vector<PlannedKernel> fuse(const Graph& g, const std::vector<Snippet>& parts, const char* prefix) {
  std::vector<PlannedKernel> out;
  PlannedKernel cur;
  auto flush = [&](const std::string& reason) {
    if (cur.parts.empty()) return;
    cur.cut = reason;
    finish(cur);
    out.push_back(cur);
    cur = PlannedKernel();
  };
  for (const Snippet& s : parts) {
    if (!cur.parts.empty()) {
      const std::string reason = cut_reason(cur, s, g);
      if (!reason.empty()) flush(reason);
    }
    if (cur.parts.empty()) {
      cur.prefix = prefix;
      cur.extent = s.extent;
    }
    cur.parts.push_back(s);
    merge_params(cur.params, s.params);
  }
  flush("end of graph");
  std::set<std::string> seen;
  for (PlannedKernel& k : out) k.duplicate = !seen.insert(k.name).second;
  return out;
}

}  // namespace

KernelPlan plan_kernels(const Graph& g) {
  g.validate();
  KernelPlan plan;
  std::vector<Snippet> fwd, adj;
  for (int o = 0; o < int(g.ops().size()); ++o)
    for (Snippet& s : forward_snippets(g, o)) fwd.push_back(s);
  for (int o = int(g.ops().size()) - 1; o >= 0; --o)
    for (Snippet& s : adjoint_snippets(g, o)) adj.push_back(s);
  plan.forward = fuse(g, fwd, "fwd");
  plan.adjoint = fuse(g, adj, "adj");
  // A solver kernel shared with the forward plan is a duplicate in the adjoint plan.
  std::set<std::string> fwd_names;
  for (const PlannedKernel& k : plan.forward) fwd_names.insert(k.name);
  for (PlannedKernel& k : plan.adjoint)
    if (fwd_names.count(k.name)) k.duplicate = true;
  return plan;
}

std::vector<const PlannedKernel*> KernelPlan::unique_kernels() const {
  std::vector<const PlannedKernel*> out;
  std::set<std::string> seen;
  for (const auto* list : {&forward, &adjoint})
    for (const PlannedKernel& k : *list)
      if (seen.insert(k.name).second) out.push_back(&k);
  return out;
}

const PlannedKernel* KernelPlan::find(bool adjoint_plan, const std::string& label, int op) const {
  for (const PlannedKernel& k : adjoint_plan ? adjoint : forward)
    if (k.label() == label && (op < 0 || k.parts.front().op == op)) return &k;
  return nullptr;
}

size_t KernelPlan::prefix_cut(bool adjoint_plan, int op_count) const {
  enum class Side { Prefix, Tail, Both };
  auto side = [op_count](const PlannedKernel& k) {
    bool prefix = false, tail = false;
    for (int o : k.ops) (o < op_count ? prefix : tail) = true;
    return prefix && tail ? Side::Both : tail ? Side::Tail : Side::Prefix;
  };
  const std::vector<PlannedKernel>& plan = adjoint_plan ? adjoint : forward;
  const Side first = adjoint_plan ? Side::Tail : Side::Prefix;
  size_t cut = 0;
  while (cut < plan.size() && side(plan[cut]) == first) ++cut;
  for (size_t i = cut; i < plan.size(); ++i)
    if (side(plan[i]) != (adjoint_plan ? Side::Prefix : Side::Tail))
      throw std::logic_error("kernel plan: " + plan[i].name + " keeps the ops from " + std::to_string(op_count) +
                             " on from being left out");
  return cut;
}

static const char* param_kind(KernelParam::Kind k) {
  switch (k) {
    case KernelParam::Kind::Tensor: return "tensor";
    case KernelParam::Kind::Adjoint: return "cotangent";
    case KernelParam::Kind::Grid: return "grid";
    case KernelParam::Kind::Scratch: return "scratch";
    case KernelParam::Kind::Vector: return "vector";
    case KernelParam::Kind::Value: return "value";
  }
  return "?";
}

std::string KernelPlan::text(const Graph& g, bool sanitize) const {
  std::string s = "# ssc kernel plan\n# fusion: same domain; cut at a domain change, a gather of a buffer written in the\n"
                  "# same kernel, an opaque op (solver sequence) or a reduction. No atomics.\n";
  auto list = [&](const std::vector<PlannedKernel>& ks, const char* title) {
    s += fmt::format("\n## {} ({} launches in sequence, {} distinct kernels)\n", title, ks.size(),
                     [&] {
                       std::set<std::string> n;
                       for (const PlannedKernel& k : ks) n.insert(k.name);
                       return n.size();
                     }());
    for (size_t i = 0; i < ks.size(); ++i) {
      const PlannedKernel& k = ks[i];
      s += fmt::format("\n[{}] {}{}\n", i, k.name, k.duplicate ? "  (same code as above)" : "");
      s += fmt::format("    over: {} x batch\n", extent_name(k.extent));
      if (!k.stage.empty()) s += fmt::format("    stage: {}\n", k.stage);
      for (const Snippet& p : k.parts)
        s += fmt::format("    op {:>2} {:<18} part {}\n", p.op, g.ops()[p.op].name(), p.label);
      if (k.duplicate) {
        s += fmt::format("    cut: {}\n", k.cut);
        continue;
      }
      std::string args;
      for (const KernelParam& p : k.params) {
        std::string flags = p.write ? (p.gather ? "rw*" : "w") : (p.gather ? "r*" : "r");
        if (p.kind == KernelParam::Kind::Value) flags = "val";
        args += fmt::format("\n      {:<10} {:<7} {:<3} {}", param_kind(p.kind), p.type, flags, p.name);
      }
      s += "    args (r* = gathered):" + args + "\n";
      s += fmt::format("    cut: {}\n", k.cut);
    }
  };
  list(forward, "forward");
  list(adjoint, "adjoint (ops in reverse)");
  if (sanitize) s = std::regex_replace(s, std::regex("__[0-9a-f]{8}"), "__########");
  return s;
}

}  // namespace ssc
