// The recording readers of `ssc prepare` (models/recording/): Open3D's folder, TUM RGB-D's
// depth.txt and a plain folder of PNGs; format detection; the time axis; and every error a
// user can meet (intrinsics missing or for another image size, irregular timestamps, a
// missing frame, a depth scale given the wrong way round).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "models/io/run_record.h"
#include "models/recording/depth_recording.h"
#include "models/recording/frame_timing.h"
#include "tests/expect_input_error.h"

namespace fs = std::filesystem;

namespace ssc {
namespace {

class RecordingReaders : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("ssc-readers-" + std::to_string(getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    clear_warnings();
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(dir_);
  }
  // A 8x6 image whose pixel (u, v) reads `base + u` millimetres (0 at (0, 0): no reading).
  static DepthImage image(double base) {
    DepthImage img;
    img.width = 8, img.height = 6;
    for (int v = 0; v < 6; ++v)
      for (int u = 0; u < 8; ++u) img.depth.push_back(u == 0 && v == 0 ? 0.0 : base + 0.001 * u);
    return img;
  }
  void open3d(int frames, const std::string& intrinsics_json = "") {
    fs::create_directories(dir_ / "o3d/depth");
    for (int f = 0; f < frames; ++f)
      write_depth_png((dir_ / "o3d/depth" / fmt::format("{:06d}.png", f)).string(), image(1.0 + 0.01 * f), 0.001);
    std::ofstream(dir_ / "o3d/intrinsic.json")
        << (intrinsics_json.empty() ? R"({"width": 8, "height": 6, "intrinsic_matrix": [6, 0, 0, 0, 6.5, 0, 3.5, 2.5, 1]})"
                                    : intrinsics_json);
  }
  void tum(const std::vector<double>& times) {
    fs::create_directories(dir_ / "tum/depth");
    std::ofstream list(dir_ / "tum/depth.txt");
    list << "# depth maps\n# timestamp filename\n";
    for (size_t f = 0; f < times.size(); ++f) {
      const std::string name = fmt::format("depth/{:.6f}.png", times[f]);
      write_depth_png((dir_ / "tum" / name).string(), image(0.8 + 0.01 * f), 1.0 / 5000);
      list << fmt::format("{:.6f} {}\n", times[f], name);
    }
  }
  fs::path dir_;
};

TEST_F(RecordingReaders, ReadsOpen3dFolderWithColumnMajorIntrinsics) {
  open3d(3);
  RecordingOptions o;
  o.fps = 30;
  const DepthRecording r = read_recording((dir_ / "o3d").string(), o);
  EXPECT_EQ(r.format, "open3d");
  ASSERT_EQ(r.frames.size(), 3u);
  EXPECT_EQ(r.intrinsics.width, 8);
  EXPECT_EQ(r.intrinsics.fx, 6);
  EXPECT_EQ(r.intrinsics.fy, 6.5);
  EXPECT_EQ(r.intrinsics.cx, 3.5);
  EXPECT_EQ(r.intrinsics.cy, 2.5);
  EXPECT_EQ(r.frames[0].at(0, 0), 0.0);  // zero is no reading
  EXPECT_NEAR(r.frames[2].at(3, 1), 1.023, 1e-12);
  EXPECT_NEAR(r.timestamps[2], 2.0 / 30, 1e-15);
}

TEST_F(RecordingReaders, Open3dWithoutFpsOrIntrinsicsIsAnError) {
  open3d(2);
  expect_input_error([&] { read_recording((dir_ / "o3d").string(), {}); }, {"--fps", "timestamps"});
  fs::remove(dir_ / "o3d/intrinsic.json");
  RecordingOptions o;
  o.fps = 30;
  o.format = "open3d";
  expect_input_error([&] { read_recording((dir_ / "o3d").string(), o); }, {"intrinsic.json", "--intrinsics"});
}

TEST_F(RecordingReaders, RowMajorIntrinsicMatrixIsRefused) {
  open3d(1, R"({"width": 8, "height": 6, "intrinsic_matrix": [6, 0, 3.5, 0, 6.5, 2.5, 0, 0, 1]})");
  RecordingOptions o;
  o.fps = 30;
  expect_input_error([&] { read_recording((dir_ / "o3d").string(), o); }, {"intrinsic.json", "intrinsic_matrix", "column-major"});
}

TEST_F(RecordingReaders, IntrinsicsForAnotherImageSizeAreAnError) {
  open3d(1, R"({"width": 640, "height": 480, "intrinsic_matrix": [525, 0, 0, 0, 525, 0, 319.5, 239.5, 1]})");
  RecordingOptions o;
  o.fps = 30;
  expect_input_error([&] { read_recording((dir_ / "o3d").string(), o); }, {"intrinsic.json", "640x480", "8x6"});
  // fx,fy,cx,cy of a 640x480 camera on 8x6 images: the principal point gives it away.
  o.intrinsics = "525,525,319.5,239.5";
  expect_input_error([&] { read_recording((dir_ / "o3d").string(), o); }, {"--intrinsics", "principal point", "8x6"});
}

TEST_F(RecordingReaders, ReadsTumWithItsTimestampsAndScale) {
  tum({100.0, 100.0334, 100.0661, 100.1002});
  RecordingOptions o;
  o.intrinsics = "6,6,3.5,2.5";
  const DepthRecording r = read_recording((dir_ / "tum").string(), o);
  EXPECT_EQ(r.format, "tum");
  EXPECT_DOUBLE_EQ(r.depth_scale, 1.0 / 5000);
  ASSERT_EQ(r.frames.size(), 4u);
  EXPECT_NEAR(r.frames[1].at(2, 2), 0.812, 1e-4);
  EXPECT_DOUBLE_EQ(r.timestamps[3], 100.1002);
  const FrameTiming t = regularise_timestamps(r.timestamps, 1.0 / 30, "depth.txt");
  EXPECT_EQ(t.frame_index, (std::vector<int>{0, 1, 2, 3}));
  EXPECT_NEAR(t.frame_dt, 0.0334, 0.0005);
}

TEST_F(RecordingReaders, TumMissingFrameFileAndNoIntrinsicsAreErrors) {
  tum({1.0, 1.033});
  RecordingOptions o;
  expect_input_error([&] { read_recording((dir_ / "tum").string(), o); }, {"intrinsics", "--intrinsics", "freiburg1"});
  o.intrinsics = "6,6,3.5,2.5";
  fs::remove(dir_ / "tum/depth/1.033000.png");
  expect_input_error([&] { read_recording((dir_ / "tum").string(), o); }, {"depth.txt", "line 4", "missing"});
}

TEST_F(RecordingReaders, PlainFolderNeedsIntrinsicsAndFps) {
  fs::create_directories(dir_ / "plain");
  for (int f = 0; f < 3; ++f) write_depth_png((dir_ / "plain" / fmt::format("d{}.png", f)).string(), image(1), 0.001);
  RecordingOptions o;
  EXPECT_EQ(detect_recording_format((dir_ / "plain").string()), "folder");
  expect_input_error([&] { read_recording((dir_ / "plain").string(), o); }, {"--intrinsics"});
  o.intrinsics = "6,6,3.5,2.5";
  expect_input_error([&] { read_recording((dir_ / "plain").string(), o); }, {"--fps"});
  o.fps = 15;
  o.depth_scale = 0.0005;
  const DepthRecording r = read_recording((dir_ / "plain").string(), o);
  EXPECT_EQ(r.frames.size(), 3u);
  EXPECT_NEAR(r.frames[0].at(1, 0), 0.5 * 1.001, 1e-9);
  EXPECT_NEAR(r.timestamps[2], 2.0 / 15, 1e-15);
  o.depth_scale = 1000;  // Open3D's units per metre instead of metres per unit
  expect_input_error([&] { read_recording((dir_ / "plain").string(), o); }, {"--depth-scale", "0.001"});
}

TEST_F(RecordingReaders, NumberedFilesPlaceADroppedFrame) {
  open3d(4);
  fs::remove(dir_ / "o3d/depth/000002.png");
  RecordingOptions o;
  o.fps = 10;
  const DepthRecording r = read_recording((dir_ / "o3d").string(), o);
  EXPECT_EQ(r.timestamps, (std::vector<double>{0.0, 0.1, 0.3}));
  ASSERT_EQ(warnings().size(), 1u);
  EXPECT_EQ(warnings()[0].code, "dropped_frames");
}

TEST_F(RecordingReaders, FrameRangeSelectsFrames) {
  open3d(5);
  RecordingOptions o;
  o.fps = 30;
  parse_frame_range("1:3", &o);
  const DepthRecording r = read_recording((dir_ / "o3d").string(), o);
  ASSERT_EQ(r.frames.size(), 2u);
  EXPECT_NEAR(r.frames[0].at(1, 1), 1.011, 1e-12);
  parse_frame_range("3:9", &o);
  expect_input_error([&] { read_recording((dir_ / "o3d").string(), o); }, {"--frames", "0 <= A < B <= 5"});
  expect_input_error([&] { parse_frame_range("x", &o); }, {"--frames"});
}

TEST_F(RecordingReaders, UnknownFolderIsAnError) {
  fs::create_directories(dir_ / "empty");
  expect_input_error([&] { read_recording((dir_ / "empty").string(), {}); }, {"depth.txt", "intrinsic.json", "PNG"});
  expect_input_error([&] { read_recording((dir_ / "nothing").string(), {}); }, {"not a folder"});
}

TEST(FrameTiming, JitterIsKeptOnTheFrameGridAndGapsAreDroppedFrames) {
  clear_warnings();
  const FrameTiming t = regularise_timestamps({0.0, 0.034, 0.066, 0.135, 0.166}, 0.1, "t");
  EXPECT_EQ(t.frame_index, (std::vector<int>{0, 1, 2, 4, 5}));
  EXPECT_EQ(t.dropped, 1);
  EXPECT_NEAR(t.frame_dt, 0.0333, 0.0005);
  EXPECT_EQ(warnings().size(), 1u);
}

TEST(FrameTiming, IrregularTimestampsAreAnError) {
  expect_input_error([] { regularise_timestamps({0.0, 0.033, 0.066, 0.116, 0.149}, 0.1, "depth.txt"); },
                     {"depth.txt", "irregular timestamps", "frames 2 and 3"});
}

}  // namespace
}  // namespace ssc
