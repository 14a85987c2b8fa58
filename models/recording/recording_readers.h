// The three recording layouts of depth_recording.h, one reader each, and what they share:
// intrinsics from "fx,fy,cx,cy" or a JSON file, the frames' PNGs, the checks.
#pragma once
#include <string>
#include <vector>

#include "models/recording/depth_recording.h"

namespace ssc {

DepthRecording read_open3d_recording(const std::string& folder, const RecordingOptions& options);
DepthRecording read_tum_recording(const std::string& folder, const RecordingOptions& options);
DepthRecording read_folder_recording(const std::string& folder, const RecordingOptions& options);

// Intrinsics from --intrinsics: "fx,fy,cx,cy" (the size comes from the images) or a JSON file
// in Open3D's layout ({"width", "height", "intrinsic_matrix": 9 numbers, column-major}).
DepthIntrinsics parse_intrinsics_option(const std::string& text, std::string* source);
// Open3D's intrinsic JSON file; errors name the file and key.
DepthIntrinsics read_intrinsics_json(const std::string& file);

// intrinsic.json or camera_intrinsic.json in `folder` (Open3D's names), or "".
std::string find_intrinsics_json(const std::string& folder);
// The recording's intrinsics: --intrinsics where given, else the folder's intrinsics JSON;
// with neither, InputError(`missing`). Sets r.intrinsics and r.intrinsics_source.
void take_intrinsics(DepthRecording& r, const RecordingOptions& options, const std::string& folder,
                     const std::string& missing);

// Timestamps f / fps for files numbered in their names (the last digit run): a missing number
// is a dropped frame, a gap in the times (warning dropped_frames); names without digits are
// taken in order. InputError naming --fps when it is missing or not positive.
std::vector<double> timestamps_from_numbered_files(const RecordingOptions& options,
                                                   const std::vector<std::string>& files, const std::string& format);

// Files in `folder` ending in .png (case-insensitive), sorted with digit runs compared as numbers.
std::vector<std::string> list_png_files(const std::string& folder);

// Keeps frames [first_frame, end_frame) of files/timestamps (--frames); InputError naming the range.
void select_frames(const RecordingOptions& options, std::vector<std::string>* files, std::vector<double>* timestamps,
                   const std::string& where);

// Reads every frame's PNG (depth_scale applied) and checks the intrinsics against the image
// size (a width or height of 0 in the intrinsics is taken from the first image).
void load_frames(DepthRecording* recording);

// Evenly spaced timestamps f / fps; InputError naming --fps when it is missing or not positive.
std::vector<double> timestamps_from_fps(const RecordingOptions& options, size_t frames, const std::string& format);

// --depth-scale when given (checked: positive, at most 1 m per unit), else `fallback`.
double depth_scale_option(const RecordingOptions& options, double fallback);

}  // namespace ssc
