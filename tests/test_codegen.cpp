// The CUDA code generator (codegen/) and its NVRTC compiler (runtime/nvrtc_compiler):
//  - CodegenPlan: snapshot of the kernel plan of the torus timestep graph (hashes
//    sanitised) against tests/data/codegen_torus_plan.txt (SSC_UPDATE_SNAPSHOTS=1 rewrites it),
//    fusion and cut rules, no atomics, run-time values absent from the source;
//  - NvrtcCompile: every forward and adjoint kernel of the example graphs compiles for
//    sm_90 in double and float (skipped without NVRTC), the cache and its keys;
// The generated kernels run on a GPU in tests/test_gpu.cpp.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>

#include "codegen/cuda_source.h"
#include "codegen/kernel_plan.h"
#include "codegen/sha256.h"
#include "models/sim/body.h"
#include "models/sim/scene.h"
#include "models/sim/simulation.h"
#include "models/sim/timestep_graph.h"
#include "runtime/cuda_runtime.h"
#include "runtime/cubin_resources.h"
#include "runtime/nvrtc_compiler.h"
#include "tests/gpu_test_support.h"

namespace ssc {
namespace {

namespace fs = std::filesystem;

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

NvrtcOptions test_options(const std::string& arch = "sm_90") {
  NvrtcOptions o;
  o.arch = arch;
  o.fmad = false;
  return o;
}

TEST(CodegenSha256, KnownVectors) {
  EXPECT_EQ(sha256_hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(sha256_hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(sha256_hex(std::string(1000, 'a')), "41edece42d63e8d9bf515a9ba6932e1c20cbc9f5a5d134645adb5db1b9737ea3");
}

TEST(CodegenPlan, TorusSnapshot) {
  const TimestepGraph t = build_timestep_graph(1, true);
  const std::string text = plan_kernels(t.graph).text(t.graph, true);
  const fs::path ref = fs::path(SSC_SOURCE_DIR) / "tests/data/codegen_torus_plan.txt";
  if (std::getenv("SSC_UPDATE_SNAPSHOTS")) std::ofstream(ref) << text;
  ASSERT_TRUE(fs::exists(ref)) << "missing " << ref << " (run with SSC_UPDATE_SNAPSHOTS=1)";
  EXPECT_EQ(text, read_text(ref)) << "the kernel plan changed; review it and run with SSC_UPDATE_SNAPSHOTS=1";
}

TEST(CodegenPlan, FusionAndCuts) {
  const TimestepGraph t = build_timestep_graph(1, true);
  const KernelPlan plan = plan_kernels(t.graph);
  // The Lame parameters, the corotation, its offset force and K u- share the cell kernel.
  const PlannedKernel* corot = plan.find(false, "lame");
  ASSERT_NE(corot, nullptr);
  ASSERT_EQ(corot->parts.size(), 4u);
  EXPECT_EQ(corot->parts[0].label, "lame");
  EXPECT_EQ(corot->parts[2].label, "corotation_force");
  EXPECT_EQ(corot->parts[3].label, "stiffness_apply");
  EXPECT_EQ(corot->name.rfind("fwd_cell_lame_corotation_corotation_force_etc__", 0), 0u) << corot->name;
  // The solve is a solver sequence, each stage its own kernel.
  for (const char* label : {"newmark_apply_cell", "newmark_apply_node", "pcg_start", "pcg_iterate", "extension_apply"})
    EXPECT_NE(plan.find(false, label), nullptr) << label;
  for (const PlannedKernel& k : plan.forward) EXPECT_FALSE(k.cut.empty()) << k.name;
  // The adjoint runs ops in reverse: the first adjoint kernel belongs to the last op.
  ASSERT_FALSE(plan.adjoint.empty());
  EXPECT_EQ(plan.adjoint.front().ops.front(), int(t.graph.ops().size()) - 1);
  // The Lame cotangents are per cell: the corotation's adjoint fuses behind its force's.
  const PlannedKernel* adj_corot = plan.find(true, "corotation_force");
  ASSERT_NE(adj_corot, nullptr);
  ASSERT_EQ(adj_corot->parts.size(), 2u);
  EXPECT_EQ(adj_corot->parts[1].label, "corotation");
  EXPECT_NE(plan.find(true, "stiffness_apply"), nullptr);
}

// A step no cost observes leaves the band extension out: its kernels are the forward plan's
// tail and the adjoint plan's head, apart from every other op's, in every model's graph.
TEST(CodegenPlan, TheExtensionIsATailOfBothPlans) {
  TimestepModel every;
  every.friction = true, every.region_count = 1, every.stiffness_gradient = true, every.air_drag = true;
  TimestepModel implicit;
  implicit.implicit_contact = true, implicit.updated_corotation = true, implicit.neo_hookean = true;
  for (const TimestepModel& model : {TimestepModel{}, every, implicit}) {
    const TimestepGraph t = build_timestep_graph(2, true, model);
    ASSERT_EQ(t.extension_op, int(t.graph.ops().size()) - 1);
    const KernelPlan plan = plan_kernels(t.graph);
    const size_t f = plan.prefix_cut(false, t.extension_op), a = plan.prefix_cut(true, t.extension_op);
    ASSERT_GT(f, 0u);
    ASSERT_LT(f, plan.forward.size());
    ASSERT_GT(a, 0u);
    ASSERT_LT(a, plan.adjoint.size());
    for (size_t i = 0; i < plan.forward.size(); ++i)
      for (int o : plan.forward[i].ops) EXPECT_EQ(o == t.extension_op, i >= f) << plan.forward[i].name;
    for (size_t i = 0; i < plan.adjoint.size(); ++i)
      for (int o : plan.adjoint[i].ops) EXPECT_EQ(o == t.extension_op, i < a) << plan.adjoint[i].name;
    EXPECT_EQ(plan.prefix_cut(false, int(t.graph.ops().size())), plan.forward.size());
    EXPECT_EQ(plan.prefix_cut(true, int(t.graph.ops().size())), 0u);
  }
  // A cut through a fused kernel (the Lame parameters and the corotation share one) is refused.
  const TimestepGraph t = build_timestep_graph(1, true);
  const KernelPlan plan = plan_kernels(t.graph);
  const PlannedKernel* fused = plan.find(false, "lame");
  ASSERT_NE(fused, nullptr);
  ASSERT_GE(fused->ops.size(), 2u);
  EXPECT_THROW(plan.prefix_cut(false, fused->ops[1]), std::logic_error);
}

TEST(CodegenSource, NoAtomicsAndLineDirectives) {
  const TimestepGraph t = build_timestep_graph(1, true);
  const KernelPlan plan = plan_kernels(t.graph);
  for (const PlannedKernel* k : plan.unique_kernels()) {
    const std::string src = kernel_function(*k);
    EXPECT_EQ(src.find("atomic"), std::string::npos) << k->name;
    EXPECT_NE(src.find("extern \"C\" __global__"), std::string::npos);
  }
  const std::string prelude = kernel_prelude({});
  EXPECT_NE(prelude.find("#line 1 \"ops/elasticity.h\""), std::string::npos);
  EXPECT_NE(prelude.find("typedef double Real;"), std::string::npos);
  EXPECT_NE(kernel_prelude({"float", 128}).find("typedef float Real;"), std::string::npos);
}

TEST(CodegenSource, RunTimeValuesAreParameters) {
  // Two scenes that differ in E, dt, damping and the plane generate identical sources.
  auto sources = [](const Scene& s) {
    const TimestepGraph t = build_timestep_graph(int(s.planes.size()), false);
    std::string all;
    const KernelPlan plan = plan_kernels(t.graph);
    for (const PlannedKernel* k : plan.unique_kernels()) all += kernel_source(*k, {});
    return all;
  };
  const Scene a = torus_scene();
  const Scene b = torus_scene({"material.youngs_modulus=12345.678", "time.dt=0.00731", "material.mass_damping=0.377",
                               "ground.height=0.123"});
  ASSERT_NE(a.material.youngs_modulus, b.material.youngs_modulus);
  ASSERT_NE(a.time.dt, b.time.dt);
  const std::string sa = sources(a), sb = sources(b);
  EXPECT_EQ(sa, sb);
  for (const char* v : {"12345.678", "0.00731", "0.377", "5000", "0.01"}) EXPECT_EQ(sb.find(v), std::string::npos) << v;
}

// ---- NVRTC ----

#define SKIP_WITHOUT_NVRTC() \
  if (!nvrtc_available()) GTEST_SKIP() << "ssc was built without NVRTC (no CUDA toolkit): kernels not compiled"

std::vector<KernelSource> example_kernel_sources(const std::string& real) {
  std::vector<KernelSource> out;
  std::set<std::string> seen;
  struct Variant {
    int planes;
    bool extension;
    TimestepModel model;
  };
  TimestepModel every;  // every extension
  every.friction = every.stiffness_gradient = every.air_drag = true;
  every.region_count = 2;
  TimestepModel iterating = every;  // and the step's nonlinear iterations
  iterating.implicit_contact = iterating.updated_corotation = true;
  iterating.nonlinear_iterations = 2;
  TimestepModel neo_hookean = iterating;  // Neo-Hookean, with the rotation updated and lagged
  neo_hookean.neo_hookean = true;
  TimestepModel neo_hookean_lagged = neo_hookean;
  neo_hookean_lagged.updated_corotation = false;
  for (const Variant& v : {Variant{1, true, {}}, Variant{0, false, {}}, Variant{1, false, {}},
                           Variant{2, true, TimestepModel{true}}, Variant{2, true, every}, Variant{2, true, iterating},
                           Variant{2, true, neo_hookean}, Variant{2, true, neo_hookean_lagged}}) {
    const TimestepGraph t = build_timestep_graph(v.planes, v.extension, v.model);
    const KernelPlan plan = plan_kernels(t.graph);
    for (const PlannedKernel* k : plan.unique_kernels())
      if (seen.insert(k->name).second) out.push_back({k->name, kernel_source(*k, {real, 128})});
  }
  return out;
}

TEST(NvrtcCompile, AllExampleKernelsDoubleAndFloat) {
  SKIP_WITHOUT_NVRTC();
  test_cache_root();
  for (const char* real : {"double", "float"}) {
    const auto sources = example_kernel_sources(real);
    const auto start = std::chrono::steady_clock::now();
    const auto compiled = compile_kernels(sources, test_options());
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ASSERT_EQ(compiled.size(), sources.size());
    int fresh = 0, max_regs = 0, checked = 0;
    for (const CompiledKernel& k : compiled) {
      EXPECT_FALSE(k.image.empty()) << k.name;
      EXPECT_TRUE(k.is_cubin) << k.name << ": fell back to PTX";
      EXPECT_TRUE(k.resources.known) << k.name << " log: " << k.log;
      if (k.resources.known && !k.resources.from_cubin) {  // the CUBIN's reading agrees with ptxas' report
        const CubinResources c = cubin_resources(k.image, k.name);
        EXPECT_TRUE(c.found) << k.name;
        EXPECT_EQ(c.registers, k.resources.registers) << k.name;
        EXPECT_EQ(c.shared_bytes, k.resources.shared_bytes) << k.name;
        ++checked;
      }
      fresh += !k.from_cache;
      max_regs = std::max(max_regs, k.resources.registers);
      if (k.name.find("_pcg_grid") != std::string::npos)  // the persistent solves: registers bound their speed
        std::printf("[ %s ] %s: %d registers, %d bytes spill stores, %d bytes spill loads\n", real, k.name.c_str(),
                    k.resources.registers, k.resources.spill_store_bytes, k.resources.spill_load_bytes);
    }
    std::printf("[ %s ] %zu kernels, %d compiled, %.2f s wall, max %d registers; %d read from the CUBIN as ptxas "
                "reported\n", real, compiled.size(), fresh, s, max_regs, checked);
    RecordProperty(std::string("compile_seconds_") + real, std::to_string(s));
  }
}

TEST(NvrtcCache, SameCubinSecondTimeAndDistinctKeys) {
  SKIP_WITHOUT_NVRTC();
  test_cache_root();
  const TimestepGraph t = build_timestep_graph(0, false);
  const KernelPlan plan = plan_kernels(t.graph);
  const PlannedKernel* k = plan.find(false, "velocity_update");
  ASSERT_NE(k, nullptr);
  const std::string src = kernel_source(*k, {});
  const CompiledKernel a = compile_kernel(k->name, src, test_options());
  const CompiledKernel b = compile_kernel(k->name, src, test_options());
  EXPECT_TRUE(b.from_cache);
  EXPECT_EQ(a.image, b.image);
  EXPECT_EQ(a.key, b.key);
  EXPECT_TRUE(fs::exists(fs::path(kernel_cache_dir()) / (a.key + ".cubin")));
  NvrtcOptions fmad = test_options();
  fmad.fmad = true;
  EXPECT_NE(kernel_cache_key(src, fmad), a.key);
  EXPECT_NE(kernel_cache_key(src, test_options("sm_80")), a.key);
  EXPECT_NE(kernel_cache_key(src + " ", test_options()), a.key);
  const CompiledKernel c = compile_kernel(k->name, src, test_options("sm_80"));
  EXPECT_NE(c.image, a.image);
}

TEST(NvrtcCompile, ErrorNamesKernelSourceAndLog) {
  SKIP_WITHOUT_NVRTC();
  NvrtcOptions o = test_options();
  o.use_cache = false;
  try {
    compile_kernel("broken_kernel", "extern \"C\" __global__ void broken_kernel() { this_is_not_defined(); }", o);
    FAIL() << "expected NvrtcError";
  } catch (const NvrtcError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("broken_kernel"), std::string::npos) << m;
    EXPECT_NE(m.find("broken_kernel.cu"), std::string::npos) << m;
    EXPECT_NE(m.find("this_is_not_defined"), std::string::npos) << m;
  }
}

TEST(NvrtcCompile, PtxasLogParsing) {
  const std::string log =
      "ptxas info    : Compiling entry function 'k1' for 'sm_90'\n"
      "ptxas info    : Function properties for k1\n"
      "    16 bytes stack frame, 8 bytes spill stores, 4 bytes spill loads\n"
      "ptxas info    : Used 72 registers, used 0 barriers, 1024 bytes smem, 400 bytes cmem[0]\n"
      "ptxas info    : Compiling entry function 'k2' for 'sm_90'\n"
      "ptxas info    : Used 12 registers\n";
  const KernelResources r = parse_ptxas_log(log, "k1");
  EXPECT_TRUE(r.known);
  EXPECT_EQ(r.registers, 72);
  EXPECT_EQ(r.shared_bytes, 1024);
  EXPECT_EQ(r.stack_bytes, 16);
  EXPECT_EQ(r.spill_store_bytes, 8);
  EXPECT_EQ(r.spill_load_bytes, 4);
  EXPECT_EQ(parse_ptxas_log(log, "k2").registers, 12);
}

TEST(NvrtcCompile, CubinReaderRefusesWhatIsNoCubin) {
  EXPECT_FALSE(cubin_resources("", "k").found);
  EXPECT_FALSE(cubin_resources("// PTX\n.version 9.0\n", "k").found);
  std::string elf(64, '\0');  // an ELF64 header whose section table lies beyond the file
  elf.replace(0, 6, "\x7f" "ELF\x02\x01");
  elf[0x28] = '\x7f', elf[0x3A] = 64, elf[0x3C] = 4, elf[0x3E] = 1;
  EXPECT_FALSE(cubin_resources(elf, "k").found);
}

}  // namespace
}  // namespace ssc

