// Where the two_materials candidate's interface lies: its orientation, offset and moduli, searched
// from the stiffness gradient's proposal (candidates.h, interface_proposal).
//
// A region's cells are fixed when its grid is built, so the interface's geometry cannot be a
// parameter of the fit: the problem is loaded once and each geometry reassigns the region's
// cells (models/sim/body.h). The search is a pattern search over the normal (tilted towards
// four directions across it), the offset (moved both ways) and the ratio of the two moduli
// (where the guess gives the body's), with the steps halved each round; a geometry's score is
// the held-in cost at the best of a few scales of its moduli, all run as one batch of
// simulations, with the base fit's other parameters. The body's modulus is the guess's (the
// gradient fit's soft side: a homogeneous base can be many times too stiff for a body with a
// stiff part). The candidate's fit then takes the best geometry found.
#pragma once
#include <string>

#include "models/diagnosis/candidates.h"
#include "models/diagnosis/model_fit.h"

namespace ssc {

struct InterfaceSearchOptions {
  int rounds = 3;
  double tilt_deg = 15;         // the first round's tilt of the normal
  double shift_fraction = 1.0 / 8;  // the first round's offset step, of the body's extent
  int moves_per_round = 3;
  int moduli = 4;               // moduli per geometry: both sides' (the second's alone where the
                                //   body's is not given) times 3^t, t from -1 to 1
  double ratio_step = 2;        // the first round's factor on the second modulus alone
};

struct InterfaceSearch {
  InterfaceGuess best;       // the geometry and its best moduli
  double heldin_cost = 0;    // there
  double start_cost = 0;     // at the proposal
  int geometries = 0;        // geometries scored
};

InterfaceSearch search_interface(const FittedModel& base, const InterfaceGuess& start, const DiagnosisContext& c,
                                 const InterfaceSearchOptions& options = {});

}  // namespace ssc
