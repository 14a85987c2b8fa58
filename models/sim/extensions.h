// The model extensions in one table: the model layer's twin of ops/registry.cpp.
//
// A row says everything the scene reader, the problem loader and `ssc diagnose` need to know
// of one extension: its name (the scene's "extensions" switch and diagnose's candidate), the
// ops it adds to the timestep graph, the scene keys that turn it on, its parameters by exact
// name, the value that turns it off, its typical amount and the range its starts are drawn
// from, the event after which it acts, and how the diagnosis fits it (in the shared batch
// with every other "off"-valued extension, on a plane proposed from the data, or as a switch
// of the model with no parameter of its own). Plausible ranges (what a physical object can
// have) are per parameter: `plausible_range` below, from the parameter table, the row for
// body-dependent ones, and the scene's "plausible" section, which can widen them.
// A new extension is its op (if it needs one) and one row here.
#pragma once
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "models/sim/scene.h"

namespace ssc {

struct ExtensionRow {
  std::string name;  // "friction": the scene's switch and diagnose's candidate
  std::string what;  // one line for messages and docs
  std::vector<std::string> ops;         // the ops it adds to the timestep graph
  std::vector<std::string> scene_keys;  // where a scene turns it on
  // How `ssc diagnose` fits it:
  //   OffValue       its parameters have an off value, so it shares the base model's batch
  //   ProposedPlane  a contact plane proposed from where the base fit leaves the data
  //   ProposedRegion a second material, its interface proposed from the stiffness gradient
  //   ModelSwitch    a change of the model with no parameter of its own
  //   Measurement    a correction of the recording, not of the physics (a camera's focal
  //                  length, the depth unit, the frames' clock: models/observation/
  //                  measurement_correction.h), fitted against the base model's motion
  enum class Fit { OffValue, ProposedPlane, ProposedRegion, ModelSwitch, Measurement } fit = Fit::OffValue;
  std::vector<std::string> overrides;  // scene overrides that put its ops in the model
  // Its parameters as `--fit` takes them (vectors unexpanded) for a scene.
  std::function<std::vector<std::string>(const Scene&)> parameters;
  double off_value = 0;  // Fit::OffValue: the value of each parameter that turns it off
  bool one_sided = false;  // cannot go below its off value (a coefficient, a density)
  // Degrees of freedom chosen by a search on the held-in frames besides its fitted parameters
  // (two_materials: the interface's normal and offset, 3). Counted with them where models the
  // data cannot tell apart are told apart by their size (models/diagnosis/naming.h).
  int searched_degrees_of_freedom = 0;
  // Typical amount (the score test's probe, the identifiability's step at off) and the range
  // starts are drawn from, for a body of this extent (m).
  std::function<double(double extent)> typical;
  std::function<std::pair<double, double>(double extent)> start_range;
  bool log_start = false;  // draw starts log-uniformly
  // The frame from which it acts: the first contact with any plane ("contact"), with the plane
  // it adds ("added_plane"), or the start ("start").
  std::string event = "contact";
  // Whether a parameter name is one of its own (`owner` below).
  std::function<bool(const std::string&)> owns;
  std::function<void(Scene&)> model_on;    // fitting one of its parameters puts it in the model
  std::function<void(Scene&)> switch_off;  // "extensions": {name: false}
  // Fit::Measurement: its one parameter's unit, plausible range (with what it stands for) and
  // what a fitted value says of the recording ("the cameras' focal lengths look 5 % too large").
  std::string unit;
  std::pair<double, double> plausible{0, 0};
  std::string plausible_source;
  std::function<std::string(double)> tell;
};

const std::vector<ExtensionRow>& extension_table();
// nullptr for an unknown name.
const ExtensionRow* find_extension(const std::string& name);
std::vector<std::string> extension_names();
// "friction, heterogeneous_stiffness, ..." for messages.
std::string extension_list();

// The extension a parameter belongs to; the parameter's own name when it belongs to none
// (youngs_modulus, mass_damping).
std::string owner(const std::string& parameter);

// The unit of a parameter: its extension row's for a measurement, else the parameter table's.
std::string parameter_or_measurement_unit(const std::string& parameter);
// Whether a name is a measurement candidate's parameter ("camera.focal_scale").
bool is_measurement_parameter(const std::string& parameter);

// Turns on every extension whose parameter is in `fitted` (a fit or sweep of friction puts
// the friction op in the model), and applies the scene's "extensions" switches.
void model_fitted_extensions(Scene& scene, const std::vector<std::string>& fitted);
void switch_off_extensions(Scene& scene);

// The values a physical object can have for a parameter (exact name): the scene's
// "plausible" section where it names it, else the extension row's for a body of this extent,
// else the parameter table's; an unlimited end is +-infinity. `source` (optional) receives
// where the range comes from, for messages ("air: 1.2 kg/m^3").
std::pair<double, double> plausible_range(const Scene& scene, const std::string& parameter, double extent,
                                          std::string* source = nullptr);
// Empty when the value lies within its plausible range, else why it is not plausible and how
// to widen the range ("air_drag = 20 kg/m^3 is outside its plausible range [0, 1.5] (air: ...)").
std::string implausibility(const Scene& scene, const std::string& parameter, double value, double extent);

}  // namespace ssc
