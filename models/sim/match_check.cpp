// Checks of the observed points' matches (see match_check.h).
#include "models/sim/match_check.h"

#include <fmt/format.h>

#include "runtime/errors.h"
#include "models/io/run_record.h"

namespace ssc {

void check_matches(const std::vector<FrameCost>& frames, const std::string& where, const std::string& at) {
  long points = 0, matched = 0;
  bool every_frame_unsegmented = !frames.empty();
  for (const FrameCost& f : frames) {
    points += f.points;
    matched += f.matched;
    every_frame_unsegmented &= f.points > 0 && f.points - f.matched > kUnsegmentedFraction * f.points;
  }
  if (points == 0)
    throw InputError(fmt::format("{}: the observations hold no depth measurement (every pixel is 0); check the depth "
                                 "images and depth_scale in cameras.json", where));
  if (matched < kMinMatchedFraction * points)
    throw InputError(fmt::format(
        "{}: only {} of {} observed points ({:.1f} %) lie on the simulated body at {}, so the cost says nothing about the "
        "parameters. Usual causes: a camera pose given as world-to-camera (cameras.json wants camera_to_world), the scene "
        "and the recording not in the same frame (object position, ground, time of the first frame), a wrong depth_scale, "
        "or depth that is not segmented (floor and background left in)",
        where, matched, points, 100.0 * matched / points, at));
  if (every_frame_unsegmented)
    warn("unsegmented_depth",
         fmt::format("{}: in every frame more than {:.0f} % of the observed points are far from the simulated body "
                     "({} of {} matched in all, at {}); the depth is probably not segmented (floor or background left in), "
                     "which biases the fit: mask the depth images to the object",
                     where, 100 * kUnsegmentedFraction, matched, points, at));
}

}  // namespace ssc
