// The score test: a ranking of the candidates that have an "off" value, from one simulation
// and one backward pass. The held-in cost's gradient at the base fit, with every such
// extension present at off, is turned into the relative cost decrease a typical amount of each
// would bring (one-sided for coefficients that cannot go below off, such as friction and air
// drag; in its best direction for a vector, such as a stiffness gradient).
#pragma once
#include <map>
#include <string>

#include "models/diagnosis/model_fit.h"

namespace ssc {

std::map<std::string, double> score_test(const FittedModel& base, const DiagnosisContext& c);

}  // namespace ssc
