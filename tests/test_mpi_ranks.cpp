// `mpirun -n 2 ssc ...` against one process (runtime/ranks.h, models/sim/batch_workers.h): on
// the CalculiX drop data, on the CPU, two ranks give the one process's result bit for bit, only
// rank 0 writes the output, and an error names the failed rank.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "tests/cli_test_folder.h"

namespace ssc {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

const std::string kCase = std::string(SSC_TEST_DATA_DIR) + "/calculix_drops/clean";

class MpiRanks : public CliTestFolder {
 protected:
  MpiRanks() : CliTestFolder("ssc-mpi-") {}
  void SetUp() override {
    CliTestFolder::SetUp();
#ifndef SSC_WITH_MPI
    GTEST_SKIP() << "ssc was built without MPI (no OpenMPI development files at configure time)";
#endif
    ASSERT_EQ(std::system("command -v mpirun > /dev/null"), 0)
        << "ssc was built with MPI but mpirun is missing (Debian: openmpi-bin)";
  }
  // ssc under mpirun with two ranks of one thread each (root allowed: CI runs as root).
  int run_ranks(const std::string& args, std::string* out, std::string* err) {
    return run_with_prefix(kMpirun + " -n 2 -x OMP_NUM_THREADS=1", args, out, err);
  }
  // The command as one process (--out one) and on two ranks (--out two), both succeeding; rank
  // 1's scratch folder (in a TMPDIR of the test's own) is gone afterwards, and no hidden folder
  // or lock is left beside the outputs.
  void run_one_and_two(const std::string& args) {
    std::string out, err;
    ASSERT_EQ(run(args + " --out '" + (dir_ / "one").string() + "'", &out, &err), 0) << out << err;
    fs::create_directories(dir_ / "tmp");
    ASSERT_EQ(run_with_prefix(kMpirun + " -n 2 -x OMP_NUM_THREADS=1 -x TMPDIR='" + (dir_ / "tmp").string() + "'",
                              args + " --out '" + (dir_ / "two").string() + "'", &out, &err),
              0)
        << out << err;
    EXPECT_TRUE(fs::is_empty(dir_ / "tmp")) << "rank 1 left its scratch folder";
    for (const auto& e : fs::directory_iterator(dir_))
      EXPECT_NE(e.path().filename().string()[0], '.') << "left beside the outputs: " << e.path();
  }
  const std::string kMpirun =
      "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1 timeout 300 mpirun";
};

// Everything but what a run's time and place change.
json without_times(json j) {
  for (const char* key : {"wall_seconds", "device"}) j.erase(key);
  return j;
}

TEST_F(MpiRanks, ReconstructOnTwoRanksGivesTheOneProcessResult) {
  run_one_and_two("reconstruct '" + kCase + "/scene.json' --observations '" + kCase +
                  "/obs' --fit youngs_modulus --starts 2 --iterations 1 --optimizer lm --device cpu --quiet");
  const json one = read_json(dir_ / "one/result.json"), two = read_json(dir_ / "two/result.json");
  EXPECT_EQ(without_times(one), without_times(two));
  EXPECT_EQ(one.at("starts").size(), 2u);
  EXPECT_NE(two.at("device").get<std::string>().find("MPI rank 0 of 2"), std::string::npos) << two.at("device");
}

TEST_F(MpiRanks, SweepOnTwoRanksGivesTheOneProcessCsv) {
  run_one_and_two("sweep '" + kCase + "/scene.json' --observations '" + kCase +
                  "/obs' --param youngs_modulus=40000:60000:3 --device cpu --quiet");
  EXPECT_EQ(read_text(dir_ / "one/sweep.csv"), read_text(dir_ / "two/sweep.csv"));
}

TEST_F(MpiRanks, AnInputErrorEndsEveryRankWithOneMessage) {
  std::string out, err;
  const int code = run_ranks("reconstruct '" + (dir_ / "missing.json").string() + "' --observations '" + kCase +
                                 "/obs' --fit youngs_modulus --device cpu --out '" + (dir_ / "fit").string() + "'",
                             &out, &err);
  EXPECT_NE(code, 0);
  EXPECT_NE(err.find("missing.json"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir_ / "fit"));
}

// Rank 1 alone cannot make its scratch folder (its TMPDIR is a file): rank 0, already in the
// first batch, must not wait for it forever. Every rank ends with rank 1's error, named, and
// no output is written.
TEST_F(MpiRanks, ARankThatFailsAloneIsNamedAndEndsTheRun) {
  std::string out, err;
  std::ofstream(dir_ / "not-a-folder") << "x";
  const std::string args = "'" + binary_ + "' reconstruct '" + kCase + "/scene.json' --observations '" + kCase +
                           "/obs' --fit youngs_modulus --starts 2 --iterations 1 --optimizer lm --device cpu --out '" +
                           (dir_ / "fit").string() + "'";
  // mpirun's MPMD form: one rank with the usual environment, one with the broken TMPDIR.
  const int code = run_with_prefix(kMpirun + " -x OMP_NUM_THREADS=1 -n 1 " + args + " : -n 1 -x TMPDIR='" +
                                       (dir_ / "not-a-folder").string() + "'",
                                   "reconstruct '" + kCase + "/scene.json' --observations '" + kCase +
                                       "/obs' --fit youngs_modulus --starts 2 --iterations 1 --optimizer lm --device "
                                       "cpu --out '" + (dir_ / "fit").string() + "'",
                                   &out, &err);
  EXPECT_EQ(code, 2) << err;
  EXPECT_NE(err.find("ssc: error: rank 1 of 2 (host "), std::string::npos) << err;
  EXPECT_NE(err.find("TMPDIR"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(dir_ / "fit"));
  EXPECT_TRUE(leftovers().empty());
}

}  // namespace
}  // namespace ssc
