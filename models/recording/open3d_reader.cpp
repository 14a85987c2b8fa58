// Open3D's RGB-D folder (its RealSense and Azure Kinect recorders): DIR/depth/*.png,
// millimetres unless --depth-scale says otherwise, and DIR/intrinsic.json (or
// camera_intrinsic.json) with width, height and a column-major intrinsic_matrix. The
// folder has no timestamps: --fps gives them, and the frame numbers in the file names place
// a dropped frame.
#include <fmt/format.h>

#include <filesystem>

#include "models/recording/recording_readers.h"
#include "runtime/errors.h"

namespace fs = std::filesystem;

namespace ssc {

DepthRecording read_open3d_recording(const std::string& folder, const RecordingOptions& options) {
  DepthRecording r;
  const std::string depth_folder = (fs::path(folder) / "depth").string();
  if (!fs::is_directory(depth_folder))
    throw InputError(fmt::format("{}: an Open3D recording keeps its depth frames in depth/, which is missing", folder));
  r.files = list_png_files(depth_folder);
  if (r.files.empty()) throw InputError(fmt::format("{}: holds no PNG depth frame", depth_folder));
  take_intrinsics(r, options, folder,
                  fmt::format("{}: intrinsic.json is missing: an Open3D recording stores the depth camera's "
                              "intrinsics there; copy it from the recorder's output or give --intrinsics "
                              "fx,fy,cx,cy", folder));
  r.depth_scale = depth_scale_option(options, 0.001);
  r.timestamps = timestamps_from_numbered_files(options, r.files, "an Open3D recording");
  select_frames(options, &r.files, &r.timestamps, depth_folder);
  return r;
}

}  // namespace ssc
