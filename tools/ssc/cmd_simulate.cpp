// `ssc simulate SCENE --out DIR`: runs the forward simulation and writes the deformed
// surface of every frame (PLY) and a summary (JSON), atomically.
#include <fmt/format.h>

#include <chrono>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "runtime/errors.h"
#include "models/io/text_file.h"
#include "models/io/output_dir.h"
#include "models/io/ply_writer.h"
#include "models/io/run_record.h"
#include "models/sim/body.h"
#include "models/sim/deformed_surface.h"
#include "models/sim/simulation.h"
#include "tools/ssc/commands.h"
#include "tools/ssc/device_option.h"
#include "tools/ssc/progress.h"
#include "tools/ssc/run_checks.h"

namespace ssc {
namespace {

struct SimulateOptions {
  std::string scene, out;
  std::vector<std::string> overrides, probes;
  bool no_frames = false;
  std::string device = "auto";
  ProgressMode progress = ProgressMode::Auto;
};

Eigen::Vector3d parse_probe(const std::string& text) {
  std::stringstream in(text);
  Eigen::Vector3d p;
  char c1 = 0, c2 = 0;
  if (!(in >> p.x() >> c1 >> p.y() >> c2 >> p.z()) || c1 != ',' || c2 != ',' || !in.eof())
    throw InputError(fmt::format("--probe {}: expected three comma-separated numbers x,y,z (metres, rest pose)", text));
  return p;
}

nlohmann::json vec_json(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

nlohmann::json frame_record(const Simulation& sim, int frame, const std::vector<Eigen::Vector3d>& probes) {
  nlohmann::json f;
  f["frame"] = frame;
  f["time"] = frame * sim.dt();
  f["center_of_mass"] = vec_json(sim.center_of_mass(0));
  f["kinetic_energy"] = sim.kinetic_energy(0);
  f["elastic_energy"] = sim.elastic_energy(0);
  f["gravitational_energy"] = sim.gravitational_energy(0);
  f["contact_energy"] = sim.contact_energy(0);
  f["cg_iterations"] = frame == 0 ? 0 : sim.last_cg_iterations(0);
  if (!sim.on_gpu()) f["degenerate_cells"] = frame == 0 ? 0 : sim.degenerate_cells(0);
  nlohmann::json p = nlohmann::json::array();
  for (const Eigen::Vector3d& x : probes) p.push_back(vec_json(sim.probe(0, x)));
  f["probes"] = p;
  return f;
}

int run_simulate(const SimulateOptions& o) {
  const auto start = std::chrono::steady_clock::now();
  const Scene scene = load_scene(o.scene, o.overrides);
  OutputDir out(o.out, {o.scene, scene.object.path});
  out.manifest()["scene"] = {{"file", o.scene}, {"resolved", scene.resolved}};
  std::vector<Eigen::Vector3d> probes;
  for (const std::string& p : o.probes) probes.push_back(parse_probe(p));
  const SimGrid grid = build_body_grid(scene);
  Simulation sim(scene, grid);
  for (const Eigen::Vector3d& p : probes) sim.probe(0, p);  // reject bad probes before running
  const std::string device = place_simulation(sim, o.device);
  const DeformedSurface surface(grid);
  out.manifest()["device"] = device;
  out.make_folder("frames");
  note(fmt::format("{}: {} cells, {} nodes, {} band nodes, {} contact points, mass {:.4g} kg", scene.file, grid.cell_count,
                   grid.node_count, grid.band_count, grid.contact_points.size(), sim.total_mass()));

  nlohmann::json frames = nlohmann::json::array();
  auto write_frame = [&](int frame) {
    frames.push_back(frame_record(sim, frame, probes));
    if (!o.no_frames)
      write_ply(out.file(fmt::format("frames/frame_{:04d}.ply", frame)), surface.positions(sim.displacement(0)),
                surface.triangles());
  };
  write_frame(0);
  Progress progress("simulate: step", scene.time.steps, o.progress);
  const auto sim_start = std::chrono::steady_clock::now();
  for (int s = 1; s <= scene.time.steps; ++s) {
    sim.step();
    write_frame(s);
    progress.update(s, fmt::format("CG {}", sim.last_cg_iterations(0)));
  }
  progress.finish();
  report_inverted_cells(sim);
  const double sim_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - sim_start).count();

  nlohmann::json summary;
  summary["scene"] = scene.file;
  summary["dt"] = scene.time.dt;
  summary["steps"] = scene.time.steps;
  summary["theta"] = scene.time.theta;
  summary["grid"] = {{"cell_size", grid.h},
                     {"cells", grid.cell_count},
                     {"nodes", grid.node_count},
                     {"band_nodes", grid.band_count},
                     {"contact_points", grid.contact_points.size()},
                     {"volume", grid.total_volume},
                     {"floored_weights", grid.floored_weights}};
  summary["mass"] = sim.total_mass();
  nlohmann::json probe_list = nlohmann::json::array();
  for (const auto& p : probes) probe_list.push_back(vec_json(p));
  summary["probe_points"] = probe_list;
  summary["frames"] = frames;
  summary["device"] = device;
  summary["seconds_per_step"] = scene.time.steps > 0 ? sim_seconds / scene.time.steps : 0.0;
  summary["warnings"] = warnings_json();
  summary["wall_seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  write_text_file(out.file("summary.json"), summary.dump(2) + "\n");
  out.commit();
  std::printf("wrote %s (%d frames, %.2f ms per step)\n", o.out.c_str(), scene.time.steps + 1,
              1e3 * summary["seconds_per_step"].get<double>());
  return 0;
}

}  // namespace

Command register_simulate(CLI::App& app) {
  auto o = std::make_shared<SimulateOptions>();
  CLI::App* sub = app.add_subcommand("simulate", "Run the forward simulation of a scene");
  sub->add_option("scene", o->scene, "Scene file (JSON, docs/scene-format.md)")->required();
  sub->add_option("--out", o->out, "Output folder (replaced atomically)")->required();
  sub->add_option("--set", o->overrides, "Override a scene key: dotted.key=JSON, repeatable");
  sub->add_option("--probe", o->probes, "Record the displacement of rest point x,y,z (metres), repeatable");
  sub->add_flag("--no-frames", o->no_frames, "Write only summary.json, no PLY frames");
  add_device_option(sub, &o->device);
  add_progress_options(sub, &o->progress);
  return [o] { return run_simulate(*o); };
}

}  // namespace ssc
