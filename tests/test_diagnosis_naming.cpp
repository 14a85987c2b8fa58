// The naming rule of `ssc diagnose` (models/diagnosis/naming.h) on verdicts with the figures of
// the CalculiX drop whose cameras.json has focal lengths 3 % too large (docs/diagnosis.md):
// the correction removes 26 % of the held-out residual and 47 % beyond the half-cell control,
// which itself removes 36 %; two_materials removes 70 %.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "models/diagnosis/naming.h"

namespace ssc {
namespace {

CandidateVerdict verdict(const std::string& name, double gain, double low, double discretization) {
  CandidateVerdict v;
  v.name = name;
  v.gain = gain, v.gain_low = low, v.gain_high = gain + (gain - low);
  v.discretization_gain = discretization;
  return v;
}

TEST(DiagnosisNaming, APhysicalCandidateMustBeatTheDiscretizationControls) {
  const DiagnosisOptions o;
  EXPECT_TRUE(clears_bars(verdict("two_materials", 0.70, 0.59, 0.364), false, true, o));
  EXPECT_FALSE(clears_bars(verdict("two_materials", 0.59, 0.46, 0.529), false, true, o));  // the clean drop
  CandidateVerdict v = verdict("two_materials", 0.70, 0.59, 0.364);
  v.placebo_gain = 0.6;
  EXPECT_FALSE(clears_bars(v, false, true, o));
  v = verdict("air_drag", 0.85, 0.80, 0.0);
  v.implausible = {"air_drag = 265 kg/m^3 at the upper end of its plausible range"};
  EXPECT_FALSE(clears_bars(v, false, false, o));
}

TEST(DiagnosisNaming, AMeasurementCandidateMustGainBeyondTheFinestControl) {
  const DiagnosisOptions o;
  CandidateVerdict focal = verdict("focal_length", 0.258, 0.214, 0.364);
  EXPECT_FALSE(clears_bars(focal, true, true, o)) << "not laid onto the control: no pass";
  focal.control_gain = 0.465, focal.control_gain_low = 0.420;
  EXPECT_TRUE(clears_bars(focal, true, true, o));
  EXPECT_FALSE(clears_bars(focal, false, true, o)) << "the same figures for a physical candidate";
  focal.control_gain = 0.15, focal.control_gain_low = 0.10;
  EXPECT_FALSE(clears_bars(focal, true, true, o)) << "what the control leaves, it hardly explains";
  // No control gained (ssc-made data, or none run): the placebo and min_gain alone.
  EXPECT_TRUE(clears_bars(verdict("depth_scale", 0.96, 0.95, 0.0), true, false, o));
  EXPECT_FALSE(clears_bars(verdict("depth_scale", 0.15, 0.12, 0.0), true, false, o));
}

// The ssc-made Neo-Hookean cube thrown at 2 m/s (docs/diagnosis.md, step 8): the base predicts
// the held-out frames to the noise, the Neo-Hookean model fits the bounce the held-in frames saw.
TEST(DiagnosisNaming, AParameterFreeSwitchCanBeNamedOnTheHeldInFrames) {
  const DiagnosisOptions o;
  CandidateVerdict nh = verdict("nonlinear_material", 0.005, -0.042, 0.0);
  nh.gain_high = 0.053;
  nh.heldin_gain = 0.324, nh.heldin_gain_low = 0.25, nh.heldin_gain_high = 0.40;
  EXPECT_FALSE(clears_bars(nh, false, false, o)) << "not a parameter-free switch: the held-out bar alone";
  nh.parameter_free = true;
  EXPECT_TRUE(clears_bars(nh, false, false, o));
  EXPECT_TRUE(heldin_bar_only(nh, false, false, o));
  EXPECT_FALSE(clears_bars(nh, true, false, o)) << "a measurement is never named on the frames it was fitted to";
  CandidateVerdict v = nh;
  v.discretization_heldin_gain = 0.22;
  EXPECT_FALSE(clears_bars(v, false, false, o)) << "a finer discretization fits the held-in frames as well";
  v = nh;
  v.gain = -0.34, v.gain_low = -0.58, v.gain_high = -0.02;
  EXPECT_FALSE(clears_bars(v, false, false, o)) << "the held-out frames speak against it";
  v = nh;
  v.heldin_gain = 0.15, v.heldin_gain_low = 0.10;
  EXPECT_FALSE(clears_bars(v, false, false, o)) << "below min_gain";
  v = verdict("nonlinear_material", 0.90, 0.87, 0.0);  // named on the held-out frames: not on the held-in bar alone
  v.parameter_free = true, v.heldin_gain = 0.70, v.heldin_gain_low = 0.65;
  EXPECT_TRUE(clears_bars(v, false, false, o));
  EXPECT_FALSE(heldin_bar_only(v, false, false, o));
}

// The CalculiX clean drop with 6 elements a 0.2 m edge (docs/diagnosis.md): the stiffness
// gradient (3 parameters) and the Neo-Hookean switch (none) remove 64 % and 63 %, alike.
TEST(DiagnosisNaming, OfTwoCandidatesThatPredictAlikeTheSimplerIsTheCause) {
  std::vector<CandidateVerdict> verdicts = {verdict("heterogeneous_stiffness", 0.64, 0.55, 0.03),
                                            verdict("two_materials", 0.49, 0.40, 0.03),
                                            verdict("nonlinear_material", 0.63, 0.44, 0.03)};
  verdicts[0].degrees_of_freedom = 3, verdicts[1].degrees_of_freedom = 4, verdicts[2].degrees_of_freedom = 0;
  std::vector<size_t> named = {0, 2, 1};
  EXPECT_FALSE(prefer_the_simplest(named, verdicts, {})) << "told apart: the largest gain stays the cause";
  EXPECT_EQ(named, (std::vector<size_t>{0, 2, 1}));
  EXPECT_TRUE(prefer_the_simplest(named, verdicts, {{"heterogeneous_stiffness", "nonlinear_material"}}));
  EXPECT_EQ(named, (std::vector<size_t>{2, 0, 1}));
  // Alike, but the other is the larger model: the first stays (a stiffness gradient against
  // two materials whose interface was searched: 3 against 4).
  named = {0, 1};
  EXPECT_FALSE(prefer_the_simplest(named, verdicts, {{"two_materials", "heterogeneous_stiffness"}}));
  EXPECT_EQ(named, (std::vector<size_t>{0, 1}));
  // A measurement first is not traded for a physical candidate.
  verdicts.push_back(verdict("focal_length", 0.3, 0.2, 0.03));
  verdicts[3].degrees_of_freedom = 1;
  named = {3, 2};
  EXPECT_FALSE(prefer_the_simplest(named, verdicts, {{"focal_length", "nonlinear_material"}}));
}

TEST(DiagnosisNaming, AMeasurementIsTheCauseBeforeAnyPhysicalCandidate) {
  const std::vector<CandidateVerdict> verdicts = {verdict("two_materials", 0.70, 0.59, 0.364),
                                                  verdict("focal_length", 0.258, 0.214, 0.364),
                                                  verdict("heterogeneous_stiffness", 0.69, 0.59, 0.364)};
  std::vector<size_t> named = {0, 1, 2};
  std::vector<std::string> unjudged;
  order_named(named, verdicts, &unjudged);
  EXPECT_EQ(named, (std::vector<size_t>{1, 0, 2}));
  EXPECT_EQ(unjudged, (std::vector<std::string>{"two_materials", "heterogeneous_stiffness"}));
  named = {2, 0};
  unjudged.clear();
  order_named(named, verdicts, &unjudged);
  EXPECT_EQ(named, (std::vector<size_t>{0, 2})) << "physical candidates alone: by gain";
  EXPECT_TRUE(unjudged.empty());
}

TEST(DiagnosisNaming, AConfoundedPairSaysWhichBaseValuesDifferBetweenItsFits) {
  // The gentle two-material drop at a reduced budget (docs/diagnosis.md, session 29): the two
  // fits predict alike, with moduli 57.0 and 149.6 kPa; the mass damping is within 10 %.
  FittedModel sharp, smooth;
  sharp.name = "two_materials", smooth.name = "heterogeneous_stiffness";
  sharp.names = {"youngs_modulus", "mass_damping", "material.regions[0].youngs_modulus"};
  sharp.values = Eigen::Vector3d(57041.6, 0.100, 310747.6);
  smooth.names = {"youngs_modulus", "mass_damping", "material.stiffness_gradient.x"};
  smooth.values = Eigen::Vector3d(149574.5, 0.105, 15.6);
  const std::string line = confounded_line(sharp.name, smooth.name, &sharp, &smooth);
  EXPECT_EQ(line.rfind("two_materials or heterogeneous_stiffness: indistinguishable with this data; youngs_modulus ", 0), 0u)
      << line;
  EXPECT_NE(line.find(" with two_materials, "), std::string::npos) << line;
  EXPECT_NE(line.find(" with heterogeneous_stiffness: these data cannot tell which"), std::string::npos) << line;
  EXPECT_EQ(line.find("mass_damping"), std::string::npos) << line;
  smooth.values[0] = 60000;  // within 10 %: nothing to tell apart
  EXPECT_EQ(confounded_line(sharp.name, smooth.name, &sharp, &smooth),
            "two_materials or heterogeneous_stiffness: indistinguishable with this data");
  // A pair from the identifiability check: the cause and a base parameter, no fit of its own.
  EXPECT_EQ(confounded_line("air_drag", "mass_damping", &sharp, nullptr),
            "air_drag or mass_damping: indistinguishable with this data");
}

}  // namespace
}  // namespace ssc
