/* Speed against error of nested levels (issue "Nested levels with
 * subcycling"), on the paper's indentation of silicon by a surface
 * pressure (see pressure_indentation.c): 40 um x 40 um half model, 1 um
 * cells, pressure 2 GPa on x < 5 um of the top ramped over 1500 steps of
 * 20 ps; three levels, each a quarter of the next coarser in area, refined
 * under the loaded strip (0.25 um cells on [0, 10] x [30, 40] um).
 *
 * Runs, for STEPS coarse steps of 20 ps (default 300): the 3-level run,
 * its uniform-finest twin (0.25 um, steps of 5 ps), and uniform runs at
 * 0.5 um and 1 um. Prints wall and CPU times, computational cells and
 * particles of each, and the stress error over the finest region
 * [0, 10] x [30, 40] um: each run's relative L2 difference from the
 * uniform-finest run (its stress field interpolated bilinearly at the
 * run's particles), and the uniform-finest run's own error estimated from
 * the 0.5 um run (second order: |s_0.5 - s_0.25| / 3). The 3-level run's
 * error is at most its difference from the uniform-finest run plus that
 * estimate; the target is a wall time <= 30 % of the uniform-finest run
 * with that error within 2x of the uniform-finest error.
 *
 * Then prints the paper's cell-percentage table (fig. 6b) from actual
 * layouts of 1 to 5 nested levels of this kind: the cells of the levels'
 * own boxes (gimlet_level_boxes, checked against gimlet_level_patches),
 * the cells the levels compute on (boxes plus the 4-cell ghost ring of a
 * refined level) and the owned particles (gimlet_particle_count: the
 * coarser levels' bands of fine-sized particles included, copies not),
 * each as a percentage of a uniform grid at the finest cell size.
 *
 * Every level is tiled by 2 x 2 patches (balanced over the ranks by
 * particle count).
 *
 * Last, one JSON line (for `make bench`, scripts/bench.py) with each run's
 * wall and CPU time, particles, particle-steps (the sum over levels of the
 * level's particles at the start times the steps the level took) and
 * stress difference, the estimate, and the two target ratios.
 *
 *   mpiexec -n N levels_speed [STEPS] [--no-table]
 *
 * --no-table skips the cell-percentage table.
 */
#include <mpi.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "gimlet.h"

static int rank_ = 0;

#define CHECK(call)                                                      \
  do {                                                                   \
    int rc_ = (call);                                                    \
    if (rc_ != GIMLET_OK) {                                              \
      char m_[512];                                                      \
      gimlet_last_error(m_, sizeof m_, NULL);                            \
      fprintf(stderr, "rank %d: %s -> %d: %s\n", rank_, #call, rc_, m_); \
      MPI_Abort(MPI_COMM_WORLD, 2);                                      \
    }                                                                    \
  } while (0)

static const double um = 1e-6, L = 40 * 1e-6;

/* `levels` nested levels of the indentation layout over a coarse grid of
 * cell size h; particles only when `fill`. */
static GimletSim *make(int levels, double h, int fill) {
  GimletSim *s = NULL;
  CHECK(gimlet_create(MPI_COMM_WORLD, 0, 0, L, L, h, &s));
  /* The paper's weights and transfer (uGIMP, FLIP), which this scene's
   * figures were measured with; the library's defaults are cpGIMP, APIC. */
  CHECK(gimlet_set_shape(s, GIMLET_SHAPE_UGIMP));
  CHECK(gimlet_set_transfer(s, GIMLET_TRANSFER_FLIP));
  for (int l = 1; l < levels; l++) {
    double w = L / (1 << l), box[4] = {0, L - w, w, L};
    CHECK(gimlet_add_level(s, box, 1));
  }
  /* 2 x 2 patches per level (a refined level: its box plus the 4-cell ghost
   * ring on the two sides away from the domain edge), for 2 to 4 ranks. */
  int n0 = (int)lround(L / h);
  for (int l = 0; l < levels; l++) {
    int nb = l ? 44 : n0;
    CHECK(gimlet_set_patch_size(s, l, (nb + 1) / 2, (nb + 1) / 2));
  }
  CHECK(gimlet_set_thickness(s, 1 * um));
  int m;
  CHECK(gimlet_add_material_linear_elastic(s, 170e9, 0.18, 2330.0, &m));
  CHECK(gimlet_set_face_bc(s, GIMLET_FACE_LEFT, GIMLET_BC_ROLLER));
  CHECK(gimlet_set_face_bc(s, GIMLET_FACE_BOTTOM, GIMLET_BC_FIXED));
  CHECK(gimlet_fill_rectangle(s, 0, 0, L, L, fill ? 2 : 1, m, 2330.0, 0, 0, NULL));
  int64_t loaded;
  CHECK(gimlet_apply_traction(s, GIMLET_FACE_TOP, L, 0, 5 * um, 0, -2e9, &loaded));
  CHECK(gimlet_set_load_ramp(s, 1500 * 20e-12));
  return s;
}

/* Cells the levels' own boxes hold (from gimlet_level_boxes, each box
 * checked against the patches gimlet_level_patches reports), and cells the
 * levels compute on: a refined level's boxes grown by its 4-cell ghost ring,
 * clipped to the domain. */
static void cells(GimletSim *s, double *own, double *comp) {
  int nl;
  CHECK(gimlet_num_levels(s, &nl));
  *own = *comp = 0;
  for (int l = 0; l < nl; l++) {
    double h, b[64], tiled = 0, boxed = 0;
    int64_t nb, np;
    CHECK(gimlet_level_info(s, l, &h, NULL, NULL));
    CHECK(gimlet_level_boxes(s, l, b, 16, &nb));
    long n = lround(L / h), ring = l ? 4 : 0;
    for (int k = 0; k < nb; k++) {
      long lo[2], hi[2];
      for (int a = 0; a < 2; a++) {
        lo[a] = lround(b[4 * k + a] / h);
        hi[a] = lround(b[4 * k + 2 + a] / h);
      }
      boxed += (double)(hi[0] - lo[0]) * (hi[1] - lo[1]);
      for (int a = 0; a < 2; a++) {
        lo[a] = lo[a] - ring < 0 ? 0 : lo[a] - ring;
        hi[a] = hi[a] + ring > n ? n : hi[a] + ring;
      }
      *comp += (double)(hi[0] - lo[0]) * (hi[1] - lo[1]);
    }
    CHECK(gimlet_level_patches(s, l, NULL, NULL, 0, &np));
    int64_t *c = malloc(32 * np + 32);
    CHECK(gimlet_level_patches(s, l, c, NULL, np, &np));
    for (int k = 0; k < np; k++) tiled += (double)(c[4 * k + 2] - c[4 * k]) * (c[4 * k + 3] - c[4 * k + 1]);
    free(c);
    if (tiled < boxed) fprintf(stderr, "level %d: patches hold %.0f cells, boxes %.0f\n", l, tiled, boxed);
    *own += boxed;
  }
}

/* Reference position and stress (4) of the particles of the finest region,
 * gathered on every rank: 6 values each. */
static double *region(GimletSim *s, int *count) {
  int64_t n;
  CHECK(gimlet_get_field(s, GIMLET_FIELD_REFERENCE, NULL, 0, &n));
  double *x0 = malloc(16 * n + 16), *sg = malloc(32 * n + 32), *mine = malloc(48 * n + 48);
  CHECK(gimlet_get_field(s, GIMLET_FIELD_REFERENCE, x0, n, &n));
  CHECK(gimlet_get_field(s, GIMLET_FIELD_STRESS, sg, n, &n));
  int k = 0;
  for (int64_t i = 0; i < n; i++) {
    if (x0[2 * i] > 10 * um || x0[2 * i + 1] < 30 * um) continue;
    mine[6 * k] = x0[2 * i];
    mine[6 * k + 1] = x0[2 * i + 1];
    for (int c = 0; c < 4; c++) mine[6 * k + 2 + c] = sg[4 * i + c];
    k++;
  }
  int size, cnt = 6 * k;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  int *cnts = malloc(sizeof(int) * size), *displ = malloc(sizeof(int) * size), tot = 0;
  MPI_Allgather(&cnt, 1, MPI_INT, cnts, 1, MPI_INT, MPI_COMM_WORLD);
  for (int r = 0; r < size; r++) displ[r] = tot, tot += cnts[r];
  double *all = malloc(8 * (size_t)tot + 8);
  MPI_Allgatherv(mine, cnt, MPI_DOUBLE, all, cnts, displ, MPI_DOUBLE, MPI_COMM_WORLD);
  *count = tot / 6;
  free(x0); free(sg); free(mine); free(cnts); free(displ);
  return all;
}

/* Relative L2 difference over the region of run `a` from the uniform
 * 0.25 um run `u`, whose particles sit on the lattice (m + 1/2) 0.125 um. */
static double difference(const double *a, int na, const double *u, int nu) {
  const int mm = 80;
  const double sp = 0.125 * um;
  double *g = calloc((size_t)mm * mm * 4, 8);
  for (int k = 0; k < nu; k++) {
    int i = (int)lround(u[6 * k] / sp - 0.5), j = (int)lround((u[6 * k + 1] - 30 * um) / sp - 0.5);
    if (i >= 0 && j >= 0 && i < mm && j < mm)
      for (int c = 0; c < 4; c++) g[4 * ((size_t)j * mm + i) + c] = u[6 * k + 2 + c];
  }
  double d2 = 0, s2 = 0;
  for (int k = 0; k < na; k++) {
    double fx = a[6 * k] / sp - 0.5, fy = (a[6 * k + 1] - 30 * um) / sp - 0.5;
    if (fabs(fx - lround(fx)) < 1e-6) fx = (double)lround(fx); /* on the lattice */
    if (fabs(fy - lround(fy)) < 1e-6) fy = (double)lround(fy);
    fx = fmin(fmax(fx, 0), mm - 1);
    fy = fmin(fmax(fy, 0), mm - 1);
    int i = (int)fx < mm - 1 ? (int)fx : mm - 2, j = (int)fy < mm - 1 ? (int)fy : mm - 2;
    double ax = fx - i, ay = fy - j;
    for (int c = 0; c < 4; c++) {
      size_t q = (size_t)j * mm + i;
      double r = (1 - ax) * (1 - ay) * g[4 * q + c] + ax * (1 - ay) * g[4 * (q + 1) + c] +
                 (1 - ax) * ay * g[4 * (q + mm) + c] + ax * ay * g[4 * (q + mm + 1) + c];
      d2 += pow(a[6 * k + 2 + c] - r, 2);
      s2 += r * r;
    }
  }
  free(g);
  return sqrt(d2 / s2);
}

int main(int argc, char **argv) {
  MPI_Init(&argc, &argv);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  int steps = 300, size, table = 1;
  for (int i = 1; i < argc; i++) {
    if (!strcmp(argv[i], "--no-table")) table = 0;
    else if (atoi(argv[i]) > 0) steps = atoi(argv[i]);
    else {
      if (rank_ == 0) fprintf(stderr, "unknown argument %s; usage: levels_speed [STEPS] [--no-table]\n", argv[i]);
      MPI_Finalize();
      return 2;
    }
  }
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  /* Runs: 3 levels, uniform 0.25 um, 0.5 um, 1 um. */
  const char *name[4] = {"3 levels (1/0.5/0.25 um)", "uniform 0.25 um", "uniform 0.5 um", "uniform 1 um"};
  int lev[4] = {3, 1, 1, 1}, sub[4] = {1, 4, 2, 1};
  double hh[4] = {1 * um, 0.25 * um, 0.5 * um, 1 * um}, wall[4], cpu[4], own[4], comp[4], psteps[4];
  int64_t np[4];
  double *reg[4];
  int nreg[4];
  for (int r = 0; r < 4; r++) {
    GimletSim *s = make(lev[r], hh[r], 1);
    cells(s, &own[r], &comp[r]);
    CHECK(gimlet_particle_count(s, NULL, &np[r]));
    int64_t lev_np[8] = {0};
    for (int l = 0; l < lev[r]; l++) CHECK(gimlet_level_particle_count(s, l, &lev_np[l]));
    double t;
    int64_t st;
    MPI_Barrier(MPI_COMM_WORLD);
    double w0 = MPI_Wtime();
    clock_t c0 = clock();
    for (int k = 0; k < steps * sub[r]; k++) CHECK(gimlet_step(s, 20e-12 / sub[r], &t, &st));
    cpu[r] = (double)(clock() - c0) / CLOCKS_PER_SEC;
    MPI_Barrier(MPI_COMM_WORLD);
    wall[r] = MPI_Wtime() - w0;
    MPI_Allreduce(MPI_IN_PLACE, &cpu[r], 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    psteps[r] = 0;
    for (int l = 0; l < lev[r]; l++) {
      int64_t lc[2];
      CHECK(gimlet_level_stats(s, l, NULL, lc));
      psteps[r] += (double)lev_np[l] * (double)lc[0];
    }
    MPI_Allreduce(MPI_IN_PLACE, &psteps[r], 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    /* Where the steps went (summed over levels; largest over ranks). */
    double ph[5] = {0};
    for (int l = 0; l < lev[r]; l++) {
      double t5[5];
      CHECK(gimlet_level_stats(s, l, t5, NULL));
      for (int k = 0; k < 5; k++) ph[k] += t5[k];
    }
    MPI_Allreduce(MPI_IN_PLACE, ph, 5, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    if (rank_ == 0)
      printf("%s: kernel %.3f s, contact %.3f s, exchange %.3f s, migration %.3f s, coupling %.3f s "
             "(summed over levels, largest over ranks)\n",
             name[r], ph[0], ph[1], ph[2], ph[3], ph[4]);
    reg[r] = region(s, &nreg[r]);
    CHECK(gimlet_destroy(&s));
  }
  double diff[4], est = difference(reg[2], nreg[2], reg[1], nreg[1]) / 3;
  for (int r = 0; r < 4; r++) diff[r] = difference(reg[r], nreg[r], reg[1], nreg[1]);
  if (rank_ == 0) {
    printf("pressure indentation, %d coarse steps of 20 ps (load factor %.3f), %d rank(s)\n", steps,
           fmin(1.0, steps / 1500.0), size);
    printf("%-26s %9s %9s %9s %9s %10s %9s %14s\n", "run", "wall [s]", "cpu [s]", "wall/fine", "cells",
           "particles", "/fine", "stress diff");
    for (int r = 0; r < 4; r++)
      printf("%-26s %9.2f %9.2f %9.3f %9.0f %10lld %9.3f %14.3e\n", name[r], wall[r], cpu[r], wall[r] / wall[1],
             comp[r], (long long)np[r], (double)np[r] / np[1], diff[r]);
    printf("cells ratio (computational) 3 levels / uniform finest: %.3f; particles ratio: %.3f\n",
           comp[0] / comp[1], (double)np[0] / np[1]);
    printf("uniform-finest error estimate |s_0.5 - s_0.25| / 3 = %.3e; 3-level error <= %.3e + %.3e = "
           "%.3e = %.2fx that estimate\n",
           est, diff[0], est, diff[0] + est, (diff[0] + est) / est);
    printf("target: wall(3 levels) / wall(uniform finest) = %.3f <= 0.30 %s; error within 2x: %s\n",
           wall[0] / wall[1], wall[0] / wall[1] <= 0.30 ? "met" : "NOT met",
           diff[0] + est <= 2 * est ? "met" : "NOT met");
    printf("{\"case\":\"levels_speed\",\"ranks\":%d,\"coarse_steps\":%d,\"runs\":[", size, steps);
    const char *key[4] = {"3_levels", "uniform_0.25um", "uniform_0.5um", "uniform_1um"};
    for (int r = 0; r < 4; r++)
      printf("%s{\"name\":\"%s\",\"wall_s\":%.4f,\"cpu_s\":%.4f,\"particles\":%lld,\"particle_steps\":%.6e,"
             "\"cells\":%.0f,\"stress_diff\":%.4e}",
             r ? "," : "", key[r], wall[r], cpu[r], (long long)np[r], psteps[r], comp[r], diff[r]);
    printf("],\"fine_error_estimate\":%.4e,\"wall_ratio\":%.4f,\"error_bound_ratio\":%.4f}\n", est,
           wall[0] / wall[1], (diff[0] + est) / est);
    fflush(stdout);
  }
  for (int r = 0; r < 4; r++) free(reg[r]);
  if (!table) {
    MPI_Finalize();
    return 0;
  }
  if (rank_ == 0) {
    printf("\ncell percentage (paper fig. 6b: each level a quarter of the next coarser in area;\n"
           "the paper: about 8 %% of a uniform finest grid with 4 levels)\n");
    printf("%7s %14s %18s %14s\n", "levels", "own boxes [%]", "computed cells [%]", "particles [%]");
  }
  for (int nl = 1; nl <= 5; nl++) {
    GimletSim *s = make(nl, 1 * um, 1);
    double o, c, fine = pow(40.0 * (1 << (nl - 1)), 2);
    int64_t n;
    cells(s, &o, &c);
    CHECK(gimlet_particle_count(s, NULL, &n));
    if (rank_ == 0) printf("%7d %14.2f %18.2f %14.2f\n", nl, 100 * o / fine, 100 * c / fine, 100 * n / (4 * fine));
    CHECK(gimlet_destroy(&s));
  }
  MPI_Finalize();
  return 0;
}
