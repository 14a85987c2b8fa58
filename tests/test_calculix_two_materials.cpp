// A body of two materials against CalculiX: the cube of tests/data/calculix_drops/two_materials
// (tools/calculix/drops.py, case two_materials: a soft third at 50 kPa and a stiff two thirds at
// 400 kPa, split across the body by a plane that cuts ssc's 25 mm cells obliquely), dropped onto
// a 20 degree incline; its surface at 60 Hz rendered by `ssc render` with 1 mm noise. The
// frames that `ssc diagnose` holds out (the last 30 %: the second impact) are what a fit of the
// effect has to predict. At CalculiX's truth, ssc's model with the two materials must predict
// them much better than any homogeneous body; with each cell's modulus taken from the side its
// centroid lies on it did not (0.494 against 0.500 at best), with the cells' shares of each side
// it does.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "models/diagnosis/model_fit.h"
#include "models/sim/parameters.h"
#include "models/sim/problem.h"

namespace ssc {
namespace {

const std::string kCase = std::string(SSC_TEST_DATA_DIR) + "/calculix_drops/two_materials";

struct Split {
  double held_in = 0, held_out = 0;
};

Split costs(const Problem& problem, const PhysicalParameters& p, int held_in_frames) {
  const std::vector<double> frames = per_frame_costs(problem, p, "cpu");
  Split s;
  for (size_t f = 0; f < frames.size(); ++f) (int(f) < held_in_frames ? s.held_in : s.held_out) += frames[f];
  return s;
}

TEST(CalculixTwoMaterials, TheTrueBodyPredictsTheHeldOutFramesBetterThanAnyHomogeneousOne) {
  const Problem problem = load_problem(kCase + "/scene.json", {}, kCase + "/obs");
  ASSERT_EQ(problem.frames.size(), 22u);
  const int held_in = 15;  // diagnose holds out the last 30 %: frames 15-21
  const PhysicalParameters truth = PhysicalParameters::from_scene(problem.scene);
  const Split at_truth = costs(problem, truth, held_in);
  std::printf("two materials at CalculiX's truth: held-in cost %.4g, held-out %.4g\n", at_truth.held_in,
              at_truth.held_out);
  double best_held_out = 1e300;
  for (double E : {1e5, 2e5, 3e5, 4e5}) {
    PhysicalParameters homogeneous = truth;
    set_parameter(homogeneous, "youngs_modulus", E);
    set_parameter(homogeneous, "material.regions[0].youngs_modulus", E);
    const Split h = costs(problem, homogeneous, held_in);
    std::printf("homogeneous, E = %.0f kPa: held-in %.4g, held-out %.4g\n", E / 1e3, h.held_in, h.held_out);
    best_held_out = std::min(best_held_out, h.held_out);
  }
  EXPECT_LT(at_truth.held_out, 0.5 * best_held_out);
}

}  // namespace
}  // namespace ssc
