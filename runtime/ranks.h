// The processes of one run: this one alone, or the ranks an MPI launcher started (`mpirun -n K
// ssc ...`). Every rank runs the same command on the same inputs and takes its share of each
// batch's items (models/sim/batch_workers.h); all_gather gives every rank every share, so the
// ranks go on in step and rank 0 writes the output. MPI is started only where a launcher set its
// environment (OMPI_COMM_WORLD_SIZE, PMI_SIZE, PMIX_RANK); a plain run never touches it. A build
// without MPI (SSC_WITH_MPI unset) refuses a launch of several ranks at start().
#pragma once
#include <string>
#include <vector>

namespace ssc::ranks {

// MPI_Init_thread under a launcher; throws std::runtime_error if that fails or MPI is not built in.
void start(int* argc, char*** argv);
// MPI_Finalize, where start() initialised MPI.
void finish();

int rank();         // 0 where there is one
int count();        // 1 where there is one
int local_rank();   // among the ranks on this host
int local_count();  // ranks on this host
std::string host();

// Every rank's bytes in rank order, on every rank (MPI_Allgatherv); {mine} where there is one.
std::vector<std::string> all_gather(const std::string& mine);

}  // namespace ssc::ranks
