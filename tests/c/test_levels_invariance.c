/* Nested levels on several ranks and patch layouts (issue "Nested levels
 * with subcycling"): rank and patch invariance, exact mass conservation.
 *
 * Rank 0 first runs the scene alone (on MPI_COMM_SELF, one patch per box
 * of every level) as the reference; then every rank runs it together on
 * MPI_COMM_WORLD with every level tiled by patches of PATCH x PATCH cells.
 * Checks, after STEPS coarse steps:
 *   - positions and stresses by global id match the reference to 1e-12
 *     relative (position differences over the largest coordinate, stress
 *     differences over the largest stress component);
 *   - each particle is owned by exactly one level: the global ids over all
 *     levels are unique, and the (id, mass) list equals the one after
 *     insertion, so the total mass is conserved exactly (the diagnostic
 *     mass, a floating-point sum in patch order, within 1e-14);
 *   - at least one particle changed level (the coupling moved owners).
 * Reported: momentum and energy at the start and the end (the scenes have
 * walls and loads, so neither is conserved; the numbers show the drift).
 *
 * Scenes: "plate" (2 levels, box [0.25, 0.75]^2 of a unit square of 32
 * cells, vibrating with an amplitude of one coarse cell so that particles
 * cross patch and level boundaries) and "pressure" (the paper's
 * indentation of silicon with 3 levels under the loaded strip, see
 * test_levels_pressure.c).
 *
 *   test_levels_invariance SCENE PATCH STEPS [WEIGHTS]
 *
 * WEIGHTS is "ugimp_flip" (the default here: uGIMP weights with the
 * FLIP transfer, the paper's, which the examples and the main job use) or
 * "cpgimp_apic" (the library's default, cpGIMP weights with the APIC
 * transfer; both are set explicitly on both runs. cpGIMP with APIC is the
 * combination whose affine matrices once depended on the patch layout
 * through the nodes beyond the roller plane that only the tails of the
 * cpGIMP domains reach).
 */
#include <mpi.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "gimlet.h"
#include "weights.h"

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

typedef struct { uint64_t id; double v[8]; } Rec; /* x, y, sxx, syy, sxy, szz, mass, level */

static int by_id(const void *a, const void *b) {
  uint64_t x = ((const Rec *)a)->id, y = ((const Rec *)b)->id;
  return x < y ? -1 : x > y;
}

static const double um = 1e-6;

/* The weights and transfer of both runs: 1 for cpGIMP with APIC, 0 for
 * uGIMP with FLIP (see the usage notes). */
static int cpgimp_apic = 0;

/* Builds the scene on `comm`; `patch` > 0 tiles every level with patches
 * of that many cells. Returns the coarse step. */
static double setup(GimletSim **s, MPI_Comm comm, const char *scene, int patch) {
  if (!strcmp(scene, "plate")) {
    const double E = 1e4, nu = 0.3, rho = 1, h = 1.0 / 32;
    CHECK(gimlet_create(comm, 0, 0, 1, 1, h, s));
    CHECK(weights_set(*s, cpgimp_apic));
    double b[4] = {0.25, 0.25, 0.75, 0.75};
    CHECK(gimlet_add_level(*s, b, 1));
    if (patch > 0)
      for (int l = 0; l < 2; l++) CHECK(gimlet_set_patch_size(*s, l, patch, patch));
    int m;
    CHECK(gimlet_add_material_neo_hookean(*s, E, nu, rho, &m));
    for (int f = 0; f < 4; f++) CHECK(gimlet_set_face_bc(*s, f, GIMLET_BC_ROLLER));
    CHECK(gimlet_fill_rectangle(*s, 0, 0, 1, 1, 2, m, rho, 0, 0, NULL));
    double lam = E * nu / ((1 + nu) * (1 - 2 * nu)), mu = E / (2 * (1 + nu));
    double om = M_PI * sqrt((lam + 2 * mu) / rho), v0 = om * h;
    int64_t n;
    CHECK(gimlet_get_field(*s, GIMLET_FIELD_POSITION, NULL, 0, &n));
    double *x = malloc(16 * n + 16), *v = malloc(16 * n + 16);
    CHECK(gimlet_get_field(*s, GIMLET_FIELD_POSITION, x, n, &n));
    for (int64_t i = 0; i < 2 * n; i++) v[i] = v0 * sin(M_PI * x[i]);
    CHECK(gimlet_set_field(*s, GIMLET_FIELD_VELOCITY, v, n));
    free(x);
    free(v);
    double dt;
    CHECK(gimlet_stable_dt(*s, &dt));
    return 0.8 * dt;
  }
  CHECK(gimlet_create(comm, 0, 0, 40 * um, 40 * um, 1 * um, s));
  CHECK(weights_set(*s, cpgimp_apic));
  double b1[4] = {0, 20 * um, 20 * um, 40 * um}, b2[4] = {0, 30 * um, 10 * um, 40 * um};
  CHECK(gimlet_add_level(*s, b1, 1));
  CHECK(gimlet_add_level(*s, b2, 1));
  if (patch > 0)
    for (int l = 0; l < 3; l++) CHECK(gimlet_set_patch_size(*s, l, patch, patch));
  CHECK(gimlet_set_thickness(*s, 1 * um));
  int m;
  CHECK(gimlet_add_material_linear_elastic(*s, 170e9, 0.18, 2330.0, &m));
  CHECK(gimlet_set_face_bc(*s, GIMLET_FACE_LEFT, GIMLET_BC_ROLLER));
  CHECK(gimlet_set_face_bc(*s, GIMLET_FACE_BOTTOM, GIMLET_BC_FIXED));
  CHECK(gimlet_fill_rectangle(*s, 0, 0, 40 * um, 40 * um, 2, m, 2330.0, 0, 0, NULL));
  int64_t loaded;
  CHECK(gimlet_apply_traction(*s, GIMLET_FACE_TOP, 40 * um, 0, 5 * um, 0, -2e9, &loaded));
  CHECK(gimlet_set_load_ramp(*s, 1500 * 20e-12));
  return 20e-12;
}

/* Every particle of the run on `comm`, sorted by id, on the root (rank 0
 * of MPI_COMM_WORLD, which is rank 0 of both communicators used here). */
static Rec *collect(GimletSim *s, MPI_Comm comm, int64_t *count) {
  int64_t n;
  CHECK(gimlet_get_ids(s, NULL, 0, &n));
  uint64_t *ids = malloc(8 * n + 8);
  double *x = malloc(16 * n + 16), *sg = malloc(32 * n + 32), *ms = malloc(8 * n + 8), *lv = malloc(8 * n + 8);
  CHECK(gimlet_get_ids(s, ids, n, &n));
  CHECK(gimlet_get_field(s, GIMLET_FIELD_POSITION, x, n, &n));
  CHECK(gimlet_get_field(s, GIMLET_FIELD_STRESS, sg, n, &n));
  CHECK(gimlet_get_field(s, GIMLET_FIELD_MASS, ms, n, &n));
  CHECK(gimlet_get_field(s, GIMLET_FIELD_LEVEL, lv, n, &n));
  Rec *mine = malloc(sizeof(Rec) * (n + 1));
  for (int64_t i = 0; i < n; i++) {
    mine[i].id = ids[i];
    mine[i].v[0] = x[2 * i];
    mine[i].v[1] = x[2 * i + 1];
    for (int c = 0; c < 4; c++) mine[i].v[2 + c] = sg[4 * i + c];
    mine[i].v[6] = ms[i];
    mine[i].v[7] = lv[i];
  }
  int size, me, cnt = (int)(n * sizeof(Rec));
  MPI_Comm_size(comm, &size);
  MPI_Comm_rank(comm, &me);
  int *cnts = malloc(sizeof(int) * size), *displ = malloc(sizeof(int) * size);
  MPI_Gather(&cnt, 1, MPI_INT, cnts, 1, MPI_INT, 0, comm);
  int tot = 0;
  if (me == 0)
    for (int r = 0; r < size; r++) displ[r] = tot, tot += cnts[r];
  Rec *all = me == 0 ? malloc(tot + sizeof(Rec)) : NULL;
  MPI_Gatherv(mine, cnt, MPI_BYTE, all, cnts, displ, MPI_BYTE, 0, comm);
  *count = tot / (int64_t)sizeof(Rec);
  if (me == 0) qsort(all, *count, sizeof(Rec), by_id);
  free(ids); free(x); free(sg); free(ms); free(lv); free(mine); free(cnts); free(displ);
  return all;
}

/* Runs the scene; returns the sorted records (root only), the initial
 * ones, and the diagnostics before and after. */
static Rec *run(MPI_Comm comm, const char *scene, int patch, int steps, Rec **initial, int64_t *n0,
                int64_t *n, double d0[5], double d1[5], int64_t *moved) {
  GimletSim *s = NULL;
  double dt = setup(&s, comm, scene, patch);
  *initial = collect(s, comm, n0);
  CHECK(gimlet_diagnostics(s, &d0[0], &d0[1], &d0[2], &d0[3], &d0[4]));
  double t;
  int64_t st;
  for (int k = 0; k < steps; k++) CHECK(gimlet_step(s, dt, &t, &st));
  CHECK(gimlet_diagnostics(s, &d1[0], &d1[1], &d1[2], &d1[3], &d1[4]));
  Rec *out = collect(s, comm, n);
  *moved = 0;
  int me;
  MPI_Comm_rank(comm, &me);
  if (me == 0)
    for (int64_t i = 0; i < *n && i < *n0; i++)
      *moved += out[i].id == (*initial)[i].id && out[i].v[7] != (*initial)[i].v[7];
  CHECK(gimlet_destroy(&s));
  return out;
}

/* Exact conservation on the root: same ids (unique), same masses. */
static int conserved(const char *what, const Rec *a, int64_t na, const Rec *b, int64_t nb, const double d0[5],
                     const double d1[5]) {
  int ok = na == nb;
  for (int64_t i = 0; ok && i < na; i++) {
    if (i > 0 && b[i].id == b[i - 1].id) ok = 0;
    if (a[i].id != b[i].id || a[i].v[6] != b[i].v[6]) ok = 0;
  }
  double dm = fabs(d1[4] - d0[4]) / d0[4];
  ok = ok && dm <= 1e-14;
  printf("  %s: %lld particles, ids unique and (id, mass) list unchanged: %s; diagnostic mass "
         "change %.1e\n",
         what, (long long)nb, ok ? "yes" : "NO", dm);
  printf("  %s: momentum (%.6e, %.6e) -> (%.6e, %.6e); energy %.6e -> %.6e (kinetic %.3e, "
         "strain %.3e)\n",
         what, d0[2], d0[3], d1[2], d1[3], d0[0] + d0[1], d1[0] + d1[1], d1[0], d1[1]);
  return ok;
}

int main(int argc, char **argv) {
  MPI_Init(&argc, &argv);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  if (argc < 4 || argc > 5) {
    if (rank_ == 0) fprintf(stderr, "usage: %s plate|pressure PATCH STEPS [ugimp_flip|cpgimp_apic]\n", argv[0]);
    MPI_Finalize();
    return 2;
  }
  if (argc == 5 && (cpgimp_apic = weights_parse(argv[4])) < 0) {
    if (rank_ == 0) fprintf(stderr, "unknown weights %s\n", argv[4]);
    MPI_Finalize();
    return 2;
  }
  const char *scene = argv[1];
  int patch = atoi(argv[2]), steps = atoi(argv[3]), size;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  int fail = 0;
  Rec *ri = NULL, *rr = NULL, *wi, *wr;
  int64_t rn0 = 0, rn = 0, wn0, wn, rmoved = 0, wmoved;
  double rd0[5], rd1[5], wd0[5], wd1[5];
  if (rank_ == 0) rr = run(MPI_COMM_SELF, scene, 0, steps, &ri, &rn0, &rn, rd0, rd1, &rmoved);
  wr = run(MPI_COMM_WORLD, scene, patch, steps, &wi, &wn0, &wn, wd0, wd1, &wmoved);
  if (rank_ == 0) {
    printf("%s%s, %d steps: reference 1 rank 1 patch per box; run %d ranks, patches of %d cells; "
           "%lld particles changed level (reference %lld)\n",
           scene, cpgimp_apic ? " (cpGIMP, APIC)" : "", steps, size, patch, (long long)wmoved,
           (long long)rmoved);
    fail |= !conserved("reference", ri, rn0, rr, rn, rd0, rd1);
    fail |= !conserved("run", wi, wn0, wr, wn, wd0, wd1);
    double xs = 0, ss = 0, dx = 0, ds = 0;
    int same = rn == wn;
    for (int64_t i = 0; same && i < rn; i++) {
      if (rr[i].id != wr[i].id) {
        same = 0;
        break;
      }
      for (int c = 0; c < 2; c++) {
        xs = fmax(xs, fabs(rr[i].v[c]));
        dx = fmax(dx, fabs(rr[i].v[c] - wr[i].v[c]));
      }
      for (int c = 2; c < 6; c++) {
        ss = fmax(ss, fabs(rr[i].v[c]));
        ds = fmax(ds, fabs(rr[i].v[c] - wr[i].v[c]));
      }
    }
    double ex = dx / xs, es = ss > 0 ? ds / ss : ds;
    printf("  max |dx| / position scale = %.3e, max |dstress| / stress scale = %.3e (bound 1e-12)\n", ex, es);
    fail |= !(same && ex <= 1e-12 && es <= 1e-12);
    fail |= wmoved == 0 && !strcmp(scene, "plate");
    printf("test_levels_invariance %s: %s\n", scene, fail ? "FAILED" : "passed");
  }
  MPI_Bcast(&fail, 1, MPI_INT, 0, MPI_COMM_WORLD);
  free(ri); free(rr); free(wi); free(wr);
  MPI_Finalize();
  return fail;
}
