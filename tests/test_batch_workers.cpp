// Sharing a batch among workers (models/sim/batch_workers.h), the device names
// (models/sim/compute_device.h) and the records the ranks send each other
// (models/io/byte_record.h, models/optim/batch_evaluation.h), on one process; and that a
// point's values do not depend on the batch it runs in.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "models/cost/surface_constraint.h"
#include "models/io/byte_record.h"
#include "models/optim/batch_evaluation.h"
#include "models/sim/batch_workers.h"
#include "models/sim/compute_device.h"
#include "runtime/cuda_runtime.h"
#include "runtime/errors.h"
#include "tests/ssc_binary.h"

namespace ssc {
namespace {

TEST(ByteRecord, ValuesStringsAndVectorsComeBackAsWritten) {
  ByteWriter w;
  w.put(3.25);
  w.put_string("a\0b");
  w.put_string(std::string("x\0y", 3));
  w.put_vector(std::vector<int>{4, -5, 6});
  w.put('z');
  ByteReader r(w.bytes());
  EXPECT_EQ(r.get<double>(), 3.25);
  EXPECT_EQ(r.get_string(), "a");
  EXPECT_EQ(r.get_string(), std::string("x\0y", 3));
  EXPECT_EQ(r.get_vector<int>(), (std::vector<int>{4, -5, 6}));
  EXPECT_EQ(r.get<char>(), 'z');
  EXPECT_TRUE(r.at_end());
  EXPECT_THROW(r.get<int>(), std::runtime_error);
  const std::string cut = w.bytes().substr(0, 12);
  ByteReader short_reader(cut);
  short_reader.get<double>();
  EXPECT_THROW(short_reader.get_string(), std::runtime_error);
}

TEST(BatchWorkers, PointEvaluationsComeBackBitForBit) {
  PointEvaluation e;
  e.ok = false;
  e.failure = "the Newmark solve did not converge";
  e.value.cost = 0.1 + 1e-17;
  e.value.frames = {{1.5, 10, 7}, {2.5, 12, 11}};
  e.value.gradient.youngs_modulus = -3.0e-9;
  e.value.gradient.gravity = Eigen::Vector3d(1, 2, 3);
  e.value.gradient.angular_velocity = Eigen::Vector3d(-1, 0.5, 1e-300);
  e.value.gradient.plane_normal = {Eigen::Vector3d(0, 0, 1)};
  e.value.gradient.plane_height = {0.25, -0.5};
  e.value.gradient.input["friction_mu"] = {0.125};
  e.value.gradient.input["drag"] = {1, 2};
  e.residuals.r = Eigen::VectorXd::LinSpaced(5, -1, 1);
  e.residuals.matched = {1, 0, 1, 1, 0};
  const PointEvaluation d = decode_point(encode_point(e));
  EXPECT_EQ(d.ok, e.ok);
  EXPECT_EQ(d.failure, e.failure);
  EXPECT_EQ(d.value.cost, e.value.cost);
  ASSERT_EQ(d.value.frames.size(), 2u);
  EXPECT_EQ(d.value.frames[1].cost, 2.5);
  EXPECT_EQ(d.value.frames[1].matched, 11);
  EXPECT_EQ(d.value.gradient.youngs_modulus, e.value.gradient.youngs_modulus);
  EXPECT_EQ(d.value.gradient.gravity, e.value.gradient.gravity);
  EXPECT_EQ(d.value.gradient.angular_velocity, e.value.gradient.angular_velocity);
  EXPECT_EQ(d.value.gradient.plane_normal, e.value.gradient.plane_normal);
  EXPECT_EQ(d.value.gradient.plane_height, e.value.gradient.plane_height);
  EXPECT_EQ(d.value.gradient.input, e.value.gradient.input);
  EXPECT_EQ(d.residuals.r, e.residuals.r);
  EXPECT_EQ(d.residuals.matched, e.residuals.matched);
  EXPECT_THROW(decode_point(encode_point(e) + "x"), std::runtime_error);
}

TEST(BatchWorkers, OneProcessOnTheCpuIsOneWorkerWithEveryItem) {
  const std::vector<BatchShare> shares = this_rank_shares(7, "cpu");
  ASSERT_EQ(shares.size(), 1u);
  EXPECT_EQ(shares[0].begin, 0);
  EXPECT_EQ(shares[0].end, 7);
  EXPECT_EQ(shares[0].device, "cpu");
  EXPECT_TRUE(shares[0].reports);
  // A named GPU is one worker too (whether or not this machine has it: nothing is started).
  const std::vector<BatchShare> one_gpu = this_rank_shares(5, "cuda:3");
  ASSERT_EQ(one_gpu.size(), 1u);
  EXPECT_EQ(one_gpu[0].device, "cuda:3");
  EXPECT_EQ(one_gpu[0].end, 5);
}

TEST(BatchWorkers, RunSharedKeepsItemOrderAndRethrowsWithBatchIndices) {
  const std::vector<std::string> out = run_shared(4, "cpu", [](const BatchShare& s) {
    std::vector<std::string> r;
    for (int i = s.begin; i < s.end; ++i) r.push_back(std::to_string(i * i));
    return r;
  });
  EXPECT_EQ(out, (std::vector<std::string>{"0", "1", "4", "9"}));
  EXPECT_THROW(run_shared(2, "cpu", [](const BatchShare&) { return std::vector<std::string>{"one"}; }),
               std::logic_error);
  EXPECT_THROW(run_shared(2, "cpu", [](const BatchShare&) -> std::vector<std::string> { throw InputError("bad"); }),
               InputError);
}

TEST(BatchWorkers, AFailedRankIsNamedAndItsErrorKeepsItsType) {
  BatchShare first{0, 2, "cpu", 0, true}, second{2, 5, "cpu", 0, false};
  const std::string ok = rank_outcome({first}, {{"a", "b"}}, {nullptr});
  std::exception_ptr boom;
  try {
    throw SimulationError("the Newmark solve did not converge", {1});
  } catch (...) {
    boom = std::current_exception();
  }
  const std::string failed = rank_outcome({second}, {{}}, {boom});
  EXPECT_EQ(merge_rank_outcomes({ok, rank_outcome({second}, {{"c", "d", "e"}}, {nullptr})}, 5),
            (std::vector<std::string>{"a", "b", "c", "d", "e"}));
  try {
    merge_rank_outcomes({ok, failed}, 5);
    FAIL() << "no error";
  } catch (const SimulationError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("rank 1 of 2 (host ", 0), 0u) << e.what();
    EXPECT_NE(std::string(e.what()).find("the Newmark solve did not converge"), std::string::npos);
    EXPECT_EQ(e.items, std::vector<int>{3});  // item 1 of the share that starts at 2
  }
  std::exception_ptr input;
  try {
    throw InputError("scene.json: object.mesh: no such file");
  } catch (...) {
    input = std::current_exception();
  }
  EXPECT_THROW(merge_rank_outcomes({rank_outcome({first}, {{}}, {input}), ok}, 4), InputError);
  EXPECT_THROW(merge_rank_outcomes({ok}, 3), std::logic_error);  // a count unlike the batch's
}

TEST(ComputeDevice, NamesAndTheirGpus) {
  EXPECT_FALSE(runs_on_gpu("cpu"));
  EXPECT_TRUE(runs_on_gpu("cuda"));
  EXPECT_TRUE(runs_on_gpu("cuda:1"));
  EXPECT_TRUE(device_gpus("cpu").empty());
  EXPECT_EQ(device_gpus("cuda:2"), std::vector<int>{2});
  EXPECT_EQ(gpu_device(5), "cuda:5");
  EXPECT_FALSE(device_gpus("cuda").empty());  // at least GPU 0, whose construction says why it is missing
  for (const char* bad : {"cuda:", "cuda:x", "cuda:-1", "gpu", "cuda:1a"})
    EXPECT_THROW(device_gpus(bad), InputError) << bad;
  EXPECT_EQ(describe_device("cpu"), "cpu");
}

// side_by_side on the CPU: every item runs, in order, on the device given, and the first
// failure is rethrown only after the others ran.
TEST(ComputeDevice, SideBySideRunsEveryItemBeforeItRethrows) {
  std::vector<std::string> ran(4);
  side_by_side(4, "cpu", [&](size_t k, const std::string& device) { ran[k] = device; });
  EXPECT_EQ(ran, std::vector<std::string>(4, "cpu"));
  std::vector<int> order;
  try {
    side_by_side(4, "cpu", [&](size_t k, const std::string&) {
      order.push_back(int(k));
      if (k == 1) throw InputError("item 1");
      if (k == 2) throw std::runtime_error("item 2");
    });
    ADD_FAILURE() << "item 1's error expected";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "item 1");
  }
  EXPECT_EQ(order, (std::vector<int>{0, 1, 2, 3}));
}

// What a split among GPUs and ranks relies on: a point evaluated in a batch gives the bits it
// gives alone (cost, gradient and residual vector), on the CPU and, where there is one, on the
// GPU. The catalogue's ball (4 steps), observed by ssc.
TEST(BatchEvaluation, APointsValuesDoNotDependOnTheBatchBesideIt) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("ssc-batch-evaluation-" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string scene = std::string(SSC_SOURCE_DIR) + "/tests/catalogue/fixtures/ball.json";
  ASSERT_EQ(std::system(("'" + ssc_binary_path() + "' observe '" + scene + "' --out '" + (dir / "obs").string() +
                         "' --device cpu --quiet").c_str()),
            0);
  const Problem problem = load_problem(scene, {}, (dir / "obs").string(), 0, {"youngs_modulus"});
  const SurfaceConstraintCost cost(problem.grid, problem.phi_max);
  const SurfaceResiduals residuals(cost, problem.frames);
  const PhysicalParameters base = PhysicalParameters::from_scene(problem.scene);
  const std::vector<std::string> names = {"youngs_modulus"};
  std::vector<Eigen::VectorXd> points;
  for (double E : {3000.0, 5000.0, 8000.0}) points.push_back(Eigen::VectorXd::Constant(1, E));
  std::vector<std::string> devices = {"cpu"};
  if (gpu_unavailable_reason().empty()) devices.push_back("cuda:0");
  for (const std::string& device : devices) {
    BatchSimulations together(problem, device);
    const std::vector<PointEvaluation> all = evaluate_batch(together, cost, base, names, points, true);
    const std::vector<PointEvaluation> all_r = evaluate_batch(together, cost, base, names, points, false, &residuals);
    for (size_t k = 0; k < points.size(); ++k) {
      BatchSimulations alone(problem, device);
      const PointEvaluation one = evaluate_batch(alone, cost, base, names, {points[k]}, true)[0];
      const PointEvaluation one_r = evaluate_batch(alone, cost, base, names, {points[k]}, false, &residuals)[0];
      ASSERT_TRUE(all[k].ok && one.ok) << device << ": " << all[k].failure << one.failure;
      EXPECT_GT(all[k].value.cost, 0.0) << device;
      EXPECT_EQ(all[k].value.cost, one.value.cost) << device << ", point " << k;
      EXPECT_EQ(all[k].value.gradient.youngs_modulus, one.value.gradient.youngs_modulus) << device << ", point " << k;
      EXPECT_EQ(all_r[k].residuals.r, one_r.residuals.r) << device << ", point " << k;
    }
    EXPECT_NE(all[0].value.cost, all[2].value.cost) << "the points differ, so must their costs";
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace ssc
