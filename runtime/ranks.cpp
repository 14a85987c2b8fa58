// The ranks of one run (see ranks.h).
#include "runtime/ranks.h"

#include <unistd.h>

#include <cstdlib>
#include <stdexcept>

#ifdef SSC_WITH_MPI
#include <mpi.h>
#endif

namespace ssc::ranks {
namespace {

struct World {
  bool mpi = false;
  int rank = 0, count = 1, local_rank = 0, local_count = 1;
#ifdef SSC_WITH_MPI
  MPI_Comm comm = MPI_COMM_NULL;
#endif
};
World world;

// The rank count a launcher announced in the environment (1 without one).
int launched_ranks() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE", "MPI_LOCALNRANKS"})
    if (const char* v = std::getenv(name); v && *v) return std::max(1, std::atoi(v));
  return std::getenv("PMIX_RANK") ? 2 : 1;  // PMIx without a size: a launcher, count unknown
}

}  // namespace

void start(int* argc, char*** argv) {
  if (launched_ranks() <= 1) return;
#ifdef SSC_WITH_MPI
  int provided = 0;
  if (MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS)
    throw std::runtime_error("MPI_Init_thread failed");
  world.mpi = true;
  MPI_Comm_dup(MPI_COMM_WORLD, &world.comm);
  MPI_Comm_rank(world.comm, &world.rank);
  MPI_Comm_size(world.comm, &world.count);
  MPI_Comm local;
  MPI_Comm_split_type(world.comm, MPI_COMM_TYPE_SHARED, world.rank, MPI_INFO_NULL, &local);
  MPI_Comm_rank(local, &world.local_rank);
  MPI_Comm_size(local, &world.local_count);
  MPI_Comm_free(&local);
#else
  (void)argc;
  (void)argv;
  throw std::runtime_error(
      "this ssc was built without MPI, so it cannot share a run between the ranks mpirun started; install "
      "OpenMPI's development files (Debian: libopenmpi-dev) and build again, or run ssc without mpirun");
#endif
}

void finish() {
#ifdef SSC_WITH_MPI
  if (!world.mpi) return;
  MPI_Comm_free(&world.comm);
  MPI_Finalize();
  world.mpi = false;
#endif
}

int rank() { return world.rank; }
int count() { return world.count; }
int local_rank() { return world.local_rank; }
int local_count() { return world.local_count; }

std::string host() {
  char name[256] = {};
  if (gethostname(name, sizeof name - 1) != 0) return "unknown host";
  return name;
}

std::vector<std::string> all_gather(const std::string& mine) {
  if (world.count == 1) return {mine};
#ifdef SSC_WITH_MPI
  const long long size = (long long)mine.size();
  std::vector<long long> sizes(size_t(world.count));
  MPI_Allgather(&size, 1, MPI_LONG_LONG, sizes.data(), 1, MPI_LONG_LONG, world.comm);
  std::vector<int> counts(size_t(world.count)), offsets(size_t(world.count));
  long long total = 0;
  for (int r = 0; r < world.count; ++r) {
    if (sizes[size_t(r)] > (1LL << 30)) throw std::runtime_error("a rank's share of a batch's results exceeds 1 GiB");
    counts[size_t(r)] = int(sizes[size_t(r)]);
    offsets[size_t(r)] = int(total);
    total += sizes[size_t(r)];
  }
  if (total > (1LL << 31) - 1) throw std::runtime_error("a batch's results exceed 2 GiB");
  std::string all(size_t(total), '\0');
  MPI_Allgatherv(mine.data(), counts[size_t(world.rank)], MPI_BYTE, all.data(), counts.data(), offsets.data(), MPI_BYTE,
                 world.comm);
  std::vector<std::string> out;
  for (int r = 0; r < world.count; ++r) out.push_back(all.substr(size_t(offsets[size_t(r)]), size_t(counts[size_t(r)])));
  return out;
#else
  throw std::logic_error("all_gather over several ranks without MPI");
#endif
}

}  // namespace ssc::ranks
