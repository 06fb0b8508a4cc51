/* The paper's indentation of silicon by a surface pressure (Ma et al. 2005,
 * section 4, second example), on as many ranks as it is started with.
 *
 * Half model (symmetry roller at x = 0) of a 40 um x 40 um silicon block
 * (E = 170 GPa, nu = 0.18, rho = 2330 kg/m^3, plane strain, thickness
 * 1 um), 1 um cells, 2x2 particles per cell, bottom fixed. A pressure
 * p0 = 2 GPa acts on the top surface for 0 <= x <= a = 5 um, ramped over
 * 1500 increments of 20 ps and then held. Optional nested levels refine the
 * region under the load (each level a quarter of the next coarser in area).
 *
 *   pressure_indentation [--steps N] [--levels L] [--patches PXxPY] [--out DIR]
 *
 * Writes DIR/indentation.csv (time series), DIR/indentation_*.h5 and
 * DIR/indentation.xdmf (particle fields, open the .xdmf in ParaView) and
 * DIR/axis_stress.csv: the stresses of the particles near the symmetry axis
 * at the end, beside the closed-form strip load on a half-space. */
#include <math.h>
#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "gimlet.h"

static int rank_ = 0;

#define CHECK(call)                                                      \
  do {                                                                   \
    if ((call) != GIMLET_OK) {                                           \
      char m_[512];                                                      \
      gimlet_last_error(m_, sizeof m_, NULL);                            \
      fprintf(stderr, "rank %d: %s failed: %s\n", rank_, #call, m_);     \
      MPI_Abort(MPI_COMM_WORLD, 1);                                      \
    }                                                                    \
  } while (0)

int main(int argc, char **argv) {
  MPI_Init(&argc, &argv);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  int size;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  int steps = 2000, levels = 1, px = 2, py = 1;
  const char *out = "results";
  for (int i = 1; i + 1 < argc; i += 2) {
    if (!strcmp(argv[i], "--steps")) steps = atoi(argv[i + 1]);
    else if (!strcmp(argv[i], "--levels")) levels = atoi(argv[i + 1]);
    else if (!strcmp(argv[i], "--out")) out = argv[i + 1];
    else if (!strcmp(argv[i], "--patches")) sscanf(argv[i + 1], "%dx%d", &px, &py);
  }
  const double um = 1e-6, L = 40 * um, h = 1 * um, a = 5 * um, p0 = 2e9, dt = 20e-12;
  GimletSim *sim = NULL;
  CHECK(gimlet_create(MPI_COMM_WORLD, 0, 0, L, L, h, &sim));
  /* The paper's weights and transfer (uGIMP, FLIP), which this scene's
   * figures were measured with; the library's defaults are cpGIMP, APIC. */
  CHECK(gimlet_set_shape(sim, GIMLET_SHAPE_UGIMP));
  CHECK(gimlet_set_transfer(sim, GIMLET_TRANSFER_FLIP));
  CHECK(gimlet_set_thickness(sim, 1 * um));
  /* Level l covers [0, L/2^l] x [L - L/2^l, L]: a quarter of the next
   * coarser level's area, touching the symmetry plane and the top. */
  for (int l = 1; l < levels; l++) {
    double w = L / (1 << l);
    double box[4] = {0, L - w, w, L};
    CHECK(gimlet_add_level(sim, box, 1));
  }
  /* Every level is 40 of its cells wide; a refined level computes on its
   * box plus the 4-cell ghost ring on the sides away from the domain edge. */
  for (int l = 0; l < levels; l++) {
    int nb = 40 + (l ? 4 : 0);
    CHECK(gimlet_set_patch_size(sim, l, (nb + px - 1) / px, (nb + py - 1) / py));
  }
  int si;
  CHECK(gimlet_add_material_linear_elastic(sim, 170e9, 0.18, 2330.0, &si));
  CHECK(gimlet_set_face_bc(sim, GIMLET_FACE_LEFT, GIMLET_BC_ROLLER));
  CHECK(gimlet_set_face_bc(sim, GIMLET_FACE_BOTTOM, GIMLET_BC_FIXED));
  CHECK(gimlet_fill_rectangle(sim, 0, 0, L, L, 2, si, 2330.0, 0, 0, NULL));
  int64_t loaded = 0;
  CHECK(gimlet_apply_traction(sim, GIMLET_FACE_TOP, L, 0, a, 0, -p0, &loaded));
  CHECK(gimlet_set_load_ramp(sim, 1500 * dt));

  char path[1024];
  snprintf(path, sizeof path, "%s/indentation.csv", out);
  CHECK(gimlet_output_open(sim, out, "indentation"));
  CHECK(gimlet_csv_open(sim, path));
  int64_t n = 0;
  CHECK(gimlet_particle_count(sim, NULL, &n));
  if (rank_ == 0)
    printf("pressure indentation: %d rank(s), %d level(s), %lld particles, %lld loaded, %d steps of %g s\n", size,
           levels, (long long)n, (long long)loaded, steps, dt);
  double wall = MPI_Wtime();
  for (int s = 1; s <= steps; s++) {
    CHECK(gimlet_step(sim, dt, NULL, NULL));
    if (s % 100 == 0) CHECK(gimlet_csv_append(sim));
    if (s % 500 == 0 || s == steps) {
      CHECK(gimlet_write_output(sim));
      double ke, se;
      CHECK(gimlet_diagnostics(sim, &ke, &se, NULL, NULL, NULL));
      if (rank_ == 0) printf("  step %5d: kinetic %.4e J/m, strain %.4e J/m\n", s, ke / 1e-6, se / 1e-6);
    }
  }
  wall = MPI_Wtime() - wall;

  /* Stresses near the axis (x < h) against the half-space strip load. */
  int64_t m = 0;
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_POSITION, NULL, 0, &m));
  double *x = malloc(16 * (m + 1)), *sg = malloc(32 * (m + 1));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_POSITION, x, m, &m));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_STRESS, sg, m, &m));
  int k = 0;
  double *rows = malloc(sizeof(double) * 3 * (m + 1));
  for (int64_t i = 0; i < m; i++)
    if (x[2 * i] < 0.5 * h) {
      rows[3 * k] = L - x[2 * i + 1];
      rows[3 * k + 1] = -sg[4 * i + 1]; /* compression positive */
      rows[3 * k + 2] = -sg[4 * i];
      k++;
    }
  int *counts = malloc(sizeof(int) * size), *displ = malloc(sizeof(int) * size), tot = 0, mine = 3 * k;
  MPI_Gather(&mine, 1, MPI_INT, counts, 1, MPI_INT, 0, MPI_COMM_WORLD);
  if (rank_ == 0)
    for (int r = 0; r < size; r++) { displ[r] = tot; tot += counts[r]; }
  double *all = malloc(sizeof(double) * (tot + 3));
  MPI_Gatherv(rows, mine, MPI_DOUBLE, all, counts, displ, MPI_DOUBLE, 0, MPI_COMM_WORLD);
  if (rank_ == 0) {
    snprintf(path, sizeof path, "%s/axis_stress.csv", out);
    FILE *f = fopen(path, "w");
    if (f) {
      fprintf(f, "depth_m,sigma_z_gimp_pa,sigma_x_gimp_pa,sigma_z_halfspace_pa,sigma_x_halfspace_pa\n");
      for (int i = 0; i < tot / 3; i++) {
        double z = all[3 * i], t1 = atan2(a, z);
        double sz = p0 / M_PI * (2 * t1 + sin(2 * t1)), sx = p0 / M_PI * (2 * t1 - sin(2 * t1));
        fprintf(f, "%.6e,%.6e,%.6e,%.6e,%.6e\n", z, all[3 * i + 1], all[3 * i + 2], sz, sx);
      }
      fclose(f);
    }
    printf("done in %.2f s (%.3e particle-steps/s); wrote %s/indentation.csv, %s/indentation.xdmf, %s\n", wall,
           (double)n * steps / wall, out, out, path);
  }
  free(x); free(sg); free(rows); free(counts); free(displ); free(all);
  CHECK(gimlet_destroy(&sim));
  MPI_Finalize();
  return 0;
}
