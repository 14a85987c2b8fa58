// A plain folder of 16-bit depth PNGs: everything the files do not say comes from the
// command line: --intrinsics (required), --fps (required), --depth-scale (default 0.001,
// millimetres). Frame numbers in the file names place a dropped frame.
#include <fmt/format.h>

#include "models/recording/recording_readers.h"
#include "runtime/errors.h"

namespace ssc {

DepthRecording read_folder_recording(const std::string& folder, const RecordingOptions& options) {
  DepthRecording r;
  r.files = list_png_files(folder);
  if (r.files.empty()) throw InputError(fmt::format("{}: holds no PNG depth frame", folder));
  take_intrinsics(r, options, folder,
                  fmt::format("{}: a folder of depth PNGs needs the camera's intrinsics: give --intrinsics "
                              "fx,fy,cx,cy (pixels) or --intrinsics FILE (JSON with width, height, "
                              "intrinsic_matrix)", folder));
  r.depth_scale = depth_scale_option(options, 0.001);
  r.timestamps = timestamps_from_numbered_files(options, r.files, "a folder of depth PNGs");
  select_frames(options, &r.files, &r.timestamps, folder);
  return r;
}

}  // namespace ssc
