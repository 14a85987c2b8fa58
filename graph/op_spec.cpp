// Declaring op specs (see op_spec.h).
#include "graph/op_spec.h"

#include <fmt/format.h>

#include <stdexcept>

namespace ssc {

const char* domain_name(Domain d) {
  switch (d) {
    case Domain::Scalar: return "scalar";
    case Domain::Cell: return "cell";
    case Domain::Node: return "node";
    case Domain::Point: return "point";
    case Domain::Band: return "band";
  }
  return "?";
}

const char* access_name(Access a) {
  switch (a) {
    case Access::Pointwise: return "pointwise";
    case Access::Gather: return "gather";
    case Access::ScatterAdd: return "scatter-add";
    case Access::Reduction: return "reduction";
    case Access::Opaque: return "opaque";
  }
  return "?";
}

const char* extent_name(Extent e) {
  switch (e) {
    case Extent::One: return "one";
    case Extent::Cell: return "cell";
    case Extent::Node: return "node";
    case Extent::Point: return "point";
    case Extent::Band: return "band";
    case Extent::Len: return "vec";
    case Extent::Item: return "item";
    case Extent::Grid: return "grid";
  }
  return "?";
}

Domain extent_domain(Extent e) {
  switch (e) {
    case Extent::Cell: return Domain::Cell;
    case Extent::Node: return Domain::Node;
    case Extent::Point: return Domain::Point;
    case Extent::Band: return Domain::Band;
    default: return Domain::Scalar;
  }
}

const SlotSpec* OpSpec::slot(const std::string& n) const {
  for (const SlotSpec& s : slots)
    if (s.name == n) return &s;
  return nullptr;
}

const ScratchSpec& OpSpec::scratch_spec(const std::string& key) const {
  for (const ScratchSpec& s : scratch)
    if (s.key == key) return s;
  throw std::logic_error(fmt::format("op {}: no scratch buffer '{}'", name, key));
}

std::string OpSpec::scratch_type(const std::string& key) const {
  for (const std::vector<PartSpec>* parts : {&forward, &adjoint})
    for (const PartSpec& p : *parts)
      if (!p.function.name.empty())
        for (const PartArg& a : p.args)
          if (a.kind == PartArg::Kind::Scratch && a.name == key) return a.type;
  throw std::logic_error(fmt::format("op {}: no part writes scratch buffer '{}'", name, key));
}

const OpSpec& op_spec(const std::string& name) {
  std::string known;
  for (const OpSpec& s : op_registry()) {
    if (s.name == name) return s;
    known += (known.empty() ? "" : ", ") + s.name;
  }
  throw std::logic_error(fmt::format("no op '{}' is registered (known: {})", name, known));
}

static PartArg parse_arg(std::string text) {
  PartArg a;
  if (!text.empty() && text.back() == '^') {
    a.gather = true;
    text.pop_back();
  }
  if (text.rfind("d_", 0) == 0) {
    a.kind = PartArg::Kind::Adjoint;
    text = text.substr(2);
  } else if (!text.empty() && text[0] == '#') {
    a.kind = PartArg::Kind::Static;
    text = text.substr(1);
  } else if (!text.empty() && text[0] == '$') {
    a.kind = PartArg::Kind::Scratch;
    text = text.substr(1);
  }
  a.name = text;
  return a;
}

PartSpec part(const std::string& label, Extent extent, PartFunction f, const std::vector<std::string>& args) {
  if (args.size() != f.params.size())
    throw std::logic_error(fmt::format("part {}: {} takes {} arguments after (i, cx), the spec names {}", label, f.name,
                                       f.params.size(), args.size()));
  PartSpec p;
  p.label = label;
  p.extent = extent;
  for (size_t k = 0; k < args.size(); ++k) {
    PartArg a = parse_arg(args[k]);
    a.type = f.params[k].first;
    a.write = f.params[k].second;
    if (a.write && a.kind == PartArg::Kind::Static)
      throw std::logic_error(fmt::format("part {}: static array {} is passed as writable", label, a.name));
    p.args.push_back(a);
  }
  p.function = std::move(f);
  return p;
}

PartSpec reduction(const std::string& label, const std::vector<std::string>& sources,
                   const std::vector<std::string>& targets) {
  PartSpec p;
  p.label = label;
  p.extent = Extent::Item;
  for (const std::string& s : sources) {
    PartArg a = parse_arg(s);
    if (a.kind != PartArg::Kind::Scratch) throw std::logic_error("reduction " + label + ": source " + s + " is no $scratch");
    p.args.push_back(a);
  }
  for (const std::string& t : targets) {
    PartArg a = parse_arg(t);
    if (a.kind != PartArg::Kind::Adjoint && a.kind != PartArg::Kind::Value)
      throw std::logic_error("reduction " + label + ": target " + t + " is no slot or d_slot");
    a.write = true;
    a.type = "Real";
    p.args.push_back(a);
  }
  return p;
}

PartSpec when_bound(PartSpec p, const std::string& slot) {
  p.requires_slot = slot;
  return p;
}

SlotSpec in(const std::string& name, Access access) { return SlotSpec{name, false, access, false, true}; }
SlotSpec out(const std::string& name) { return SlotSpec{name, true, Access::Pointwise, false, true}; }
SlotSpec optional_in(const std::string& name, Access access) { return SlotSpec{name, false, access, true, true}; }
SlotSpec constant_in(const std::string& name, Access access) { return SlotSpec{name, false, access, false, false}; }

}  // namespace ssc
