// `ssc kernels SCENE --out DIR [--arch sm_90] [--real float|double]`: writes the kernel
// plan of the scene's timestep graph (plan.txt) and the CUDA source of every forward and
// adjoint kernel (kernels/<name>.cu), compiles each with NVRTC (in parallel, cached) and
// prints a table of registers, shared memory and spills. Needs no GPU.
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <thread>

#include "codegen/cuda_source.h"
#include "codegen/kernel_plan.h"
#include "runtime/errors.h"
#include "models/io/text_file.h"
#include "models/io/output_dir.h"
#include "models/io/run_record.h"
#include "models/sim/scene.h"
#include "models/sim/timestep_graph.h"
#include "runtime/nvrtc_compiler.h"
#include "tools/ssc/commands.h"
#include "tools/ssc/progress.h"

namespace ssc {
namespace {

struct KernelsOptions {
  std::string scene, out, arch = "sm_90", real = "double";
  std::vector<std::string> overrides;
  bool extension = true, no_compile = false, fmad = false;
  ProgressMode progress = ProgressMode::Auto;
};

// Compiles in rounds of one kernel per thread, so that progress can be told between rounds.
std::vector<CompiledKernel> compile_with_progress(const std::vector<KernelSource>& sources, const NvrtcOptions& no,
                                                  ProgressMode mode) {
  const size_t round = std::max(1u, std::thread::hardware_concurrency());
  Progress progress("kernels: compiled", int(sources.size()), mode);
  std::vector<CompiledKernel> compiled;
  for (size_t begin = 0; begin < sources.size(); begin += round) {
    const std::vector<KernelSource> some(sources.begin() + long(begin),
                                         sources.begin() + long(std::min(sources.size(), begin + round)));
    for (CompiledKernel& k : compile_kernels(some, no)) compiled.push_back(std::move(k));
    progress.update(int(compiled.size()), compiled.back().name);
  }
  progress.finish();
  return compiled;
}

int run_kernels(const KernelsOptions& o) {
  if (o.real != "double" && o.real != "float") throw InputError("--real must be float or double, not " + o.real);
  const Scene scene = load_scene(o.scene, o.overrides);
  OutputDir out(o.out, {o.scene, scene.object.path});
  out.manifest()["scene"] = {{"file", o.scene}, {"resolved", scene.resolved}};
  out.manifest()["arch"] = o.arch;
  out.manifest()["real"] = o.real;
  const TimestepGraph t = build_timestep_graph(int(scene.planes.size()), o.extension, timestep_model(scene));
  const KernelPlan plan = plan_kernels(t.graph);
  out.make_folder("kernels");
  write_text_file(out.file("graph.txt"), t.graph.describe());
  write_text_file(out.file("plan.txt"), plan.text(t.graph));
  const CodegenOptions co{o.real, 128};
  std::vector<KernelSource> sources;
  for (const PlannedKernel* k : plan.unique_kernels()) {
    sources.push_back({k->name, kernel_source(*k, co)});
    write_text_file(out.file("kernels/" + k->name + ".cu"), sources.back().source);
  }
  std::printf("%s: %zu forward and %zu adjoint launches per step, %zu distinct kernels (Real = %s)\n",
              scene.file.c_str(), plan.forward.size(), plan.adjoint.size(), sources.size(), o.real.c_str());
  auto finish = [&] {
    out.commit();
    std::printf("plan and sources written to %s\n", o.out.c_str());
    return 0;
  };
  if (o.no_compile) return finish();
  if (!nvrtc_available()) {
    warn("no_nvrtc", "NVRTC is not available (built without the CUDA toolkit): sources only");
    return finish();
  }
  NvrtcOptions no;
  no.arch = o.arch;
  no.fmad = o.fmad;
  const auto start = std::chrono::steady_clock::now();
  const std::vector<CompiledKernel> compiled = compile_with_progress(sources, no, o.progress);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::string table = fmt::format("{:<58} {:>5} {:>6} {:>6} {:>7} {:>7} {:>9}\n", "kernel", "regs", "smem", "stack",
                                  "spill_s", "spill_l", "compile");
  int cached = 0;
  for (const CompiledKernel& k : compiled) {
    const KernelResources& r = k.resources;
    cached += k.from_cache;
    auto shown = [&](int v) { return r.known && !r.from_cubin ? std::to_string(v) : std::string("-"); };  // "-": not known
    table += fmt::format("{:<58} {:>5} {:>6} {:>6} {:>7} {:>7} {:>9}\n", k.name, r.known ? std::to_string(r.registers) : "-",
                         r.known ? std::to_string(r.shared_bytes) : "-", shown(r.stack_bytes), shown(r.spill_store_bytes),
                         shown(r.spill_load_bytes), k.from_cache ? "cached" : fmt::format("{:.0f} ms", k.compile_ms));
  }
  write_text_file(out.file("resources.txt"), table);
  std::printf("\n%s", table.c_str());
  std::printf("\n%zu kernels for %s (%s, NVRTC %s): %.2f s wall, %d from the cache (%s)\n", compiled.size(),
              o.arch.c_str(), std::all_of(compiled.begin(), compiled.end(), [](const CompiledKernel& k) { return k.is_cubin; }) ? "CUBIN" : "PTX fallback", nvrtc_version().c_str(), secs, cached,
              kernel_cache_dir().empty() ? "cache off" : kernel_cache_dir().c_str());
  return finish();
}

}  // namespace

Command register_kernels(CLI::App& app) {
  auto o = std::make_shared<KernelsOptions>();
  CLI::App* sub = app.add_subcommand("kernels", "Write and compile the CUDA kernels of a scene's timestep (no GPU needed)");
  sub->add_option("scene", o->scene, "Scene JSON file")->required();
  sub->add_option("--out", o->out, "Output folder for plan.txt, resources.txt and kernels/*.cu (replaced atomically)")->required();
  sub->add_option("--arch", o->arch, "GPU architecture, e.g. sm_90");
  sub->add_option("--real", o->real, "float or double");
  sub->add_flag("--fmad", o->fmad, "Allow fused multiply-add contraction (default off)");
  sub->add_flag("--no-compile", o->no_compile, "Write plan and sources only");
  sub->add_option("--set", o->overrides, "Override a scene key: dotted.key=JSON, repeatable");
  add_progress_options(sub, &o->progress);
  return [o] { return run_kernels(*o); };
}

}  // namespace ssc
