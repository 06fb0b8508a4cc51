/* Without MPI_Init, creation fails with GIMLET_ERR_INVALID_STATE and a
 * message saying MPI is not initialized; the process does not abort. Then,
 * after MPI_Finalize, creation fails the same way. */
#include <mpi.h>
#include "check.h"

int main(int argc, char **argv) {
  GimletSim *sim = NULL;
  EXPECT_STATUS(gimlet_create(MPI_COMM_WORLD, 0, 0, 1, 1, 0.1, &sim), GIMLET_ERR_INVALID_STATE, "MPI is not initialized");
  EXPECT_STATUS(gimlet_create_f(0, 0, 0, 1, 1, 0.1, &sim), GIMLET_ERR_INVALID_STATE, "MPI is not initialized");
  EXPECT_TRUE(sim == NULL);
  EXPECT_OK(gimlet_destroy(&sim));
  int ma = -1;
  EXPECT_OK(gimlet_version(&ma, NULL, NULL));
  EXPECT_TRUE(ma == GIMLET_VERSION_MAJOR);
  MPI_Init(&argc, &argv);
  EXPECT_OK(gimlet_create(MPI_COMM_WORLD, 0, 0, 1, 1, 0.1, &sim));
  EXPECT_OK(gimlet_destroy(&sim));
  MPI_Finalize();
  EXPECT_STATUS(gimlet_create(MPI_COMM_WORLD, 0, 0, 1, 1, 0.1, &sim), GIMLET_ERR_INVALID_STATE, "finalized");
  printf("test_no_mpi: %d checks, %d failure(s)\n", g_checks, g_failures);
  return g_failures == 0 ? 0 : 1;
}
