/* The speed benchmark's comparison scene through the public C API, on as
 * many ranks as it is started with (`make bench` runs it; see
 * scripts/bench.py and docs/performance.md).
 *
 * The scene the peer codes of the benchmark run: a unit box of
 * CELLS x CELLS cells, all four faces fixed, a BLOCK x BLOCK Neo-Hookean
 * block (E = 1e4, nu = 0.3, rho = 1, plane strain) centred in x, 5 cells
 * above the floor, moving at v = (0, -1) under gravity (0, -9.8), PPC
 * particles per cell, dt = 0.3 dx / c with c the P-wave speed, f64.
 * CELLS = 512 and PPC = 4 give 262,144 particles, CELLS = 1024 1,048,576.
 *
 * Each run builds the scene (gimlet_create, gimlet_set_*,
 * gimlet_fill_rectangle), takes WARMUP untimed steps, then times STEPS
 * calls of gimlet_step between two barriers. The domain is tiled into one
 * column of patches per rank (patch width ceil(CELLS / ranks)), so with the
 * centred block each rank holds half the particles on 2 ranks.
 *
 * The block does not reach the floor within the run (it falls less than
 * one cell in 210 steps at 512 cells), so it falls freely and unstressed:
 * the printed errors are against that. `momentum_rel_err` is
 * |p_y - M (-1 - 9.8 t)| / (M |-1 - 9.8 t|) from gimlet_diagnostics (the
 * gravity impulse per step is exact, so this is round-off);
 * `com_fall_rel_err` is the centre of mass's fall against the continuous
 * free fall t + 4.9 t^2, relative to that fall (first order in dt: about
 * 9.8 dt / 2 with the position moved by the new velocity), and
 * `com_discrete_rel_err` the same against the discrete free fall of n
 * steps with the position moved by the new velocity,
 * n dt + 9.8 dt^2 n (n + 1) / 2 (round-off). When the block would come
 * within 2 cells of the floor all three are null.
 *
 * Prints one JSON line (rank 0): particles, steps, runs, the median wall
 * and CPU time (CPU: clock() summed over ranks), particle-steps per second,
 * per second per core (rate / ranks) and per CPU second, the wall times of
 * every run, the errors of the last run and where its timed steps went
 * (gimlet_level_stats of level 0, largest and smallest over the ranks).
 *
 *   mpiexec -n R bench_scene [--cells 512] [--ppc 4] [--steps 200]
 *       [--warmup 10] [--runs 3] [--scheme usl|musl|usf]
 *       [--shape ugimp|cpgimp|mpm] [--transfer flip|apic|xpicM] [--block 0.5] [--case NAME]
 *       [--geometry plane|axisym]
 *
 * `--geometry axisym` runs the same scene in the axisymmetric mode (x the
 * radius: the block a ring of rectangular section), for the kernel's cost
 * against plane strain; its error figures are per the axisymmetric
 * diagnostics (the whole body's).
 */
#include <math.h>
#include <mpi.h>
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
      char m_[1024];                                                     \
      gimlet_last_error(m_, sizeof m_, NULL);                            \
      fprintf(stderr, "rank %d: %s -> %d: %s\n", rank_, #call, rc_, m_); \
      MPI_Abort(MPI_COMM_WORLD, 2);                                      \
    }                                                                    \
  } while (0)

static int cmp_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

static double median(double *v, int n) {
  double *c = malloc(sizeof(double) * (size_t)n);
  memcpy(c, v, sizeof(double) * (size_t)n);
  qsort(c, (size_t)n, sizeof(double), cmp_double);
  double m = n % 2 ? c[n / 2] : 0.5 * (c[n / 2 - 1] + c[n / 2]);
  free(c);
  return m;
}

static int usage(const char *msg) {
  if (rank_ == 0)
    fprintf(stderr,
            "%s\nusage: bench_scene [--cells 512] [--ppc 4] [--steps 200] [--warmup 10] [--runs 3] "
            "[--scheme usl|musl|usf] [--shape ugimp|cpgimp|mpm] [--transfer flip|apic|xpicM] [--block 0.5] [--case NAME] [--geometry plane|axisym]\n",
            msg);
  MPI_Finalize();
  return 2;
}

int main(int argc, char **argv) {
  MPI_Init(&argc, &argv);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  int size;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  int cells = 512, ppc = 4, steps = 200, warmup = 10, runs = 3;
  int scheme = GIMLET_SCHEME_USL, shape = GIMLET_SHAPE_UGIMP, transfer = GIMLET_TRANSFER_FLIP, xpic_order = 5;
  const char *scheme_name = "usl", *shape_name = "ugimp", *case_name = "comparison";
  double block = 0.5;
  int geometry = GIMLET_PLANE_STRAIN;
  for (int i = 1; i < argc; i++) {
    const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
    char msg[256];
    if (!v) {
      snprintf(msg, sizeof msg, "%s needs a value", a);
      return usage(msg);
    }
    if (!strcmp(a, "--cells")) cells = atoi(v);
    else if (!strcmp(a, "--ppc")) ppc = atoi(v);
    else if (!strcmp(a, "--steps")) steps = atoi(v);
    else if (!strcmp(a, "--warmup")) warmup = atoi(v);
    else if (!strcmp(a, "--runs")) runs = atoi(v);
    else if (!strcmp(a, "--block")) block = atof(v);
    else if (!strcmp(a, "--case")) case_name = v;
    else if (!strcmp(a, "--geometry")) {
      if (!strcmp(v, "plane")) geometry = GIMLET_PLANE_STRAIN;
      else if (!strcmp(v, "axisym")) geometry = GIMLET_AXISYMMETRIC;
      else return usage("--geometry must be plane or axisym");
    }
    else if (!strcmp(a, "--scheme")) {
      scheme_name = v;
      if (!strcmp(v, "usl")) scheme = GIMLET_SCHEME_USL;
      else if (!strcmp(v, "musl")) scheme = GIMLET_SCHEME_MUSL;
      else if (!strcmp(v, "usf")) scheme = GIMLET_SCHEME_USF;
      else return usage("--scheme must be usl, musl or usf");
    } else if (!strcmp(a, "--shape")) {
      shape_name = v;
      if (!strcmp(v, "ugimp")) shape = GIMLET_SHAPE_UGIMP;
      else if (!strcmp(v, "cpgimp")) shape = GIMLET_SHAPE_CPGIMP;
      else if (!strcmp(v, "mpm")) shape = GIMLET_SHAPE_MPM;
      else return usage("--shape must be ugimp, cpgimp or mpm");
    } else if (!strcmp(a, "--transfer")) {
      if (!strcmp(v, "flip")) transfer = GIMLET_TRANSFER_FLIP;
      else if (!strcmp(v, "apic")) transfer = GIMLET_TRANSFER_APIC;
      else if (!strncmp(v, "xpic", 4) && atoi(v + 4) >= 1) transfer = GIMLET_TRANSFER_XPIC, xpic_order = atoi(v + 4);
      else return usage("--transfer must be flip, apic or xpicM (M the XPIC order)");
    } else {
      snprintf(msg, sizeof msg, "unknown argument %s", a);
      return usage(msg);
    }
    i++;
  }
  int side = (int)lround(sqrt((double)ppc));
  if (side < 1 || side > 8 || side * side != ppc) return usage("--ppc must be n^2 with 1 <= n <= 8");
  if (cells < 16 || cells > 16384) return usage("--cells must lie in [16, 16384]");
  if (steps < 1 || runs < 1 || warmup < 0) return usage("--steps and --runs must be >= 1, --warmup >= 0");
  if (!(block > 0 && block <= 0.9) || fabs(block * cells - lround(block * cells)) > 1e-9)
    return usage("--block must lie in (0, 0.9] and span a whole number of cells");

  const double E = 1e4, nu = 0.3, rho = 1.0, g = 9.8;
  const double h = 1.0 / cells;
  const double lam = E * nu / ((1 + nu) * (1 - 2 * nu)), mu = E / (2 * (1 + nu));
  const double c = sqrt((lam + 2 * mu) / rho), dt = 0.3 * h / c;
  const double y0 = 5 * h, xlo = 0.5 - 0.5 * block, ylo = y0, xhi = 0.5 + 0.5 * block, yhi = y0 + block;

  double *wall = malloc(sizeof(double) * (size_t)runs), *cpu = malloc(sizeof(double) * (size_t)runs);
  int64_t particles = 0, local_min = 0, local_max = 0;
  double t = 0, com_err = NAN, mom_err = NAN, disc_err = NAN;
  /* Where the timed steps of the last run went (gimlet_level_stats: kernel,
   * contact, nodal sums over shared nodes including waiting, migration,
   * coupling), the largest and smallest over the ranks. */
  double ph_max[5] = {0}, ph_min[5] = {0};
  for (int r = 0; r < runs; r++) {
    GimletSim *s = NULL;
    CHECK(gimlet_create(MPI_COMM_WORLD, 0, 0, 1, 1, h, &s));
    CHECK(gimlet_set_geometry(s, geometry));
    CHECK(gimlet_set_patch_size(s, 0, (cells + size - 1) / size, cells));
    for (int f = 0; f < 4; f++) CHECK(gimlet_set_face_bc(s, f, GIMLET_BC_FIXED));
    CHECK(gimlet_set_gravity(s, 0, -g));
    CHECK(gimlet_set_scheme(s, scheme));
    CHECK(gimlet_set_shape(s, shape));
    CHECK(gimlet_set_transfer(s, transfer));
    if (transfer == GIMLET_TRANSFER_XPIC) CHECK(gimlet_set_xpic_order(s, xpic_order));
    CHECK(gimlet_set_cfl(s, 1.0));
    int m;
    CHECK(gimlet_add_material_neo_hookean(s, E, nu, rho, &m));
    CHECK(gimlet_fill_rectangle(s, xlo, ylo, xhi, yhi, side, m, rho, 0, -1, &particles));
    int64_t st;
    for (int k = 0; k < warmup; k++) CHECK(gimlet_step(s, dt, &t, &st));
    double ph0[5], ph1[5];
    CHECK(gimlet_level_stats(s, 0, ph0, NULL));
    MPI_Barrier(MPI_COMM_WORLD);
    double w0 = MPI_Wtime();
    clock_t c0 = clock();
    for (int k = 0; k < steps; k++) CHECK(gimlet_step(s, dt, &t, &st));
    double mycpu = (double)(clock() - c0) / CLOCKS_PER_SEC;
    CHECK(gimlet_level_stats(s, 0, ph1, NULL));
    for (int k = 0; k < 5; k++) ph1[k] -= ph0[k];
    MPI_Allreduce(ph1, ph_max, 5, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    MPI_Allreduce(ph1, ph_min, 5, MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
    MPI_Barrier(MPI_COMM_WORLD);
    wall[r] = MPI_Wtime() - w0;
    MPI_Allreduce(&mycpu, &cpu[r], 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);

    /* Free fall of the unstressed block, while it stays clear of the floor. */
    int64_t local = 0, n = 0;
    CHECK(gimlet_particle_count(s, &local, NULL));
    MPI_Allreduce(&local, &local_min, 1, MPI_INT64_T, MPI_MIN, MPI_COMM_WORLD);
    MPI_Allreduce(&local, &local_max, 1, MPI_INT64_T, MPI_MAX, MPI_COMM_WORLD);
    double fall = t + 0.5 * g * t * t;
    if (fall < y0 - 2 * h) {
      CHECK(gimlet_get_field(s, GIMLET_FIELD_POSITION, NULL, 0, &n));
      double *xy = malloc(sizeof(double) * (size_t)(2 * n + 2)), sum[2] = {0, 0};
      CHECK(gimlet_get_field(s, GIMLET_FIELD_POSITION, xy, n, &n));
      for (int64_t i = 0; i < n; i++) sum[0] += xy[2 * i + 1];
      sum[1] = (double)n;
      free(xy);
      MPI_Allreduce(MPI_IN_PLACE, sum, 2, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
      double com_y = sum[0] / sum[1], com_y0 = 0.5 * (ylo + yhi);
      com_err = fabs((com_y0 - com_y) - fall) / fall;
      double nst = (double)(warmup + steps), fall_n = nst * dt + 0.5 * g * dt * dt * nst * (nst + 1);
      disc_err = fabs((com_y0 - com_y) - fall_n) / fall_n;
      double py, mass;
      CHECK(gimlet_diagnostics(s, NULL, NULL, NULL, &py, &mass));
      double p_exact = mass * (-1 - g * t);
      mom_err = fabs(py - p_exact) / fabs(p_exact);
    } else {
      com_err = mom_err = disc_err = NAN;
    }
    CHECK(gimlet_destroy(&s));
  }
  if (rank_ == 0) {
    double w = median(wall, runs), cp = median(cpu, runs), ps = (double)particles * steps;
    printf("{\"case\":\"%s\",\"impl\":\"gimlet\",\"api\":\"c\",\"scheme\":\"%s\",\"shape\":\"%s\",\"ranks\":%d,"
           "\"cells\":%d,\"ppc\":%d,\"particles\":%lld,\"rank_particles_min\":%lld,\"rank_particles_max\":%lld,"
           "\"steps\":%d,\"warmup\":%d,\"runs\":%d,\"dt\":%.6e,\"wall_s\":%.4f,\"cpu_s\":%.4f,"
           "\"pstep_per_s\":%.6e,\"pstep_per_s_per_core\":%.6e,\"pstep_per_cpu_s\":%.6e,\"walls\":[",
           case_name, scheme_name, shape_name, size, cells, ppc, (long long)particles, (long long)local_min,
           (long long)local_max, steps, warmup, runs, dt, w, cp, ps / w, ps / w / size, ps / cp);
    for (int r = 0; r < runs; r++) printf("%s%.4f", r ? "," : "", wall[r]);
    printf("],\"phase_names\":[\"kernel\",\"contact\",\"exchange\",\"migration\",\"coupling\"],"
           "\"phase_max_s\":[%.4f,%.4f,%.4f,%.4f,%.4f],\"phase_min_s\":[%.4f,%.4f,%.4f,%.4f,%.4f",
           ph_max[0], ph_max[1], ph_max[2], ph_max[3], ph_max[4], ph_min[0], ph_min[1], ph_min[2], ph_min[3],
           ph_min[4]);
    if (isnan(com_err))
      printf("],\"t_end\":%.6e,\"com_fall_rel_err\":null,\"com_discrete_rel_err\":null,"
             "\"momentum_rel_err\":null}\n", t);
    else
      printf("],\"t_end\":%.6e,\"com_fall_rel_err\":%.3e,\"com_discrete_rel_err\":%.3e,\"momentum_rel_err\":%.3e}\n",
             t, com_err, disc_err, mom_err);
    fflush(stdout);
  }
  free(wall);
  free(cpu);
  MPI_Finalize();
  return 0;
}
