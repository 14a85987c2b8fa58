// Registering a part function (graph/op_spec.h): SSC_PART(name) instantiates ops::name for
// double, float and Dual<double> (forward parts, which the op checks differentiate in
// forward mode), SSC_ADJOINT_PART(name) for double and float. Each instantiation becomes a
// type-erased loop over the part's extent for the interpreter, and the argument types and
// write flags are read from the float signature for the emitter. Compiled by ops/registry.cpp
// only.
#pragma once
#include <type_traits>
#include <utility>

#include "graph/dual.h"
#include "graph/op_spec.h"
#include "ops/part.h"

namespace ssc {
namespace part_detail {

template <class T>
std::pair<std::string, bool> param_type() {
  static_assert(std::is_pointer<T>::value, "a part's arguments are pointers");
  using E = std::remove_pointer_t<T>;
  using B = std::remove_const_t<E>;
  const bool write = !std::is_const<E>::value;
  if (std::is_same<B, float>::value) return {"Real", write};
  if (std::is_same<B, double>::value) return {"double", write};
  if (std::is_same<B, int>::value) return {"int", write};
  static_assert(std::is_same<B, float>::value || std::is_same<B, double>::value || std::is_same<B, int>::value,
                "a part's arguments point to Real (float here), double or int");
  return {"?", write};
}

template <auto F>
struct Loop;

template <class Real, class... A, void (*F)(int, const ops::PartContext<Real>&, A...)>
struct Loop<F> {
  template <size_t... I>
  static void call(int i, const ops::PartContext<Real>& cx, void* const* args, std::index_sequence<I...>) {
    F(i, cx, static_cast<A>(args[I])...);
  }
  static void run(int count, const void* context, void* const* args, long parallel_threshold) {
    const auto& cx = *static_cast<const ops::PartContext<Real>*>(context);
#pragma omp parallel for schedule(static) if (count >= parallel_threshold)
    for (int i = 0; i < count; ++i) call(i, cx, args, std::index_sequence_for<A...>{});
  }
  static std::vector<std::pair<std::string, bool>> params() { return {param_type<A>()...}; }
};

}  // namespace part_detail

template <auto Double, auto Float, auto DualDouble>
PartFunction part_function(const char* name) {
  PartFunction f;
  f.name = name;
  f.loop_double = &part_detail::Loop<Double>::run;
  f.loop_float = &part_detail::Loop<Float>::run;
  if constexpr (DualDouble != nullptr) f.loop_dual = &part_detail::Loop<DualDouble>::run;
  f.params = part_detail::Loop<Float>::params();
  return f;
}

}  // namespace ssc

#define SSC_PART(fn)                                                                             \
  ::ssc::part_function<&::ssc::ops::fn<double>, &::ssc::ops::fn<float>, &::ssc::ops::fn<::ssc::Dual<double>>>( \
      "ops::" #fn)
#define SSC_ADJOINT_PART(fn) \
  ::ssc::part_function<&::ssc::ops::fn<double>, &::ssc::ops::fn<float>, nullptr>("ops::" #fn)
