// NVRTC compilation and the kernel cache (see nvrtc_compiler.h).
#include "runtime/nvrtc_compiler.h"

#include <fmt/format.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <thread>

#include "codegen/sha256.h"
#include "runtime/cubin_resources.h"

#ifdef SSC_HAVE_NVRTC
#include <nvrtc.h>
#endif

namespace ssc {
namespace fs = std::filesystem;

bool nvrtc_available() {
#ifdef SSC_HAVE_NVRTC
  return true;
#else
  return false;
#endif
}

std::string nvrtc_version() {
#ifdef SSC_HAVE_NVRTC
  int major = 0, minor = 0;
  if (nvrtcVersion(&major, &minor) == NVRTC_SUCCESS) return fmt::format("{}.{}", major, minor);
#endif
  return "none";
}

std::vector<std::string> nvrtc_option_list(const NvrtcOptions& o) {
  std::vector<std::string> v = {"--gpu-architecture=" + o.arch, "-std=c++17", "--ptxas-options=-v"};
  if (o.line_info) v.push_back("--generate-line-info");
  v.push_back(o.fmad ? "--fmad=true" : "--fmad=false");
  return v;
}

std::string kernel_cache_dir() {
  if (const char* c = std::getenv("SSC_KERNEL_CACHE")) {
    if (std::string(c) == "off" || std::string(c).empty()) return "";
    return (fs::path(c) / "v1").string();
  }
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return (fs::path(x) / "ssc/kernels/v1").string();
  if (const char* home = std::getenv("HOME"); home && *home) return (fs::path(home) / ".cache/ssc/kernels/v1").string();
  return "";
}

std::string kernel_cache_key(const std::string& source, const NvrtcOptions& o) {
  std::string id = "ssc-kernel-cache-v1\n";
  id += "ssc " SSC_VERSION "\nnvrtc " + nvrtc_version() + "\narch " + o.arch + "\n";
  for (const std::string& s : nvrtc_option_list(o)) id += "opt " + s + "\n";
  id += "source " + std::to_string(source.size()) + "\n" + source;
  return sha256_hex(id);
}

KernelResources parse_ptxas_log(const std::string& log, const std::string& name) {
  KernelResources r;
  const size_t at = log.find("'" + name + "'");
  if (at == std::string::npos) return r;
  std::string tail = log.substr(at);
  const size_t next = tail.find("Compiling entry function", 1);
  if (next != std::string::npos) tail = tail.substr(0, next);
  std::smatch m;
  if (std::regex_search(tail, m, std::regex("Used (\\d+) registers"))) {
    r.registers = std::stoi(m[1]);
    r.known = true;
  }
  if (std::regex_search(tail, m, std::regex("(\\d+) bytes smem"))) r.shared_bytes = std::stoi(m[1]);
  if (std::regex_search(tail, m, std::regex("(\\d+) bytes stack frame"))) r.stack_bytes = std::stoi(m[1]);
  if (std::regex_search(tail, m, std::regex("(\\d+) bytes spill stores"))) r.spill_store_bytes = std::stoi(m[1]);
  if (std::regex_search(tail, m, std::regex("(\\d+) bytes spill loads"))) r.spill_load_bytes = std::stoi(m[1]);
  return r;
}

namespace {

std::string read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Writes `data` to a temporary file in the same folder and renames it over `p`.
void publish(const fs::path& p, const std::string& data) {
  static std::atomic<unsigned> counter{0};
  const fs::path tmp = p.string() + fmt::format(".tmp.{}.{}", getpid(), counter++);
  {
    std::ofstream out(tmp, std::ios::binary);
    out.write(data.data(), std::streamsize(data.size()));
    if (!out) throw std::runtime_error("cannot write " + tmp.string());
  }
  fs::rename(tmp, p);
}

nlohmann::json resources_json(const KernelResources& r) {
  return {{"known", r.known},           {"from_cubin", r.from_cubin}, {"registers", r.registers},
          {"shared_bytes", r.shared_bytes}, {"stack_bytes", r.stack_bytes},
          {"spill_store_bytes", r.spill_store_bytes}, {"spill_load_bytes", r.spill_load_bytes}};
}

std::string dump_source(const std::string& name, const std::string& source, const std::string& log) {
  fs::path dir;
  if (const char* d = std::getenv("SSC_DUMP_KERNELS"); d && *d)
    dir = d;
  else
    dir = fs::temp_directory_path() / "ssc-failed-kernels";
  std::error_code ec;
  fs::create_directories(dir, ec);
  const fs::path p = dir / (name + ".cu");
  std::ofstream(p) << source;
  if (!log.empty()) std::ofstream(dir / (name + ".log")) << log;
  return p.string();
}

}  // namespace

CompiledKernel compile_kernel(const std::string& name, const std::string& source, const NvrtcOptions& o) {
  CompiledKernel k;
  k.name = name;
  k.key = kernel_cache_key(source, o);
  const std::string dir = o.use_cache ? kernel_cache_dir() : "";
  if (const char* d = std::getenv("SSC_DUMP_KERNELS"); d && *d) dump_source(name, source, "");
  if (!dir.empty()) {
    for (const char* ext : {".cubin", ".ptx"}) {
      const fs::path bin = fs::path(dir) / (k.key + ext), meta = fs::path(dir) / (k.key + ".json");
      if (fs::exists(bin) && fs::exists(meta)) {
        try {
          const auto j = nlohmann::json::parse(read_file(meta));
          if (j.at("name") != name) continue;
          k.image = read_file(bin);
          k.is_cubin = std::string(ext) == ".cubin";
          k.log = j.value("log", "");
          const auto& r = j.at("resources");
          k.resources.known = r.at("known");
          k.resources.from_cubin = r.value("from_cubin", false);
          k.resources.registers = r.at("registers");
          k.resources.shared_bytes = r.at("shared_bytes");
          k.resources.stack_bytes = r.at("stack_bytes");
          k.resources.spill_store_bytes = r.at("spill_store_bytes");
          k.resources.spill_load_bytes = r.at("spill_load_bytes");
          k.from_cache = true;
          if (!k.image.empty()) return k;
        } catch (const std::exception&) {
          // A damaged entry is recompiled and overwritten.
        }
      }
    }
  }
#ifndef SSC_HAVE_NVRTC
  throw NvrtcError(fmt::format("cannot compile kernel {}: ssc was built without NVRTC (no CUDA toolkit)", name));
#else
  const auto start = std::chrono::steady_clock::now();
  auto check = [&](nvrtcResult r, const char* what) {
    if (r != NVRTC_SUCCESS)
      throw NvrtcError(fmt::format("NVRTC {} failed for kernel {}: {}", what, name, nvrtcGetErrorString(r)));
  };
  auto run = [&](const std::vector<std::string>& opts, bool cubin) -> bool {
    nvrtcProgram prog;
    check(nvrtcCreateProgram(&prog, source.c_str(), (name + ".cu").c_str(), 0, nullptr, nullptr), "create");
    std::vector<const char*> argv;
    for (const std::string& s : opts) argv.push_back(s.c_str());
    const nvrtcResult r = nvrtcCompileProgram(prog, int(argv.size()), argv.data());
    size_t log_size = 0;
    nvrtcGetProgramLogSize(prog, &log_size);
    std::string log(log_size, '\0');
    if (log_size) nvrtcGetProgramLog(prog, log.data());
    while (!log.empty() && log.back() == '\0') log.pop_back();
    k.log = log;
    if (r != NVRTC_SUCCESS) {
      nvrtcDestroyProgram(&prog);
      if (r == NVRTC_ERROR_INVALID_OPTION) return false;
      const std::string path = dump_source(name, source, log);
      throw NvrtcError(fmt::format("NVRTC could not compile kernel {} ({}); source: {}\n{}", name,
                                   nvrtcGetErrorString(r), path, log));
    }
    size_t size = 0;
    if (cubin) {
      if (nvrtcGetCUBINSize(prog, &size) != NVRTC_SUCCESS || size == 0) {
        nvrtcDestroyProgram(&prog);
        return false;
      }
      k.image.assign(size, '\0');
      check(nvrtcGetCUBIN(prog, k.image.data()), "get CUBIN");
    } else {
      check(nvrtcGetPTXSize(prog, &size), "get PTX size");
      k.image.assign(size, '\0');
      check(nvrtcGetPTX(prog, k.image.data()), "get PTX");
    }
    nvrtcDestroyProgram(&prog);
    return true;
  };
  const std::vector<std::string> opts = nvrtc_option_list(o);
  k.is_cubin = run(opts, true);
  if (!k.is_cubin) {  // PTX for the virtual arch (driver JIT on load)
    std::vector<std::string> p = opts;
    std::string arch = o.arch;
    if (arch.rfind("sm_", 0) == 0) arch = "compute_" + arch.substr(3);
    p[0] = "--gpu-architecture=" + arch;
    p.erase(std::remove(p.begin(), p.end(), std::string("--ptxas-options=-v")), p.end());
    if (!run(p, false))
      throw NvrtcError(fmt::format("NVRTC rejected the options for kernel {} (arch {}):\n{}", name, o.arch, k.log));
  }
  k.resources = parse_ptxas_log(k.log, name);
  if (const CubinResources c = k.is_cubin && !k.resources.known ? cubin_resources(k.image, name) : CubinResources{}; c.found) {
    k.resources.known = k.resources.from_cubin = true;
    k.resources.registers = c.registers;
    k.resources.shared_bytes = c.shared_bytes;
  }
  k.compile_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (const char* d = std::getenv("SSC_DUMP_KERNELS"); d && *d && !k.log.empty())
    std::ofstream(fs::path(d) / (name + ".log")) << k.log;
  if (!dir.empty()) {
    try {
      fs::create_directories(dir);
      const char* ext = k.is_cubin ? ".cubin" : ".ptx";
      publish(fs::path(dir) / (k.key + ".cu"), source);
      publish(fs::path(dir) / (k.key + ext), k.image);
      nlohmann::json j = {{"name", name}, {"arch", o.arch}, {"options", nvrtc_option_list(o)},
                          {"nvrtc", nvrtc_version()}, {"ssc", SSC_VERSION}, {"log", k.log},
                          {"resources", resources_json(k.resources)}};
      publish(fs::path(dir) / (k.key + ".json"), j.dump(2));  // last: marks the entry complete
    } catch (const std::exception&) {
      // A read-only or full cache folder only costs the next run a recompile.
    }
  }
  return k;
#endif
}

std::vector<CompiledKernel> compile_kernels(const std::vector<KernelSource>& kernels, const NvrtcOptions& o,
                                            int threads) {
  if (threads <= 0) threads = int(std::max(1u, std::thread::hardware_concurrency()));
  threads = std::min<int>(threads, int(std::max<size_t>(1, kernels.size())));
  std::vector<CompiledKernel> out(kernels.size());
  std::vector<std::exception_ptr> errors(kernels.size());
  std::atomic<size_t> next{0};
  std::vector<std::thread> pool;
  for (int t = 0; t < threads; ++t)
    pool.emplace_back([&] {
      for (size_t i; (i = next++) < kernels.size();) {
        try {
          out[i] = compile_kernel(kernels[i].name, kernels[i].source, o);
        } catch (...) {
          errors[i] = std::current_exception();
        }
      }
    });
  for (std::thread& t : pool) t.join();
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
  return out;
}

}  // namespace ssc
