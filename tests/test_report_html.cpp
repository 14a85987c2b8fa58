// The diagnosis report page (models/diagnosis/report_html.h): its structure for a synthetic
// report, no throw on missing keys, nulls and NaN, and the page as headless Chromium draws it
// (skipped where no Chromium is installed; tools/setup-build installs it for CI).
#include <gtest/gtest.h>
#include <png.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fmt/format.h>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>
#include <unordered_map>
#include <vector>

#include "models/diagnosis/report_html.h"

namespace ssc {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr int kImageWidth = 32, kImageHeight = 24;

// A residual image: a positive disc left of centre, a negative disc right of it (both
// `amplitude` mm, radius 5 px and a soft edge), a ripple of 5 % on top, no observed points in the top rows.
json residual_image(double amplitude) {
  json pixels = json::array();
  for (int y = 0; y < kImageHeight; ++y)
    for (int x = 0; x < kImageWidth; ++x) {
      if (y < 3) {
        pixels.push_back(nullptr);
        continue;
      }
      auto disc = [&](double cx, double cy) { return std::clamp((7.0 - std::hypot(x - cx, y - cy)) / 2.0, 0.0, 1.0); };
      pixels.push_back(amplitude * (disc(9, 13) - disc(23, 13)) + 0.05 * amplitude * std::sin(0.7 * x + 0.3 * y));
    }
  return pixels;
}

// A report with every section: 2 candidates, 30 time samples, 2 images 32x24, 200 rest points.
json synthetic_report() {
  json time = json::array(), before = json::array(), after = json::array();
  for (int i = 0; i < 30; ++i) {
    const double t = 0.05 * i;
    time.push_back(t);
    before.push_back(1.5 + 0.08 * i + 0.3 * std::sin(6 * t));
    if (i == 17) after.push_back(nullptr);  // a frame without a value
    else after.push_back(0.6 + 0.1 * std::sin(6 * t));
  }
  json points = json::array(), rest_before = json::array(), rest_after = json::array();
  for (int i = 0; i < 200; ++i) {  // a Fibonacci sphere of radius 0.1 m resting on the ground
    const double z = 1 - 2 * (i + 0.5) / 200, r = std::sqrt(1 - z * z), phi = 2.39996323 * i;
    const double px = 0.1 * r * std::cos(phi), py = 0.1 + 0.1 * r * std::sin(phi), pz = 0.1 * z;
    points.push_back({px, py, pz});
    rest_before.push_back(30 * px);  // -3 mm on the left, +3 mm on the right
    if (i == 5) rest_after.push_back(nullptr);
    else rest_after.push_back(5 * px);
  }
  return {
      {"title", "ssc diagnose: examples/<&>ramp.json"},
      {"cause", "friction"},
      {"summary_lines", json::array({"friction at the ground explains 71 % of the held-out residual", "air drag explains no more than its placebo"})},
      {"provenance", {{"scene", "examples/ramp.json"}, {"observations", "examples/ramp_obs"}, {"command", "ssc diagnose examples/ramp.json"},
                      {"version", "0.1.0"}, {"device", "cpu"}, {"date", "2026-01-01T00:00:00Z"}}},
      {"candidates",
       {{{"name", "friction"}, {"extra_parameters", {{"ground.friction", 0.31}}}, {"heldout_before", 1.2e-4}, {"heldout_after", 3.1e-5},
         {"gain", 0.71}, {"gain_low", 0.55}, {"gain_high", 0.83}, {"placebo_gain", 0.05}, {"score", 3.2}, {"passes", true},
         {"base_before", {{"youngs_modulus", 117000}}}, {"base_after", {{"youngs_modulus", 52000}}}, {"warnings", json::array()},
         {"convergence",
          {{"per_start",
            {{{"stop_reason", "converged: relative cost change < tol"}, {"iterations", 3}, {"costs", {4e-4, 1e-4, 3.2e-5, 3.1e-5}}},
             {{"stop_reason", "iteration limit"}, {"iterations", 4}, {"costs", {6e-4, 3e-4, 2e-4, 1.5e-4, 1.2e-4}}}}}}}},
        {{"name", "air_drag"}, {"extra_parameters", {{"air_drag", 0.8}}}, {"heldout_before", 1.2e-4}, {"heldout_after", 1.1e-4},
         {"gain", 0.08}, {"gain_low", -0.04}, {"gain_high", 0.2}, {"placebo_gain", 0.06}, {"score", 0.3}, {"passes", false},
         {"base_before", {{"youngs_modulus", 117000}}}, {"base_after", {{"youngs_modulus", 98000}}},
         {"warnings", {"the 90 % interval includes 0"}}}}},
      {"confounded", json::array({json::array({"air_drag", "mass_damping"})})},
      {"confounded_base",
       json::array({{{"models", {"air_drag", "mass_damping"}}, {"parameter", "youngs_modulus"}, {"values", {98000, 131000}}},
                    {{"models", {"friction", "air_drag"}}, {"parameter", "youngs_modulus"}, {"values", {1, 2}}}})},
      {"base_convergence",
       {{"per_start",
         {{{"stop_reason", "converged: gradient"}, {"iterations", 2}, {"costs", {2e-4, 1.3e-4, 1.2e-4}}},
          {{"stop_reason", "converged: gradient"}, {"iterations", 5}, {"costs", {9e-4, 5e-4, 2e-4, 1.3e-4, 1.21e-4, 1.2e-4}}}}}}},
      {"discretization_controls",
       {{{"name", "finer_grid"}, {"fitted", true}, {"what", "a grid of half the cell size, grid.cell_size 0.025 m"},
         {"parameters", {{"youngs_modulus", 51000}}}, {"gain", 0.21}, {"gain_low", 0.15}, {"gain_high", 0.27}},
        {{"name", "finer_step"}, {"fitted", false}, {"why_not", "the fit failed: <&>"}}}},
      {"parameters", {{"units", {{"youngs_modulus", "Pa"}, {"ground.friction", "1"}}},
                      {"base", {{"youngs_modulus", 117000}}},
                      {"winner", {{"youngs_modulus", 52000}, {"ground.friction", 0.31}}}}},
      {"residual_vs_time", {{"time", time}, {"before_mm", before}, {"after_mm", after}, {"heldout_from", 1.0}, {"contact_times", {0.21, 0.55}}}},
      {"residual_images",
       {{{"camera", "cam"}, {"frame", 12}, {"time", 0.6}, {"width", kImageWidth}, {"height", kImageHeight},
         {"before_mm", residual_image(4.0)}, {"after_mm", residual_image(0.6)}},
        {{"camera", "cam"}, {"frame", 24}, {"time", 1.2}, {"width", kImageWidth}, {"height", kImageHeight},
         {"before_mm", residual_image(3.0)}, {"after_mm", residual_image(0.5)}}}},
      {"rest_shape", {{"points", points}, {"before_mm", rest_before}, {"after_mm", rest_after}}},
  };
}

// Inline SVGs the synthetic report must have: the gain chart, the fits' costs (the base and the
// cause in one), the residual over time, one colour bar and 2 x (before, after) images, one
// colour bar and (before, after) rest shapes.
constexpr size_t kExpectedSvgs = 1 + 1 + 1 + 1 + 4 + 1 + 2;

size_t count_of(const std::string& text, const std::string& needle) {
  size_t n = 0;
  for (size_t at = text.find(needle); at != std::string::npos; at = text.find(needle, at + needle.size())) ++n;
  return n;
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(ReportHtml, RendersEverySectionAndFigureOfASyntheticReport) {
  const std::string html = render_report_html(synthetic_report());
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_EQ(count_of(html, "<svg"), kExpectedSvgs);
  EXPECT_EQ(count_of(html, "class=\"gain-chart\""), 1u);
  EXPECT_EQ(count_of(html, "class=\"colorbar\""), 2u);
  EXPECT_EQ(count_of(html, "class=\"residual-image\""), 4u);
  EXPECT_EQ(count_of(html, "class=\"rest-shape\""), 2u);
  EXPECT_EQ(count_of(html, "shape-rendering=\"crispEdges\""), 4u + 2u);  // the images and the colour bars
  EXPECT_EQ(count_of(html, "<script"), 0u);
  // The title, escaped, in <title> and <h1>; never raw.
  EXPECT_EQ(count_of(html, "examples/&lt;&amp;&gt;ramp.json"), 2u);
  EXPECT_EQ(count_of(html, "<&>"), 0u);
  EXPECT_NE(html.find("Most likely missing effect: friction"), std::string::npos);
  EXPECT_NE(html.find("indistinguishable with this data; youngs_modulus 9.8e+04 Pa with air_drag, 1.31e+05 Pa with "
                      "mass_damping: these data cannot tell which"),
            std::string::npos);
  EXPECT_EQ(html.find("with friction"), std::string::npos);  // another pair's values stay with it
  EXPECT_NE(html.find("a grid of half the cell size, grid.cell_size 0.025 m"), std::string::npos);
  EXPECT_NE(html.find("not fitted: the fit failed: &lt;&amp;&gt;"), std::string::npos);
  EXPECT_NE(html.find("camera cam, frame 12, t = 0.6 s"), std::string::npos);
  for (const char* text : {"time [s]", "RMS residual [mm]", "held-out frames", ">contact<", "residual [mm]", "no observed point"})
    EXPECT_NE(html.find(text), std::string::npos) << text;
  // The sections in their order.
  size_t previous = 0;
  for (const char* heading : {"<h2>Candidates", "<h2>Fits", "<h2>Residual over time", "<h2>Residual images", "<h2>Residual on the rest shape", "<h2>Parameters"}) {
    const size_t at = html.find(heading);
    ASSERT_NE(at, std::string::npos) << heading;
    EXPECT_GT(at, previous) << heading;
    previous = at;
  }
  // The images reach both saturated ends of the diverging map, and show missing pixels in grey.
  const size_t images = html.find("<h2>Residual images"), rest = html.find("<h2>Residual on the rest shape");
  const std::string image_html = html.substr(images, rest - images);
  EXPECT_NE(image_html.find("fill=\"#b2182b\""), std::string::npos);
  EXPECT_NE(image_html.find("fill=\"#2166ac\""), std::string::npos);
  EXPECT_NE(image_html.find("fill=\"#d0d0d0\""), std::string::npos);
  // The passing candidate's row is highlighted.
  EXPECT_EQ(count_of(html, "<tr class=\"pass\">"), 1u);
  // The fits: the base's two starts converged, friction's one of two; air drag has no per-start
  // record and no row. Friction's starts are drawn with the base's.
  const size_t fits = html.find("<h2>Fits"), over_time = html.find("<h2>Residual over time");
  const std::string fits_html = html.substr(fits, over_time - fits);
  EXPECT_NE(fits_html.find("<tr><td>base</td><td class=\"num\">2 of 2</td><td class=\"num\">2\u20135</td>"),
            std::string::npos)
      << fits_html;
  EXPECT_NE(fits_html.find("<tr class=\"unconverged\"><td>friction</td><td class=\"num\">1 of 2</td>"), std::string::npos);
  EXPECT_NE(fits_html.find("1 \u00d7 iteration limit"), std::string::npos);
  EXPECT_EQ(fits_html.find("air_drag"), std::string::npos);
  EXPECT_NE(fits_html.find("the cause's starts (friction)"), std::string::npos);
}

// `ssc residuals` reports one model: no "after" column, in the images or on the rest shape.
TEST(ReportHtml, OneModelHasNoEmptyAfterColumn) {
  json report = synthetic_report();
  report["rest_shape"].erase("after_mm");
  for (json& image : report["residual_images"]) image.erase("after_mm");
  const std::string html = render_report_html(report);
  EXPECT_EQ(count_of(html, "class=\"rest-shape\""), 1u);
  EXPECT_EQ(count_of(html, "class=\"residual-image\""), 2u);
  EXPECT_EQ(count_of(html, ">after</div>"), 0u);
}

// The gain chart's name column fits the longest name in bold: it starts inside the chart.
TEST(ReportHtml, TheWinningLabelIsNotCutAtTheLeft) {
  json report = synthetic_report();
  report["candidates"][0]["name"] = "heterogeneous_stiffness";
  const std::string html = render_report_html(report);
  const std::string label = " font-weight=\"bold\">heterogeneous_stiffness</text>";
  const size_t at = html.find(label);
  ASSERT_NE(at, std::string::npos);
  const size_t x = html.rfind("<text x=\"", at);
  ASSERT_NE(x, std::string::npos);
  const double right = std::stod(html.substr(x + 9));
  EXPECT_GE(right, 8.5 * 23) << "the right-aligned name ends at x = " << right;
}

TEST(ReportHtml, MissingKeysNullsAndNanDoNotThrow) {
  std::string html;
  ASSERT_NO_THROW(html = render_report_html(json{{"title", "x"}}));
  EXPECT_NE(html.find("<h1>x</h1>"), std::string::npos);
  EXPECT_EQ(count_of(html, "<svg"), 0u);
  EXPECT_EQ(count_of(html, "<h2>"), 0u);

  const double nan = std::nan("");
  const json odd = {
      {"title", nullptr},
      {"cause", 3},
      {"summary_lines", "not a list"},
      {"provenance", {{"scene", nullptr}, {"date", nan}}},
      {"candidates", {json::object(), nullptr, {{"gain", nan}, {"gain_low", nullptr}, {"passes", "yes"}, {"warnings", "one"}}}},
      {"confounded", {json::array(), nullptr, {"a"}, {"a", "b", "c"}}},
      {"parameters", {{"units", nullptr}, {"base", {{"k", nullptr}}}, {"winner", json::array()}}},
      {"residual_vs_time", {{"time", json::array()}, {"before_mm", {nullptr, nan}}, {"after_mm", nullptr}, {"heldout_from", nan},
                            {"contact_times", {nullptr}}}},
      {"residual_images", {{{"width", 0}}, {{"width", 2}, {"height", 2}, {"before_mm", {nullptr, 1.0}}}, {{"width", 1e9}, {"height", 1e9}},
                           {{"width", 1.5}, {"height", 2}}, nullptr}},
      {"rest_shape", {{"points", {{1, 2}, nullptr, {0, 0, 0}, {nan, 0, 0}}}, {"before_mm", nullptr}, {"after_mm", {nan}}}},
  };
  ASSERT_NO_THROW(html = render_report_html(odd));
  EXPECT_FALSE(std::regex_search(html, std::regex(R"(\b(nan|inf)\b)", std::regex::icase))) << "NaN must be shown as a dash, never written";
  for (const json& data : {json(nullptr), json::array(), json::object(), json{{"title", "t"}, {"residual_images", json::array()}}})
    EXPECT_NO_THROW(render_report_html(data)) << data.dump();
}

// ---- the page in headless Chromium ---------------------------------------------------------

std::string find_chromium() {
  if (access("/usr/bin/chromium", X_OK) == 0) return "/usr/bin/chromium";
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path ? path : "");
  for (std::string dir; std::getline(dirs, dir, ':');)
    for (const char* name : {"chromium", "chromium-browser"}) {
      const fs::path candidate = fs::path(dir.empty() ? "." : dir) / name;
      if (access(candidate.c_str(), X_OK) == 0) return candidate.string();
    }
  return "";
}

// Runs headless Chromium on the page with the given options; stdout and stderr go to files.
// Its own profile folder, so that it never joins a browser already running.
int run_chromium(const std::string& chromium, const std::string& options, const fs::path& page, const fs::path& dir,
                 const std::string& name) {
  const std::string command = fmt::format(
      "timeout 60 '{}' --headless --no-sandbox --disable-gpu --disable-dev-shm-usage --no-first-run --hide-scrollbars "
      "--user-data-dir='{}' --enable-logging=stderr --v=0 --virtual-time-budget=5000 {} 'file://{}' > '{}' 2> '{}'",
      chromium, (dir / ("profile-" + name)).string(), options, page.string(), (dir / (name + ".out")).string(),
      (dir / (name + ".err")).string());
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// Lines of Chromium's log that report a problem with the page. The page has no scripts, so
// any console message (Chromium writes them as "CONSOLE", without their level) means trouble.
std::vector<std::string> page_complaints(const std::string& log) {
  std::vector<std::string> lines;
  std::stringstream in(log);
  for (std::string line; std::getline(in, line);)
    if (line.find("Uncaught") != std::string::npos || line.find("CONSOLE") != std::string::npos) lines.push_back(line);
  return lines;
}

struct RgbaImage {
  int width = 0, height = 0;
  std::vector<std::uint8_t> pixels;  // RGBA, row-major
  std::string error;
};

// libpng's simplified API keeps its setjmp inside libpng: nothing here can be skipped by a longjmp.
RgbaImage read_png(const fs::path& path) {
  RgbaImage out;
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&image, path.c_str())) {
    out.error = image.message;
    return out;
  }
  image.format = PNG_FORMAT_RGBA;
  out.pixels.resize(PNG_IMAGE_SIZE(image));
  if (!png_image_finish_read(&image, nullptr, out.pixels.data(), 0, nullptr)) {
    out.error = image.message;
    png_image_free(&image);
    out.pixels.clear();
    return out;
  }
  out.width = int(image.width), out.height = int(image.height);
  return out;
}

TEST(ReportHtml, ChromiumDrawsThePage) {
  const std::string chromium = find_chromium();
  if (chromium.empty()) GTEST_SKIP() << "no Chromium (/usr/bin/chromium, or chromium / chromium-browser on PATH); tools/setup-build installs it";
  const fs::path dir = fs::temp_directory_path() / fmt::format("ssc-report-html-{}", getpid());
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path page = dir / "report.html", shot = dir / "shot.png";
  write_report_html(page.string(), synthetic_report());
  const std::string html = read_text(page);
  ASSERT_EQ(count_of(html, "<svg"), kExpectedSvgs);
  for (const auto& entry : fs::directory_iterator(dir)) EXPECT_EQ(entry.path().filename(), "report.html") << "a temp file was left behind";

  const auto start = std::chrono::steady_clock::now();
  ASSERT_EQ(run_chromium(chromium, fmt::format("--window-size=1200,3000 --screenshot='{}'", shot.string()), page, dir, "screenshot"), 0)
      << read_text(dir / "screenshot.err");
  ASSERT_EQ(run_chromium(chromium, "--dump-dom", page, dir, "dom"), 0) << read_text(dir / "dom.err");
  std::cout << fmt::format("[ info     ] two Chromium runs took {:.1f} s\n",
                           std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());

  for (const char* run : {"screenshot", "dom"})
    for (const std::string& line : page_complaints(read_text(dir / (std::string(run) + ".err")))) ADD_FAILURE() << run << ": " << line;
  // Every figure made it into the rendered document.
  EXPECT_EQ(count_of(read_text(dir / "dom.out"), "<svg"), kExpectedSvgs);

  const RgbaImage image = read_png(shot);
  ASSERT_TRUE(image.error.empty()) << shot << ": " << image.error;
  ASSERT_EQ(image.width, 1200);
  ASSERT_EQ(image.height, 3000);
  std::unordered_map<std::uint32_t, size_t> colour_counts;
  size_t strong_red = 0, strong_blue = 0;
  auto near = [](const std::uint8_t* p, int r, int g, int b) { return std::hypot(p[0] - r, p[1] - g, p[2] - b) < 40; };
  for (size_t i = 0; i < image.pixels.size(); i += 4) {
    const std::uint8_t* p = &image.pixels[i];
    ++colour_counts[(std::uint32_t(p[0]) << 16) | (std::uint32_t(p[1]) << 8) | p[2]];
    strong_red += near(p, 178, 24, 43);
    strong_blue += near(p, 33, 102, 172);
  }
  size_t most_common = 0;
  for (const auto& [colour, count] : colour_counts) most_common = std::max(most_common, count);
  const double total = double(image.width) * image.height;
  EXPECT_GT(1 - most_common / total, 0.02) << "the page looks blank";
  // Pixels at the saturated ends of the colour map: the colour bars and the rest-shape points
  // hold about 500 to 700 of each (measured without the images); the first before image's
  // discs (about 80 pixels each, drawn 8 x 8 px) add about 5000 more.
  EXPECT_GT(strong_red, 4000u) << "the positive discs of the residual images were not drawn";
  EXPECT_GT(strong_blue, 4000u) << "the negative discs of the residual images were not drawn";
  std::cout << fmt::format("[ info     ] screenshot {}: {:.1f} % of pixels off the background, {} strongly red, {} strongly blue\n",
                           shot.string(), 100 * (1 - most_common / total), strong_red, strong_blue);
  if (!HasFailure()) fs::remove_all(dir);  // a failed test keeps its folder to look at
}

}  // namespace
}  // namespace ssc
