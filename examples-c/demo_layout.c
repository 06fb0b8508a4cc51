/* The main job, first slice: creates a simulation on MPI_COMM_WORLD, lays
 * out the paper's 3-level wedge-indentation hierarchy (half model of a
 * 60 um x 40 um aluminium block, cells of 500/250/125 nm, 4 patches per
 * level), fills the block with 2x2 particles per cell of the level that
 * owns each cell, and prints the layout and the particle counts. */
#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>
#include "gimlet.h"

#define CHECK(call)                                                         \
  do {                                                                      \
    if ((call) != GIMLET_OK) {                                              \
      char msg_[512];                                                       \
      gimlet_last_error(msg_, sizeof msg_, NULL);                           \
      fprintf(stderr, "%s failed: %s\n", #call, msg_);                      \
      MPI_Abort(MPI_COMM_WORLD, 1);                                         \
    }                                                                       \
  } while (0)

int main(int argc, char **argv) {
  MPI_Init(&argc, &argv);
  int rank, size;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  const double um = 1e-6;
  GimletSim *sim = NULL;
  /* Half model: x in [0, 30 um] (symmetry plane at x = 0), y in [0, 40 um]. */
  CHECK(gimlet_create(MPI_COMM_WORLD, 0.0, 0.0, 30 * um, 40 * um, 0.5 * um, &sim));
  CHECK(gimlet_set_thickness(sim, 1 * um));
  double l1[4] = {0.0, 30 * um, 10 * um, 40 * um};
  double l2[4] = {0.0, 35 * um, 5 * um, 40 * um};
  CHECK(gimlet_add_level(sim, l1, 1));
  CHECK(gimlet_add_level(sim, l2, 1));
  CHECK(gimlet_set_patch_size(sim, 0, 30, 40));
  CHECK(gimlet_set_patch_size(sim, 1, 20, 10));
  CHECK(gimlet_set_patch_size(sim, 2, 20, 20));
  int al = -1;
  CHECK(gimlet_add_material_linear_elastic(sim, 70e9, 0.33, 2700.0, &al));
  int64_t added = 0;
  CHECK(gimlet_fill_rectangle(sim, 0.0, 0.0, 30 * um, 40 * um, 2, al, 2700.0, 0.0, 0.0, &added));

  int nl = 0;
  CHECK(gimlet_num_levels(sim, &nl));
  if (rank == 0) {
    int ma, mi, pa;
    gimlet_version(&ma, &mi, &pa);
    printf("gimlet %d.%d.%d on %d rank(s): %d levels\n", ma, mi, pa, size, nl);
  }
  for (int l = 0; l < nl; l++) {
    double h; int nb, np;
    CHECK(gimlet_level_info(sim, l, &h, &nb, &np));
    int64_t count = 0;
    CHECK(gimlet_level_patches(sim, l, NULL, NULL, 0, &count));
    int64_t *cells = malloc(sizeof(int64_t) * 4 * (size_t)count);
    int *owner = malloc(sizeof(int) * (size_t)count);
    CHECK(gimlet_level_patches(sim, l, cells, owner, count, &count));
    int64_t nloc = 0, nlev = 0;
    CHECK(gimlet_level_particle_count(sim, l, &nloc));
    MPI_Allreduce(&nloc, &nlev, 1, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);
    if (rank == 0) {
      printf("level %d: h = %.4g um, %d box(es), %d patch(es), %lld particles\n", l, h / um, nb, np,
             (long long)nlev);
      for (int64_t k = 0; k < count; k++)
        printf("  patch %lld: cells [%lld,%lld)x[%lld,%lld) on rank %d\n", (long long)k,
               (long long)cells[4 * k], (long long)cells[4 * k + 2], (long long)cells[4 * k + 1],
               (long long)cells[4 * k + 3], owner[k]);
    }
    free(cells);
    free(owner);
  }
  int64_t local = 0, global = 0;
  CHECK(gimlet_particle_count(sim, &local, &global));
  for (int r = 0; r < size; r++) {
    if (r == rank) printf("rank %d: %lld local particles\n", rank, (long long)local);
    fflush(stdout);
    MPI_Barrier(MPI_COMM_WORLD);
  }
  if (rank == 0) printf("global particle count: %lld (inserted %lld)\n", (long long)global, (long long)added);
  CHECK(gimlet_destroy(&sim));
  MPI_Finalize();
  return global == added ? 0 : 1;
}
