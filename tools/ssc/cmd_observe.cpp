// `ssc observe SCENE --out DIR`: simulates the scene and writes synthetic depth images
// in the same folder format a real RGB-D recording is read from (docs/observation-format.md).
#include <fmt/format.h>

#include "models/observation/observation_set.h"
#include "models/sim/body.h"
#include "models/sim/observation_setup.h"
#include "tools/ssc/commands.h"
#include "tools/ssc/device_option.h"
#include "tools/ssc/progress.h"
#include "tools/ssc/run_checks.h"
#include "models/io/output_dir.h"
#include "runtime/errors.h"

namespace ssc {

Command register_observe(CLI::App& app) {
  struct Options {
    std::string scene, out;
    std::vector<std::string> overrides;
    std::string device = "auto";
    ProgressMode progress = ProgressMode::Auto;
  };
  auto o = std::make_shared<Options>();
  CLI::App* sub = app.add_subcommand("observe", "Simulate a scene and render synthetic depth observations");
  sub->add_option("scene", o->scene, "Scene file with an 'observation' section")->required();
  sub->add_option("--out", o->out, "Observation folder to write (replaced atomically)")->required();
  sub->add_option("--set", o->overrides, "Override a scene key: dotted.key=JSON, repeatable");
  add_device_option(sub, &o->device);
  add_progress_options(sub, &o->progress);
  return [o] {
    const Scene scene = load_scene(o->scene, o->overrides);
    const ObservationSpec spec = parse_observation_spec(scene);
    OutputDir out(o->out, {o->scene, scene.object.path});
    out.manifest()["scene"] = {{"file", o->scene}, {"resolved", scene.resolved}};
    const SimGrid grid = build_body_grid(scene);
    Progress progress("observe: frame", scene.time.steps / spec.every + 1, o->progress);
    const ObservationSet set = render_observations(
        scene, grid, spec, [&](int done, int) { progress.update(done); },
        [&](Simulation& sim) {
          out.manifest()["device"] = place_simulation(sim, o->device);
        },
        [&](const Simulation& sim) { report_inverted_cells(sim); });
    progress.finish();
    size_t points = 0;
    for (int f = 0; f < set.frame_count; ++f)
      for (const DepthImage& img : set.frames[f])
        for (double d : img.depth) points += d > 0;
    if (points == 0)  // nothing a reconstruction could use: nothing is written
      throw InputError(fmt::format("{}: no camera sees the body in any frame (every depth pixel is empty); check "
                                   "observation.cameras (eye, target, fov_deg) and max_depth",
                                   o->scene));
    write_observation_files(out.path(), set);
    out.commit();
    std::printf("wrote %s: %d frames x %zu cameras, %zu depth measurements, noise %.3g m\n", o->out.c_str(),
                set.frame_count, set.cameras.size(), points, spec.noise);
    return 0;
  };
}

}  // namespace ssc
