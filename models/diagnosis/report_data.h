// The residual parts of the report's data (models/diagnosis/report_html.h): the residual
// against time, residual images per camera and the residual on the rest shape, before (the
// base fit) and, when given, after (the model with the named extension); in millimetres.
#pragma once
#include <nlohmann/json.hpp>

#include "models/diagnosis/residuals.h"

namespace ssc {

// Adds "residual_vs_time", "residual_images" (up to `images` frames, every camera) and
// "rest_shape" (at most 4000 points) to data.
void add_residual_report_data(nlohmann::json& data, const Problem& problem, const Residuals& before,
                              const Residuals* after, int images = 4);

}  // namespace ssc
