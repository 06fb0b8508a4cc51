/* A fuzz test of the C API (issue "Never abort, never hang", item 9).
 *
 * Random sequences of gimlet_* calls, every function of gimlet.h, with
 * valid, boundary and invalid arguments (NaN, infinities, huge and tiny
 * values, zero and negative sizes, NULL pointers, out-of-range indices),
 * seeded (the seed is printed; GIMLET_FUZZ_SEED=<n> replays it) and bounded
 * in time. Every rank draws the same sequence of calls and collective
 * arguments from the same seed; per-rank arguments (particle arrays, field
 * values, buffer capacities) may differ. In "mismatch" mode (2 ranks),
 * rank 1 changes one collective argument of some calls.
 *
 * Oracles, checked after every call (a violation is a failure, counted by
 * kind and printed with the call):
 *   - no abort, no hang (ctest's timeout);
 *   - a failed call has a message that starts with the function's name,
 *     and, for GIMLET_ERR_INVALID_ARGUMENT and _NULL_POINTER, names one of
 *     the function's arguments;
 *   - a rejected collective call changes nothing: particle counts, time,
 *     step count, diagnostics, the lost list and a checksum of every local
 *     particle field are as before; so does a gimlet_step that fails while
 *     stepping (GIMLET_ERR_UNSTABLE, _PARTICLES_LEFT: steps are
 *     transactional). gimlet_advance_to failing after some of its steps
 *     (or stopped by max_steps) keeps the steps taken before, so its
 *     failures are counted apart;
 *   - collective calls return the same status and the same message on
 *     every rank;
 *   - no GIMLET_ERR_INTERNAL (a caught panic is a bug).
 *
 * Usage: fuzz_api <work-dir> [seconds = 45] [mismatch]. Prints the seed,
 * the number of calls, the statuses, the slowest call and the failures by
 * kind. The time budget is checked between calls, so each drawn call's
 * work is kept bounded (see gimlet_advance_to below). The files a run
 * writes in <work-dir> are removed at its start, so that a seed replays
 * the same run. GIMLET_FUZZ_SLOW=<s> prints every call slower than s
 * seconds. */
#include <ctype.h>
#include <float.h>
#include <limits.h>
#include <math.h>
#include <mpi.h>
#include <stdint.h>
#include <time.h>
#include <unistd.h>
#include "check.h"

static int rank = 0, size = 1, mismatch = 0;
static uint64_t rng = 1, rng_local = 1;

static uint64_t next_u64(uint64_t *s) {
  uint64_t x = *s;
  x ^= x >> 12;
  x ^= x << 25;
  x ^= x >> 27;
  *s = x;
  return x * 0x2545F4914F6CDD1DULL;
}
/* Shared stream: the same on every rank. */
static double unif(void) { return (double)(next_u64(&rng) >> 11) / 9007199254740992.0; }
static int pick(int n) { return (int)(next_u64(&rng) % (uint64_t)n); }
/* Per-rank stream. */
static double unif_local(void) { return (double)(next_u64(&rng_local) >> 11) / 9007199254740992.0; }

static const double boundary_d[] = {0.0, -0.0, 1e-30, 1e30, 1e-31, 1e31, -1.0, 1e-300, 1e300, DBL_MAX, -DBL_MAX,
                                    DBL_MIN, 4.9e-324, NAN, INFINITY, -INFINITY, 0.5, 1.0};
static const int boundary_i[] = {0, -1, 1, 2, 3, 7, 8, 9, 64, 65, 1 << 24, (1 << 24) + 1, INT_MAX, INT_MIN};

/* A double: valid in [lo, hi] (60 %), a boundary value (25 %), or a value
 * out of [lo, hi] (15 %). */
static double arg_d(double lo, double hi) {
  double u = unif();
  if (u < 0.6) return lo + (hi - lo) * unif();
  if (u < 0.85) return boundary_d[pick((int)(sizeof boundary_d / sizeof boundary_d[0]))];
  return unif() < 0.5 ? lo - (1 + unif()) * (fabs(lo) + 1) : hi + (1 + unif()) * (fabs(hi) + 1);
}
static int arg_i(int lo, int hi) {
  double u = unif();
  if (u < 0.6) return lo + pick(hi - lo + 1);
  if (u < 0.85) return boundary_i[pick((int)(sizeof boundary_i / sizeof boundary_i[0]))];
  return unif() < 0.5 ? lo - 1 - pick(5) : hi + 1 + pick(5);
}
/* The same from the per-rank stream (for per-rank arguments). */
static double arg_d_local(double lo, double hi) {
  double u = unif_local();
  if (u < 0.6) return lo + (hi - lo) * unif_local();
  if (u < 0.85) return boundary_d[(int)(unif_local() * (sizeof boundary_d / sizeof boundary_d[0]))];
  return unif_local() < 0.5 ? lo - (1 + unif_local()) * (fabs(lo) + 1) : hi + (1 + unif_local()) * (fabs(hi) + 1);
}
static int arg_i_local(int lo, int hi) {
  double u = unif_local();
  if (u < 0.6) return lo + (int)(unif_local() * (hi - lo + 1));
  if (u < 0.85) return boundary_i[(int)(unif_local() * (sizeof boundary_i / sizeof boundary_i[0]))];
  return unif_local() < 0.5 ? lo - 1 : hi + 1;
}
/* A pointer argument: NULL in 5 % of the calls. */
static int null_now(void) { return unif() < 0.05; }

/* In mismatch mode, rank 1 changes a collective double or int argument of
 * a call with probability 0.3 (decided from the shared stream, so that the
 * ranks know the call was perturbed). */
static int perturb_now = 0;
static double coll_d(double v) {
  if (mismatch && perturb_now && rank == 1) return v == 0 ? 0.25 : v * 1.5;
  return v;
}
static int coll_i(int v) {
  if (mismatch && perturb_now && rank == 1) return v + 1;
  return v;
}

/* ---------------------------------------------------------------- state */
typedef struct {
  double time;
  int64_t steps, local, global;
  int nlevels;
  double diag[5];
  uint64_t fields;
  int64_t nlost;
  uint64_t lost;
} Snap;

static void snap(GimletSim *s, Snap *o) {
  memset(o, 0, sizeof *o);
  gimlet_time(s, &o->time, &o->steps);
  gimlet_num_levels(s, &o->nlevels);
  gimlet_particle_count(s, &o->local, &o->global);
  gimlet_diagnostics(s, &o->diag[0], &o->diag[1], &o->diag[2], &o->diag[3], &o->diag[4]);
  uint64_t h = 0xcbf29ce484222325ULL;
  int64_t n = 0;
  gimlet_get_field(s, GIMLET_FIELD_POSITION, NULL, 0, &n);
  double *b = malloc((size_t)(4 * n + 4) * sizeof *b);
  static const int fl[] = {GIMLET_FIELD_POSITION, GIMLET_FIELD_VELOCITY, GIMLET_FIELD_STRESS,
                           GIMLET_FIELD_DEFGRAD,  GIMLET_FIELD_MASS,     GIMLET_FIELD_HALF_LENGTH,
                           GIMLET_FIELD_LEVEL,    GIMLET_FIELD_PLASTIC_STRAIN, GIMLET_FIELD_AFFINE};
  for (int f = 0; f < (int)(sizeof fl / sizeof fl[0]); f++) {
    int nc = 0;
    int64_t got = 0;
    gimlet_field_components(s, fl[f], &nc);
    gimlet_get_field(s, fl[f], b, n, &got);
    h = fnv(h, b, (size_t)(got * nc) * sizeof(double));
  }
  uint64_t *ids = malloc((size_t)(n + 1) * sizeof *ids);
  int64_t got = 0;
  gimlet_get_ids(s, ids, n, &got);
  h = fnv(h, ids, (size_t)got * 8);
  free(ids);
  free(b);
  o->fields = h;
  /* The lost list: ids and positions. */
  gimlet_lost_particles(s, NULL, NULL, 0, &o->nlost);
  uint64_t *lid = malloc((size_t)(o->nlost + 1) * sizeof *lid);
  double *lxy = malloc((size_t)(2 * o->nlost + 2) * sizeof *lxy);
  got = 0;
  gimlet_lost_particles(s, lid, lxy, o->nlost, &got);
  o->lost = fnv(fnv(0xcbf29ce484222325ULL, lid, (size_t)got * 8), lxy, (size_t)got * 16);
  free(lid);
  free(lxy);
}

static int same(const Snap *a, const Snap *b) {
  /* NaN diagnostics compare by their bits. */
  return a->time == b->time && a->steps == b->steps && a->local == b->local && a->global == b->global &&
         a->nlevels == b->nlevels && memcmp(a->diag, b->diag, sizeof a->diag) == 0 && a->fields == b->fields &&
         a->nlost == b->nlost && a->lost == b->lost;
}

/* ---------------------------------------------------------------- tallies */
enum { F_NAME, F_NO_ARG, F_CHANGED, F_STATUS, F_MESSAGE, F_INTERNAL, F_KINDS };
static const char *fail_names[F_KINDS] = {"message without the function name", "argument error naming no argument",
                                          "rejected call changed the state", "statuses differ between ranks",
                                          "messages differ between ranks", "internal error (caught panic)"};
static long fails[F_KINDS], calls = 0, status_count[16], step_failures = 0, step_failures_changed = 0,
                                     steps_undone = 0, perturbed = 0, perturbed_agreed = 0;

static void fail(int kind, const char *call, int rc, const char *msg) {
  fails[kind]++;
  if (fails[kind] <= 5)
    fprintf(stderr, "rank %d: FAILURE (%s) in %s -> %d: %s\n", rank, fail_names[kind], call, rc, msg);
}

/* True when `w` appears in `s` as a word (not inside a longer name). */
static int has_word(const char *s, const char *w) {
  size_t n = strlen(w);
  for (const char *p = strstr(s, w); p; p = strstr(p + 1, w)) {
    int before = p == s || !(isalnum((unsigned char)p[-1]) || p[-1] == '_');
    int after = !(isalnum((unsigned char)p[n]) || p[n] == '_');
    if (before && after) return 1;
  }
  return 0;
}

/* The name of the last call checked (for the timing report). */
static const char *last_call = "";

/* The checks of one call. `args` lists the function's argument names
 * (space separated); `collective` whether every rank made it; `stepping`
 * 1 for gimlet_step (a failure changes nothing), 2 for gimlet_advance_to
 * (a failure keeps the steps taken before it). */
static void check_call(const char *call, const char *args, int collective, int rc, const Snap *before,
                       GimletSim *sim, int stepping) {
  calls++;
  last_call = call;
  if (rc >= 0 && rc < 16) status_count[rc]++;
  char msg[1024];
  snprintf(msg, sizeof msg, "%s", rc == GIMLET_OK ? "" : last_error());
  if (rc != GIMLET_OK) {
    if (strncmp(msg, call, strlen(call)) != 0 || strlen(msg) < strlen(call) + 8) fail(F_NAME, call, rc, msg);
    if (rc == GIMLET_ERR_INVALID_ARGUMENT || rc == GIMLET_ERR_NULL_POINTER) {
      int named = 0;
      char buf[256];
      snprintf(buf, sizeof buf, "%s", args);
      for (char *t = strtok(buf, " "); t && !named; t = strtok(NULL, " ")) named = has_word(msg + strlen(call), t);
      if (!named) fail(F_NO_ARG, call, rc, msg);
    }
    if (rc == GIMLET_ERR_INTERNAL) fail(F_INTERNAL, call, rc, msg);
  }
  if (!collective) return;
  int rcs[2] = {rc, rc};
  if (size == 2) {
    MPI_Allgather(&rc, 1, MPI_INT, rcs, 1, MPI_INT, MPI_COMM_WORLD);
    static char all[2][1024];
    MPI_Allgather(msg, 1024, MPI_CHAR, all, 1024, MPI_CHAR, MPI_COMM_WORLD);
    if (rcs[0] != rcs[1]) fail(F_STATUS, call, rc, msg);
    else if (strcmp(all[0], all[1]) != 0) fail(F_MESSAGE, call, rc, msg);
  }
  if (mismatch && perturb_now) {
    perturbed++;
    perturbed_agreed += rcs[0] == rcs[1];
  }
  if (rc != GIMLET_OK && sim && before) {
    Snap after;
    snap(sim, &after);
    int changed = !same(before, &after);
    int any = changed;
    MPI_Allreduce(&changed, &any, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    /* A failed gimlet_step is undone: it must change nothing, like a
     * rejected call. gimlet_advance_to failing after some good steps, or
     * stopping after max_steps steps (documented: the steps taken stay),
     * is an outcome of stepping, not a rejection. */
    int stepped = rc == GIMLET_ERR_UNSTABLE || rc == GIMLET_ERR_PARTICLES_LEFT ||
                  (rc == GIMLET_ERR_INVALID_STATE && strstr(msg, "steps were taken") != NULL);
    if (stepping == 1 && stepped) steps_undone++;
    if (stepping == 2 && stepped) {
      step_failures++;
      step_failures_changed += any;
    } else if (any) {
      fail(F_CHANGED, call, rc, msg);
    }
  }
}

/* ---------------------------------------------------------------- the calls */
static char work[1024];

static GimletSim *make_sim(void) {
  GimletSim *s = NULL;
  double lx = (double)(2 << pick(3)), ly = (double)(2 << pick(2));
  double h = unif() < 0.9 ? 0.25 : arg_d(0.1, 1.0);
  perturb_now = mismatch && unif() < 0.3;
  int f = unif() < 0.5;
  int rc = f ? gimlet_create_f(MPI_Comm_c2f(MPI_COMM_WORLD), coll_d(0.0), 0.0, lx, ly, h, &s)
             : gimlet_create(MPI_COMM_WORLD, coll_d(0.0), 0.0, lx, ly, h, &s);
  check_call(f ? "gimlet_create_f" : "gimlet_create", "comm fcomm x0 y0 lx ly h out", 1, rc, NULL, NULL, 0);
  perturb_now = 0;
  if (rc != GIMLET_OK) {
    EXPECT_OK(gimlet_create(MPI_COMM_WORLD, 0, 0, lx, ly, 0.25, &s));
  }
  return s;
}

/* One random call on `*simp` (which it may replace). */
static void one_call(GimletSim **simp) {
  GimletSim *sim = *simp;
  Snap before;
  snap(sim, &before);
  int which = pick(50);
  /* The test's own invariant: every rank draws the same call. */
  int lo_hi[2] = {which, -which}, red[2];
  MPI_Allreduce(lo_hi, red, 2, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  if (red[0] != -red[1]) {
    fprintf(stderr, "fuzz_api: the ranks drew different calls (a bug of the test)\n");
    MPI_Abort(MPI_COMM_WORLD, 3);
  }
  perturb_now = mismatch && unif() < 0.3;
  int rc = 0;
  double d[8];
  int iv[4];
  int64_t cnt = 0;
  int id = 0;
  char path[1200];
#define CALL(name, args, coll, expr) do { rc = (expr); check_call(name, args, coll, rc, &before, sim, 0); } while (0)
  switch (which) {
  case 0: { /* local queries */
    int r = 0, n = 0;
    CALL("gimlet_comm_info", "sim rank size", 0, gimlet_comm_info(sim, null_now() ? NULL : &r, &n));
    break;
  }
  case 1: CALL("gimlet_num_levels", "sim nlevels", 0, gimlet_num_levels(sim, null_now() ? NULL : &iv[0])); break;
  case 2: {
    double hh;
    int nb, np;
    CALL("gimlet_level_info", "sim level", 0, gimlet_level_info(sim, arg_i(0, 3), &hh, &nb, &np));
    break;
  }
  case 3: {
    double bx[64];
    int64_t cap = arg_i(0, 16);
    CALL("gimlet_level_boxes", "sim level boxes capacity count", 0,
         gimlet_level_boxes(sim, arg_i(0, 3), null_now() ? NULL : bx, cap, null_now() ? NULL : &cnt));
    break;
  }
  case 4: {
    int64_t cells[4 * 4096];
    int own[4096];
    int64_t cap = arg_i(0, 4096);
    CALL("gimlet_level_patches", "sim level cells owner capacity count", 0,
         gimlet_level_patches(sim, arg_i(0, 3), null_now() ? NULL : cells, null_now() ? NULL : own, cap, &cnt));
    break;
  }
  case 5: CALL("gimlet_level_particle_count", "sim level local", 0, gimlet_level_particle_count(sim, arg_i(0, 3), &cnt)); break;
  case 6: CALL("gimlet_field_components", "sim fld field ncomp", 0, gimlet_field_components(sim, arg_i(0, 9), &iv[0])); break;
  case 7: {
    int64_t n = 0;
    gimlet_get_field(sim, 0, NULL, 0, &n);
    double *b = malloc((size_t)(4 * n + 8) * sizeof *b);
    int64_t cap = unif() < 0.8 ? n : n - 1 - pick(3);
    CALL("gimlet_get_field", "sim fld field out capacity count", 0,
         gimlet_get_field(sim, arg_i(0, 9), null_now() ? NULL : b, cap, &cnt));
    free(b);
    break;
  }
  case 8: {
    int64_t n = 0;
    gimlet_get_ids(sim, NULL, 0, &n);
    uint64_t *b = malloc((size_t)(n + 2) * sizeof *b);
    CALL("gimlet_get_ids", "sim ids capacity count", 0, gimlet_get_ids(sim, b, unif() < 0.8 ? n : n - 1, &cnt));
    free(b);
    break;
  }
  case 9: {
    int64_t n = 0;
    gimlet_lost_particles(sim, NULL, NULL, 0, &n);
    uint64_t *b = malloc((size_t)(n + 2) * sizeof *b);
    double *xy = malloc((size_t)(2 * n + 4) * sizeof *xy);
    CALL("gimlet_lost_particles", "sim ids xy capacity count", 0,
         gimlet_lost_particles(sim, b, xy, unif() < 0.8 ? n : n - 1, null_now() ? NULL : &cnt));
    free(b), free(xy);
    break;
  }
  case 10: {
    double t;
    CALL("gimlet_time", "sim time steps", 0, gimlet_time(sim, &t, &cnt));
    break;
  }
  case 11: {
    int a, b, c;
    rc = gimlet_version(&a, &b, &c);
    check_call("gimlet_version", "major minor patch", 0, rc, NULL, NULL, 0);
    char tiny[8];
    size_t need = 0;
    rc = gimlet_last_error(unif() < 0.1 ? NULL : tiny, (size_t)pick(9), &need);
    calls++;
    break;
  }
  /* Collective calls. */
  case 12: CALL("gimlet_set_thickness", "thickness", 1, gimlet_set_thickness(sim, coll_d(arg_d(0.1, 2)))); break;
  case 13:
  case 14: {
    double e = coll_d(arg_d(1e6, 1e11)), nu = arg_d(-0.5, 0.49), rho = arg_d(100, 1e4);
    if (which == 13)
      CALL("gimlet_add_material_linear_elastic", "e nu rho id", 1,
           gimlet_add_material_linear_elastic(sim, e, nu, rho, null_now() ? NULL : &id));
    else
      CALL("gimlet_add_material_neo_hookean", "e nu rho id", 1,
           gimlet_add_material_neo_hookean(sim, e, nu, rho, null_now() ? NULL : &id));
    break;
  }
  case 15: CALL("gimlet_set_nesting_buffer", "cells nest_buffer", 1, gimlet_set_nesting_buffer(sim, coll_i(arg_i(3, 8)))); break;
  case 16: {
    /* A box aligned to the current finest level's cells (mostly). */
    int nl = 1;
    gimlet_num_levels(sim, &nl);
    double hf = 0.25 / (1 << (nl - 1));
    double x0 = hf * (8 + pick(8)), y0 = hf * (8 + pick(4)), w = hf * (4 + pick(8)), hgt = hf * (4 + pick(8));
    /* Room for as many boxes as any accepted count (4096): the library can
     * only check counts, not the length of the caller's array. */
    static double box[4 * 4096];
    double first[8] = {coll_d(x0), y0, x0 + w, y0 + hgt, arg_d(0, 4), arg_d(0, 4), arg_d(0, 8), arg_d(0, 8)};
    memcpy(box, first, sizeof first);
    int nb = unif() < 0.85 ? 1 : arg_i(1, 2);
    CALL("gimlet_add_level", "boxes nboxes nest_buffer", 1, gimlet_add_level(sim, null_now() ? NULL : box, nb));
    break;
  }
  case 17: CALL("gimlet_set_patch_size", "level px py", 1, gimlet_set_patch_size(sim, arg_i(0, 2), coll_i(arg_i(2, 32)), arg_i(2, 32))); break;
  case 18: {
    /* Per-rank particle arrays. */
    if (before.global > 20000) break;
    int n = unif_local() < 0.3 ? 0 : (int)(unif_local() * 8);
    double x[8], y[8], lp[8], vx[8], vy[8], m[8];
    int mt[8];
    for (int k = 0; k < n; k++) {
      x[k] = 0.3 + 1.5 * unif_local();
      y[k] = 0.3 + 1.5 * unif_local();
      lp[k] = unif_local() < 0.9 ? 0.05 : arg_d_local(0, 0.2);
      vx[k] = unif_local() < 0.95 ? unif_local() - 0.5 : arg_d_local(-1, 1);
      vy[k] = 0;
      m[k] = unif_local() < 0.95 ? 10 * lp[k] * lp[k] * 1000 : arg_d_local(0, 1);
      mt[k] = unif_local() < 0.95 ? 0 : arg_i_local(0, 2);
    }
    int use_mass = unif() < 0.5;
    CALL("gimlet_insert_particles", "n x y lpx lpy vx vy mass density material", 1,
         gimlet_insert_particles(sim, unif_local() < 0.05 ? -1 : n, x, y, lp, lp, vx, vy, use_mass ? m : NULL,
                                 use_mass ? NULL : m, mt));
    break;
  }
  case 19: {
    if (before.global > 20000) break;
    double xl = arg_d(0, 2), yl = arg_d(0, 2);
    double xh = xl + arg_d(0.2, 2), yh = yl + arg_d(0.2, 1);
    int64_t added = 0;
    CALL("gimlet_fill_rectangle", "xlo ylo xhi yhi rect n_per_cell material density vx vy", 1,
         gimlet_fill_rectangle(sim, coll_d(xl), yl, xh, yh, arg_i(1, 3), arg_i(0, 1), arg_d(500, 5000),
                               arg_d(-2, 2), arg_d(-2, 2), null_now() ? NULL : &added));
    break;
  }
  case 20: {
    int64_t l = 0, g = 0;
    CALL("gimlet_particle_count", "local global", 1, gimlet_particle_count(sim, &l, &g));
    break;
  }
  case 21: {
    int fld = coll_i(unif() < 0.8 ? (unif() < 0.5 ? GIMLET_FIELD_VELOCITY : GIMLET_FIELD_STRESS) : arg_i(0, 9));
    int64_t n = before.local;
    int nc = fld == GIMLET_FIELD_STRESS ? 4 : 2;
    double *v = malloc((size_t)(nc * n + 8) * sizeof *v);
    for (int64_t k = 0; k < nc * n + 8; k++) v[k] = unif_local() < 0.999 ? unif_local() - 0.5 : arg_d_local(-1, 1);
    int64_t nn = unif_local() < 0.95 ? n : n + 1;
    CALL("gimlet_set_field", "fld field values n", 1, gimlet_set_field(sim, fld, null_now() ? NULL : v, nn));
    free(v);
    break;
  }
  case 22: CALL("gimlet_diagnostics", "kinetic strain", 1, gimlet_diagnostics(sim, &d[0], &d[1], NULL, &d[3], &d[4])); break;
  case 23: CALL("gimlet_patch_crossings", "crossings", 1, gimlet_patch_crossings(sim, null_now() ? NULL : &cnt)); break;
  case 24: CALL("gimlet_set_shape", "shape", 1, gimlet_set_shape(sim, coll_i(arg_i(0, 2)))); break;
  case 25: CALL("gimlet_set_scheme", "scheme", 1, gimlet_set_scheme(sim, coll_i(arg_i(0, 2)))); break;
  case 26: CALL("gimlet_set_flip", "flip", 1, gimlet_set_flip(sim, coll_d(arg_d(0, 1)))); break;
  case 47:
    if (unif() < 0.5)
      CALL("gimlet_set_transfer", "transfer", 1, gimlet_set_transfer(sim, coll_i(arg_i(0, 2))));
    else
      CALL("gimlet_set_xpic_order", "order", 1, gimlet_set_xpic_order(sim, coll_i(arg_i(1, 16))));
    break;
  case 27: CALL("gimlet_set_cfl", "cfl", 1, gimlet_set_cfl(sim, coll_d(arg_d(0.05, 1)))); break;
  case 28: CALL("gimlet_set_gravity", "gx gy gravity", 1, gimlet_set_gravity(sim, coll_d(arg_d(-10, 10)), arg_d(-10, 10))); break;
  case 29: CALL("gimlet_set_face_bc", "face bc", 1, gimlet_set_face_bc(sim, coll_i(arg_i(0, 3)), arg_i(0, 2))); break;
  case 30: CALL("gimlet_set_load_ramp", "t_ramp", 1, gimlet_set_load_ramp(sim, coll_d(arg_d(0, 1e-3)))); break;
  case 31: CALL("gimlet_set_outflow", "policy", 1, gimlet_set_outflow(sim, coll_i(arg_i(0, 1)))); break;
  case 32: {
    int64_t loaded = 0;
    CALL("gimlet_apply_traction", "face at lo hi tx ty traction", 1,
         gimlet_apply_traction(sim, arg_i(0, 3), coll_d(arg_d(0, 2)), arg_d(0, 1), arg_d(1, 2), arg_d(-1e5, 1e5),
                               arg_d(-1e5, 1e5), &loaded));
    break;
  }
  case 48: {
    int64_t loaded = 0;
    CALL("gimlet_apply_follower_traction", "face at lo hi tx ty follow traction", 1,
         gimlet_apply_follower_traction(sim, arg_i(0, 3), coll_d(arg_d(0, 2)), arg_d(0, 1), arg_d(1, 2),
                                        arg_d(-1e5, 1e5), arg_d(-1e5, 1e5), arg_i(0, 1), &loaded));
    break;
  }
  case 33: CALL("gimlet_stable_dt", "dt", 1, gimlet_stable_dt(sim, null_now() ? NULL : &d[0])); break;
  case 34:
  case 35:
  case 36: {
    double sdt = 0;
    gimlet_stable_dt(sim, &sdt); /* collective, same everywhere */
    double dt = unif() < 0.5 ? 0.0 : (unif() < 0.8 ? sdt * arg_d(0.1, 1.0) : arg_d(-1, 1));
    if (!isfinite(sdt)) dt = unif() < 0.5 ? 0.0 : arg_d(1e-6, 1e-3);
    rc = gimlet_step(sim, coll_d(dt), &d[0], &cnt);
    check_call("gimlet_step", "dt", 1, rc, &before, sim, 1);
    break;
  }
  case 37: {
    double sdt = 0, t = 0;
    gimlet_stable_dt(sim, &sdt);
    gimlet_time(sim, &t, NULL);
    /* t_end (in stable steps) and max_steps are drawn apart, boundary
     * values included, but never both large in one call: t_end 1e30 stable
     * steps away with max_steps 2^24 or INT_MAX is a legal request for up
     * to 2^31 steps, which the library carries out step by step (forced
     * into this test's states, one such call took 2 million steps and 58 s
     * on 2 ranks; XPIC(16) makes a step about 5 times dearer), while the
     * time budget is checked between calls. So a max_steps above 65 comes
     * with t_end at most 4 stable steps away, and a farther t_end with at
     * most 65 steps: the work of one call stays bounded, and every kind of
     * argument is still drawn. */
    int max_steps = arg_i(1, 8);
    double span = arg_d(0, 4);
    if (max_steps > 65 && isfinite(span) && span > 4) span = 4 * unif();
    double te = t + (isfinite(sdt) ? sdt * span : arg_d(0, 1e-3));
    rc = gimlet_advance_to(sim, coll_d(te), max_steps, &d[0], &cnt);
    check_call("gimlet_advance_to", "t_end max_steps", 1, rc, &before, sim, 2);
    break;
  }
  case 38:
    snprintf(path, sizeof path, "%s/out%d", work, pick(2));
    CALL("gimlet_output_open", "dir basename", 1,
         gimlet_output_open(sim, null_now() ? NULL : path, unif() < 0.9 ? "fz" : (unif() < 0.5 ? "a/b" : "")));
    break;
  case 39: CALL("gimlet_write_output", "", 1, gimlet_write_output(sim)); break;
  case 40:
    snprintf(path, sizeof path, "%s/out%d/fz.xdmf", work, pick(2));
    CALL("gimlet_check_xdmf", "path items", 1, gimlet_check_xdmf(sim, path, null_now() ? NULL : &cnt));
    break;
  case 41:
    snprintf(path, sizeof path, "%s/series%d.csv", work, pick(2));
    CALL("gimlet_csv_open", "path", 1, gimlet_csv_open(sim, null_now() ? NULL : path));
    break;
  case 42: CALL("gimlet_csv_append", "", 1, gimlet_csv_append(sim)); break;
  case 43:
    snprintf(path, sizeof path, "%s/ck%d.h5", work, pick(2));
    CALL("gimlet_write_checkpoint", "path", 1, gimlet_write_checkpoint(sim, null_now() ? NULL : path));
    break;
  case 44:
    snprintf(path, sizeof path, "%s/%s", work, unif() < 0.8 ? "ck0.h5" : (unif() < 0.5 ? "missing.h5" : "series0.csv"));
    CALL("gimlet_read_checkpoint", "path", 1, gimlet_read_checkpoint(sim, path));
    break;
  case 45: {
    snprintf(path, sizeof path, "%s/%s", work, unif() < 0.8 ? "ck0.h5" : "missing.h5");
    GimletSim *s2 = NULL;
    int f = unif() < 0.5;
    rc = f ? gimlet_create_from_checkpoint_f(MPI_Comm_c2f(MPI_COMM_WORLD), path, null_now() ? NULL : &s2)
           : gimlet_create_from_checkpoint(MPI_COMM_WORLD, path, null_now() ? NULL : &s2);
    check_call(f ? "gimlet_create_from_checkpoint_f" : "gimlet_create_from_checkpoint", "comm fcomm path out", 1, rc,
               &before, sim, 0);
    if (s2) {
      /* Sometimes carry on with the restored handle. */
      if (unif() < 0.5) {
        gimlet_destroy(simp);
        *simp = s2;
      } else {
        gimlet_destroy(&s2);
      }
    }
    break;
  }
  case 46: {
    /* Start over with a fresh handle (destroy is collective, no argument). */
    if (unif() < 0.3) {
      gimlet_destroy(simp);
      *simp = make_sim();
    }
    break;
  }
  default: {
    /* A NULL handle on a random call: rejected at once on every rank. */
    rc = gimlet_step(NULL, 0, NULL, NULL);
    check_call("gimlet_step", "sim", 1, rc, NULL, NULL, 0);
    break;
  }
  }
#undef CALL
  perturb_now = 0;
  /* An internal error leaves the handle unusable: start over. */
  if (rc == GIMLET_ERR_INTERNAL) {
    gimlet_destroy(simp);
    *simp = make_sim();
  }
}

int main(int argc, char **argv) {
  check_begin(&argc, &argv);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  snprintf(work, sizeof work, "%s", argc > 1 ? argv[1] : "fuzz-out");
  double budget = argc > 2 ? atof(argv[2]) : 45.0;
  mismatch = argc > 3 && strcmp(argv[3], "mismatch") == 0 && size == 2;
  uint64_t seed = (uint64_t)time(NULL) ^ ((uint64_t)getpid() << 20);
  const char *env = getenv("GIMLET_FUZZ_SEED");
  if (env) seed = strtoull(env, NULL, 10);
  MPI_Bcast(&seed, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
  rng = seed ? seed : 1;
  rng_local = (seed ^ (0x9E3779B97F4A7C15ULL * (uint64_t)(rank + 1))) | 1;
  if (rank == 0) {
    char cmd[2200];
    /* The files a run writes are removed first: a checkpoint left by an
     * earlier run would be read before this run writes its own, and the
     * seed would no longer replay the run. */
    snprintf(cmd, sizeof cmd, "mkdir -p '%s' && cd '%s' && rm -rf ck0.h5 ck1.h5 series0.csv series1.csv out0 out1",
             work, work);
    if (system(cmd) != 0) MPI_Abort(MPI_COMM_WORLD, 2);
    printf("fuzz_api: seed %llu (replay with GIMLET_FUZZ_SEED=%llu), %d rank(s)%s, %.0f s\n", (unsigned long long)seed,
           (unsigned long long)seed, size, mismatch ? ", mismatch mode" : "", budget);
    fflush(stdout);
  }
  MPI_Barrier(MPI_COMM_WORLD);
  double t0 = MPI_Wtime();
  GimletSim *sim = make_sim();
  /* The budget is checked between calls: it holds as long as every call's
   * work is bounded. The slowest call is reported; GIMLET_FUZZ_SLOW=<s>
   * prints every call slower than s seconds as it happens. */
  const char *slow_env = getenv("GIMLET_FUZZ_SLOW");
  double slow = slow_env ? atof(slow_env) : -1, slowest = 0;
  const char *slowest_call = "none";
  long slowest_at = 0;
  for (;;) {
    int go = MPI_Wtime() - t0 < budget;
    MPI_Bcast(&go, 1, MPI_INT, 0, MPI_COMM_WORLD);
    if (!go) break;
    double tc = MPI_Wtime();
    last_call = "(none checked)";
    one_call(&sim);
    double dt = MPI_Wtime() - tc;
    if (dt > slowest) slowest = dt, slowest_call = last_call, slowest_at = calls;
    if (slow >= 0 && dt > slow && rank == 0)
      fprintf(stderr, "fuzz_api: call %ld (%s) took %.2f s, at %.1f s\n", calls, last_call, dt, MPI_Wtime() - t0);
  }
  gimlet_destroy(&sim);

  long total_fail = g_failures; /* the set-up's checks */
  for (int k = 0; k < F_KINDS; k++) total_fail += fails[k];
  long all_fail = 0;
  MPI_Allreduce(&total_fail, &all_fail, 1, MPI_LONG, MPI_SUM, MPI_COMM_WORLD);
  if (rank == 0) {
    long rejected = calls - status_count[0];
    printf("fuzz_api: %ld calls in %.1f s, %ld rejected or failed (", calls, MPI_Wtime() - t0, rejected);
    for (int k = 1; k < 16; k++)
      if (status_count[k]) printf("%sstatus %d: %ld", k > 1 ? ", " : "", k, status_count[k]);
    printf(")\n");
    printf("fuzz_api: gimlet_step calls that failed while stepping (UNSTABLE / PARTICLES_LEFT) and were undone, the state checked unchanged: %ld\n",
           steps_undone);
    printf("fuzz_api: gimlet_advance_to calls that failed while stepping or stopped at max_steps: %ld, of which %ld after some good steps (kept)\n",
           step_failures, step_failures_changed);
    if (mismatch) printf("fuzz_api: %ld calls with a collective argument changed on rank 1, %ld with the same status on both ranks\n", perturbed, perturbed_agreed);
    printf("fuzz_api: slowest call (rank 0): %s, %.2f s (call %ld)\n", slowest_call, slowest, slowest_at);
    printf("fuzz_api: failures by kind (rank 0):");
    for (int k = 0; k < F_KINDS; k++) printf(" %s = %ld;", fail_names[k], fails[k]);
    printf("\nfuzz_api: %ld failure(s) on all ranks\n", all_fail);
  }
  MPI_Finalize();
  return all_fail == 0 ? 0 : 1;
}
