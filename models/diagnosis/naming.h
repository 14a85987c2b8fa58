// Which candidates `ssc diagnose` names, and which of them is the cause (diagnosis.h states
// the rule in words): a candidate's verdict, the bars its held-out gain must clear, and the
// order the cause is taken from. Apart from the fits, so that the rule is tested on its own.
#pragma once
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "models/diagnosis/fitted_model.h"

namespace ssc {

// What a diagnosis says of one candidate (diagnosis.json's candidates[]).
struct CandidateVerdict {
  std::string name;
  double gain = 0, gain_low = 0, gain_high = 0;  // fraction of the base's held-out cost removed
  double placebo_gain = 0;
  double discretization_gain = 0;  // the largest discretization control's gain, the other bar it must beat
  // A measurement candidate's bar instead: the gain of its correction over the finest control's
  // fit, laid onto that fit's motion (NaN where there is no control).
  double control_gain = std::numeric_limits<double>::quiet_NaN(), control_gain_low = std::numeric_limits<double>::quiet_NaN();
  double score = std::numeric_limits<double>::quiet_NaN();  // predicted relative held-in decrease
  // The same on the held-in frames (the base's held-in cost removed), and the discretization
  // controls' largest held-in gain. A switch of the model with no parameter of its own
  // (`parameter_free`: the Neo-Hookean material) can be named on them (clears_bars).
  double heldin_gain = std::numeric_limits<double>::quiet_NaN(), heldin_gain_low = std::numeric_limits<double>::quiet_NaN(),
         heldin_gain_high = std::numeric_limits<double>::quiet_NaN();
  double discretization_heldin_gain = 0;
  bool parameter_free = false;
  int degrees_of_freedom = 0;  // its fitted parameters and those its proposal searched
  bool named_on_heldin = false;  // set by clears_bars' caller where only the held-in bar was cleared
  bool passes = false;
  // The frames after the event the extension is about (the first contact with any plane; with
  // the added plane for second_plane; frame 0 for air drag), held-in part: the fraction of the
  // base's cost removed there, and the Akaike difference n ln(RSS / RSS_base) + 2 k over its n
  // observed points (negative favours the extension; k its extra parameters). -1: no event.
  int event_frame = -1;
  double event_gain = std::numeric_limits<double>::quiet_NaN();
  double event_aic = std::numeric_limits<double>::quiet_NaN();
  // The fit's parameters at an end of their plausible range ("air_drag = 1.5 kg/m^3 at the
  // upper end of its plausible range [0, 1.5] (air: ...)"): such a candidate is not named.
  std::vector<std::string> implausible;
  std::vector<std::string> warnings;
};

// A physical candidate: the gain at least min_gain, and its interval's lower end above both its
// placebo's gain and the discretization controls' by margin. A measurement candidate: the
// same over its placebo and, instead of the controls' gain, its gain over the finest
// control's fit (CandidateVerdict::control_gain) where that control gained; inside every
// plausible range either way. A parameter-free physical candidate also passes on the held-in
// frames: its held-in gain at least min_gain, its interval's lower end above the controls'
// held-in gain by margin, and its held-out interval reaching 0 or above (`heldin_bar_only`).
// With no parameter to fit the noise with, its held-in gain is evidence as a held-out one is;
// where the base already predicts the held-out frames to the noise, they cannot tell.
bool clears_bars(const CandidateVerdict& v, bool measurement, bool control_gained, const DiagnosisOptions& o);
// Whether it passes on the held-in bar alone (for the printed lines).
bool heldin_bar_only(const CandidateVerdict& v, bool measurement, bool control_gained, const DiagnosisOptions& o);

// The named candidates (indices into verdicts) as the cause is taken from them: measurement
// candidates first, then by gain. With a measurement first, the physical ones were fitted to
// uncorrected frames: returned in *unjudged.
void order_named(std::vector<size_t>& named, const std::vector<CandidateVerdict>& verdicts,
                 std::vector<std::string>* unjudged);

// Among the named candidates the data cannot tell from the first (a `confounded` pair with
// it), the one with the fewest degrees of freedom, the first on a tie, is moved to the front
// of `named`: the simpler of two models that predict alike. Returns whether the first changed.
bool prefer_the_simplest(std::vector<size_t>& named, const std::vector<CandidateVerdict>& verdicts,
                         const std::vector<std::pair<std::string, std::string>>& confounded);

// The line for a confounded pair: "a or b: indistinguishable with this data", and where both
// are fitted candidates (fa, fb not null) whose fits differ in a base parameter by 10 % or
// more (moved_base), each such value with each model: "...; youngs_modulus 5.704e+04 Pa with
// a, 1.496e+05 Pa with b: these data cannot tell which".
std::string confounded_line(const std::string& a, const std::string& b, const FittedModel* fa, const FittedModel* fb);

}  // namespace ssc
