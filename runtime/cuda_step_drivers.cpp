// What one GPU timestep launches (see cuda_runtime.h): the planned kernels in order,
// forward or adjoint, with each opaque op's solver stage sequence in their place.
//
// Forward: newmark_init, then the time-step solve, started at the best point of a small space
// around newmark_init's guess (ops/galerkin_start.h); the extension: setup (rhs from the active
// neighbours, the guess), PCG with the band Laplacian on band_u. With grid solves each PCG is
// one persistent grid kernel, whose outcomes the host reads after the step: newmark_pcg_grid
// or its one-phase form for batch 1 (either computes its Jacobi diagonal and masked
// right-hand side itself); extension_pcg_grid, or its two-phase form for large batches.
// Without: newmark_diag, newmark_setup, newmark_start and the host-driven iteration kernels
// (element apply: cell kernel, node gather).
// Where the extension is one dense product (runtime/band_operator.h), it is a single
// kernel each way instead.
// Adjoint (implicit-function adjoints, as runtime/interpreter_adjoint.cpp): the
// extension's cotangent solve L y = band_u_bar into scratch y (warm-started from the
// previous, later step's y within one backward pass), the time-step system's
// A w = u_bar into scratch w (the step's first such solve warm-started from its previous
// solution, the others from zero; all to a residual against the step's largest u_bar:
// runtime/solvers.cpp, newmark_adjoint); the fused adj_ kernels around them read y and w.
#include <fmt/format.h>

#include <cstdlib>
#include <functional>

#include "runtime/errors.h"
#include "runtime/cuda_timestep_impl.h"

namespace ssc {
namespace {

std::string scratch_of(const char* key, int op) { return fmt::format("s_{}_op{}", key, op); }

}  // namespace

GpuTimestep::Impl::Apply GpuTimestep::Impl::newmark_apply(int o) {
  const PlannedKernel& cell = kernel("newmark_apply_cell", false, o);
  const PlannedKernel& node = kernel("newmark_apply_node", false, o);
  return [this, &cell, &node](cu::DevicePtr p, cu::DevicePtr q, int gate) {
    Call a;
    a.vectors = {{"v_p", p}, {"v_q", q}};
    a.values = {{"gate", double(gate)}};
    launch(cell, a);
    launch(node, a);
  };
}

GpuTimestep::Impl::Apply GpuTimestep::Impl::extension_apply() {
  const PlannedKernel& band = kernel("extension_apply");
  return [this, &band](cu::DevicePtr p, cu::DevicePtr q, int gate) {
    Call a;
    a.vectors = {{"v_p", p}, {"v_q", q}};
    a.values = {{"gate", double(gate)}};
    launch(band, a);
  };
}

// Jacobi diagonal and the masked right-hand side of op o's time-step system into v_inv_diag
// and v_b; x's start as x_start says (ops::NewmarkXStart).
void GpuTimestep::Impl::newmark_setup(int o, cu::DevicePtr rhs, cu::DevicePtr x, int x_start) {
  Call diag;
  diag.len = 8L * sizes.cell;
  launch(kernel("newmark_diag", false, o), diag);
  Call setup;
  setup.vectors = {{"v_rhs", rhs},
                   {"v_x", x},
                   {"v_x_before", scratch.at(scratch_of("w_before", o)).ptr},
                   {"v_b", scratch.at("v_b").ptr},
                   {"v_inv_diag", scratch.at("v_inv_diag").ptr}};
  setup.values = {{"x_start", x_start}};
  launch(kernel("newmark_setup", false, o), setup);
}

void GpuTimestep::Impl::newmark(int o) {
  const OpNode& op = graph.ops()[o];
  static const bool no_start = std::getenv("SSC_NO_GALERKIN_START") != nullptr;  // for comparisons, as the CPU's
  const bool start = !op.bound("guess") && !no_start;
  const cu::DevicePtr u = tensors.at(op.output("u")).ptr, rhs = tensors.at(op.input("rhs")).ptr;
  launch(kernel("newmark_init", false, o));
  if (grid_solves) {  // the grid kernel runs its setup itself
    grid_pcg(kernel(newmark_grid, false, o), u, std::max(8L * sizes.cell, long(sizes.node)), solver.cg_tolerance,
             solver.cg_max_iterations, tensors.at(op.output("cg_iterations")).ptr, "time-step solve", &cg_iterations,
             0, rhs, ops::kKeepX, scratch.at(scratch_of("w_before", o)).ptr, start);
    return;
  }
  newmark_setup(o, rhs, u, ops::kKeepX);
  if (start) {  // the Galerkin start (ops/galerkin_start.h)
    Call start;
    start.vectors = {{"v_b", scratch.at("v_b").ptr}, {"v_x", u}};
    launch(kernel("newmark_start", false, o), start);
  }
  cg_iterations = pcg(u, 3L * sizes.node, solver.cg_tolerance, solver.cg_max_iterations, newmark_apply(o),
                      "time-step solve", fmt::format("newmark {}", o), 0);
  write_iterations(op.output("cg_iterations"), cg_iterations);
}

void GpuTimestep::Impl::extension(int o) {
  const OpNode& op = graph.ops()[o];
  if (dense_extension) {
    Call product;
    product.values = {{"n_source", double(dense_extension->sources.size())}};
    product.len = long(gpu_detail::kBlock) * ((sizes.band + 31) / 32);  // whole blocks (gen::extension_dense)
    launch(kernel("extension_dense", false, o), product);
    return;
  }
  const cu::DevicePtr x = tensors.at(op.output("band_u")).ptr;
  Call setup;
  setup.vectors = {{"v_b", scratch.at("v_b").ptr}, {"v_inv_diag", scratch.at("v_inv_diag").ptr}};
  launch(kernel("extension_setup"), setup);
  if (grid_solves)
    grid_pcg(kernel(extension_grid), x, sizes.band, solver.extension_tolerance, solver.extension_max_iterations,
             scratch.at("v_iterations_sink").ptr, "displacement extension", nullptr, 0);
  else
    pcg(x, 3L * sizes.band, solver.extension_tolerance, solver.extension_max_iterations, extension_apply(),
        "displacement extension", fmt::format("extension {}", o), 0);
}

void GpuTimestep::Impl::launch_plan(const PlannedKernel* begin, const PlannedKernel* end,
                                    const std::string& first_segment, const std::function<void(int)>& solve,
                                    const char* what) {
  cu::check(d->CtxSetCurrent(ctx), "cuCtxSetCurrent");
  segment_count = 0;
  solve_checks.clear();
  open_segment(first_segment);
  int solved = -1;
  for (const PlannedKernel* kp = begin; kp != end; ++kp) {
    const PlannedKernel& k = *kp;
    if (k.stage.empty()) {
      launch(k);
      continue;
    }
    const int o = k.parts.front().op;
    if (o == solved) continue;  // the op's other solver stages: solve() launched them
    solved = o;
    solve(o);
  }
  close_segment();
  synchronize(what);
  read_solve_checks();
}

void GpuTimestep::Impl::solve_forward(int o) {
  if (graph.ops()[o].spec->solver == "newmark_pcg")
    newmark(o);
  else
    extension(o);
}

void GpuTimestep::Impl::run(int op_count) {
  const bool whole = op_count >= int(graph.ops().size());
  const size_t end = whole ? plan.forward.size() : plan.prefix_cut(false, op_count);
  segment_prefix = whole ? "segment" : fmt::format("segment (ops < {})", op_count);
  launch_plan(plan.forward.data(), plan.forward.data() + end, segment_prefix + " 0",
              [this](int o) { solve_forward(o); }, "forward step");
}

void GpuTimestep::Impl::adjoint_newmark(int o) {
  const OpNode& op = graph.ops()[o];
  const cu::DevicePtr w = scratch.at(scratch_of("w", o)).ptr;
  // The residual's reference, the largest cotangent of the step's adjoint time-step solves,
  // and the first solve's warm start, extrapolated from its solutions at the two later steps
  // (runtime/solvers.cpp, newmark_adjoint; clear_warm_starts marks them absent for a new
  // backward pass).
  const int reference_mode = adjoint_reference_set ? 2 : 1;
  adjoint_reference_set = true;
  const cu::DevicePtr rhs = adjoints.at(op.output("u")).ptr;
  const int x_start = reference_mode == 1 && warm_adjoint_solves ? ops::kWarmChainX : ops::kZeroX;
  if (grid_solves) {  // the grid kernel runs its setup itself
    grid_pcg(kernel(newmark_grid, false, o), w, std::max(8L * sizes.cell, long(sizes.node)), solver.cg_tolerance,
             solver.cg_max_iterations, scratch.at("v_iterations_sink").ptr, "adjoint time-step solve",
             &adjoint_cg_iterations, reference_mode, rhs, x_start, scratch.at(scratch_of("w_before", o)).ptr);
    return;
  }
  newmark_setup(o, rhs, w, x_start);
  const std::vector<int> its = pcg(w, 3L * sizes.node, solver.cg_tolerance, solver.cg_max_iterations, newmark_apply(o),
                                   "adjoint time-step solve", fmt::format("adjoint newmark {}", o), reference_mode);
  for (int k = 0; k < batch; ++k) adjoint_cg_iterations[k] += its[k];
}

// The adjoint solves' warm chain: no later solutions (NaN: every byte 0xff, in float and double).
void GpuTimestep::Impl::clear_warm_starts() {
  for (size_t o = 0; o < graph.ops().size(); ++o)
    if (graph.ops()[o].spec->solver == "newmark_pcg")
      for (const char* key : {"w", "w_before"})
        if (const auto w = scratch.find(scratch_of(key, int(o))); w != scratch.end())
          cu::check(d->MemsetD8(w->second.ptr, 0xff, w->second.bytes), "clear warm starts");
}

void GpuTimestep::Impl::adjoint_extension(int o) {
  if (dense_extension) {  // y stays zero: extension_solve_nodes adds nothing
    Call product;
    product.len = 32L * long(dense_extension->sources.size());
    launch(kernel("extension_dense_adjoint", true, o), product);
    return;
  }
  const cu::DevicePtr y = scratch.at(scratch_of("y", o)).ptr;
  Call setup;
  setup.vectors = {{"v_x", y}, {"v_b", scratch.at("v_b").ptr}, {"v_inv_diag", scratch.at("v_inv_diag").ptr}};
  setup.values = {{"zero_x", fresh_backward ? 1 : 0}};
  launch(kernel("extension_adj_setup", true), setup);
  if (grid_solves)
    grid_pcg(kernel(extension_grid), y, sizes.band, solver.extension_tolerance, solver.extension_max_iterations,
             scratch.at("v_iterations_sink").ptr, "adjoint displacement extension", nullptr, 0);
  else
    pcg(y, 3L * sizes.band, solver.extension_tolerance, solver.extension_max_iterations, extension_apply(),
        "adjoint displacement extension", fmt::format("adjoint extension {}", o), 0);
}

void GpuTimestep::Impl::solve_adjoint(int o) {
  if (graph.ops()[o].spec->solver == "newmark_pcg")
    adjoint_newmark(o);
  else
    adjoint_extension(o);
}

void GpuTimestep::Impl::run_adjoint(int op_count) {
  // The first segment holds the extension setup, whose zero_x argument differs between
  // the first step of a backward pass and the others: one captured graph each. A step
  // without the extension leaves its warm start to the next step that has it.
  const bool whole = op_count >= int(graph.ops().size());
  const size_t begin = whole ? 0 : plan.prefix_cut(true, op_count);
  segment_prefix = whole ? "adjoint segment" : fmt::format("adjoint segment (ops < {})", op_count);
  adjoint_reference_set = false;
  warm_adjoint_solves = true;
  adjoint_cg_iterations.assign(batch, 0);
  launch_plan(plan.adjoint.data() + begin, plan.adjoint.data() + plan.adjoint.size(),
              !whole ? segment_prefix + " 0" : fresh_backward ? "adjoint segment 0 (fresh)" : "adjoint segment 0",
              [this](int o) { solve_adjoint(o); }, "adjoint step");
  warm_adjoint_solves = false;
  if (whole) fresh_backward = false;
}

}  // namespace ssc
