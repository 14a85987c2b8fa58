// The potential of the soft-min ground contact (ops/contact.h) per unit k A: its force
// -dU/dd is the penalty -k A softmin(d) on a contact point at signed distance d.
#pragma once

namespace ssc {

// U(d) = -Li2(-exp(-alpha d)) / alpha^2: pi^2 / (12 alpha^2) at d = 0, about
// exp(-alpha d) / alpha^2 far above the plane, d^2/2 deep inside.
double softmin_potential(double d, double alpha);

}  // namespace ssc
