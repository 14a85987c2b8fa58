// A raw depth recording as an RGB-D camera's tools write it, before ssc has touched it: one
// camera's intrinsics, its depth frames in metres (0 = no reading) and the time of every
// frame. Three on-disk layouts are read (docs/cli.md#prepare):
//
//   open3d   DIR/depth/*.png and DIR/intrinsic.json (width, height, column-major
//            intrinsic_matrix), as Open3D's RealSense and Azure Kinect recorders write it;
//            no timestamps: --fps gives them
//   tum      DIR/depth.txt ("timestamp filename" lines), 16-bit PNGs at 5000 per metre; the
//            timestamps come from the file
//   folder   DIR/*.png with --intrinsics, --depth-scale and --fps
//
// Every reader checks what it loads (intrinsics against the image size, one size for all
// frames, timestamps) and throws InputError naming the file, the key and the fix.
#pragma once
#include <optional>
#include <string>
#include <vector>

#include "models/observation/depth_png.h"

namespace ssc {

struct DepthIntrinsics {
  int width = 0, height = 0;        // pixels
  double fx = 0, fy = 0, cx = 0, cy = 0;  // pixels, pixel-centre convention
};

struct DepthRecording {
  std::string format;               // "open3d", "tum" or "folder"
  std::string folder;
  DepthIntrinsics intrinsics;
  std::string intrinsics_source;    // where the intrinsics came from, for messages and the manifest
  double depth_scale = 0.001;       // metres per PNG unit
  std::vector<std::string> files;   // per frame
  std::vector<double> timestamps;   // s, per frame, as recorded (or f / fps)
  std::vector<DepthImage> frames;   // metres
};

struct RecordingOptions {
  std::string format = "auto";             // auto | open3d | tum | folder
  std::string intrinsics;                  // "fx,fy,cx,cy" or a JSON file; "" = the format's own
  std::optional<double> depth_scale;       // metres per PNG unit
  std::optional<double> fps;               // frames per second
  int first_frame = 0, end_frame = -1;     // --frames A:B (B exclusive; -1 = to the end)
};

// Detects (format "auto") or takes the format, reads the frames and checks them.
DepthRecording read_recording(const std::string& folder, const RecordingOptions& options);

// "auto" resolved: "tum" for a folder with depth.txt, "open3d" for one with depth/ and an
// intrinsics JSON, "folder" for one with PNGs; InputError otherwise.
std::string detect_recording_format(const std::string& folder);

// Parses --frames "A:B" (either side may be empty) into options; InputError for anything else.
void parse_frame_range(const std::string& text, RecordingOptions* options);

}  // namespace ssc
