// Which candidates `ssc diagnose` names, and which of them is the cause (diagnosis.h states
// the rule in words): the bars a candidate's held-out gain must clear, and the order the
// cause is taken from. Apart from the fits, so that the rule is tested on its own.
#pragma once
#include <string>
#include <vector>

#include "models/diagnosis/diagnosis.h"

namespace ssc {

// A physical candidate: the gain at least min_gain, and its interval's lower end above both its
// placebo's gain and the discretization controls' by margin. A measurement candidate: the
// same over its placebo and, instead of the controls' gain, its gain over the finest
// control's fit (CandidateVerdict::control_gain) where that control gained; inside every
// plausible range either way.
bool clears_bars(const CandidateVerdict& v, bool measurement, bool control_gained, const DiagnosisOptions& o);

// The named candidates (indices into verdicts) as the cause is taken from them: measurement
// candidates first, then by gain. With a measurement first, the physical ones were fitted to
// uncorrected frames: returned in *unjudged.
void order_named(std::vector<size_t>& named, const std::vector<CandidateVerdict>& verdicts,
                 std::vector<std::string>* unjudged);

}  // namespace ssc
