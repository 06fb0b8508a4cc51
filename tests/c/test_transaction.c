/* Transactional steps and level transfers (issue "Never abort, never hang,
 * never lose the state", items 2, 3 and 7), on 1 and 2 ranks:
 *
 *   1. a step that fails changes nothing: a block with a nonuniform velocity
 *      field crosses a refined level towards the right side of the domain;
 *      after 45 good steps (the snapshot the library keeps is then 13 steps
 *      old, so undoing replays them) a step of the largest allowed dt would
 *      move particles out of the domain and fails with
 *      GIMLET_ERR_PARTICLES_LEFT under GIMLET_OUTFLOW_FAIL. Every particle
 *      field gathered through the C API (and the ids, counts, lost list,
 *      diagnostics, time and step count) is bitwise as before the call, on
 *      every rank, and so is the contact state of a cylinder pressing a
 *      second block meanwhile (pressures, indenter force and contacts).
 *      Retrying with a smaller dt succeeds and gives bitwise the state of a
 *      run that never failed;
 *   2. the same with a step that fails with GIMLET_ERR_UNSTABLE: a
 *      linear-elastic block of two levels under an initial tension of 100 E
 *      (set through gimlet_set_field) pulls its free edges in; after 40
 *      steps of 1/1000 of the stable step (8 to replay), a step of the
 *      stable size inverts the deformation gradient at the edges. The
 *      message names the particle id, level and patch; the state is
 *      bitwise unchanged; a retry at half the step succeeds and equals a
 *      run that never failed;
 *   3. level transfers never lose a particle: the reproducer of the
 *      internal error "particle 155 left level 1 and lies in no patch of
 *      level 0" (USF, 2 levels, a fill crossing the fine box at the domain
 *      edge, two stable steps): under GIMLET_OUTFLOW_REMOVE both steps
 *      succeed and particles + lost = initial (globally); under
 *      GIMLET_OUTFLOW_FAIL a step whose particles would leave fails with
 *      PARTICLES_LEFT on every rank and changes nothing;
 *   4. the first mapping a step prepares for the next one (one level: the
 *      last pass of a step also scatters the next step's first P2G) gives
 *      the answers of separate passes: for USF, USL and MUSL, a one-level
 *      scene of 4 x 4-cell patches that a fast, deforming block with a
 *      ramped traction crosses (hundreds of patch crossings) runs twice,
 *      plain and with a call that changes nothing before every step
 *      (gimlet_set_gravity with the same values: every call that is not a
 *      step forgets the prepared mapping, so that run maps separately);
 *      the two are bitwise equal after 45 steps, after a step that fails
 *      (PARTICLES_LEFT, undone: the snapshot's grids come back with the
 *      rest) and a retry at a smaller dt.
 * Prints one line per section; exits non-zero on any failed check.
 * Usage: test_transaction [flip|xpic|axisym]. Without an argument the scenes run
 * with the library's defaults (cpGIMP weights, the affine transfer
 * GIMLET_TRANSFER_APIC, whose per-particle matrix, GIMLET_FIELD_AFFINE,
 * compared with the other fields, must be undone with the rest of a failed
 * step); section 3's reproducer always runs with the weights and transfer
 * it was filed with (uGIMP, FLIP; see transfer_scene). With "flip" every
 * scene runs with uGIMP weights and the FLIP transfer (the paper's). With
 * "xpic" every scene runs with GIMLET_TRANSFER_XPIC (order 3, FLIP fraction
 * 0.5): its extra particle passes and sums over shared nodes run on every
 * patch and level, and a failed step must be undone all the same. With
 * "axisym" sections 2 and 4 run in axisymmetry (x the radius), the hoop
 * stretches compared with the other fields. */
#include <math.h>
#include <mpi.h>
#include <stdint.h>
#include <string.h>
#include "check.h"

static int rank = 0, size = 1;
/* Run every scene with uGIMP weights and GIMLET_TRANSFER_FLIP ("flip"
 * argument). */
static int g_flip = 0;
/* Run every scene with GIMLET_TRANSFER_XPIC ("xpic" argument). */
static int g_xpic = 0;
/* Run scenes 2 and 4 in axisymmetry ("axisym" argument: x the radius; the
 * hoop stretches are then part of the state a failed step must keep). */
static int g_axisym = 0;

/* The geometry the arguments chose (right after gimlet_create). */
static void set_geometry(GimletSim *s) {
  if (g_axisym) EXPECT_OK(gimlet_set_geometry(s, GIMLET_AXISYMMETRIC));
}

/* The transfer the arguments chose. */
static void set_transfer(GimletSim *s) {
  if (g_flip) {
    EXPECT_OK(gimlet_set_shape(s, GIMLET_SHAPE_UGIMP));
    EXPECT_OK(gimlet_set_transfer(s, GIMLET_TRANSFER_FLIP));
  }
  if (g_xpic) {
    EXPECT_OK(gimlet_set_transfer(s, GIMLET_TRANSFER_XPIC));
    EXPECT_OK(gimlet_set_xpic_order(s, 3));
    EXPECT_OK(gimlet_set_flip(s, 0.5));
  }
}

/* Every rank agrees that `cond` holds. */
static void all_true(int cond, const char *what) {
  int bad = !cond, any = 0;
  MPI_Allreduce(&bad, &any, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  g_checks++;
  if (any) {
    if (bad) fprintf(stderr, "rank %d: %s\n", rank, what);
    if (rank == 0) g_failures++;
  }
}

/* Everything a caller can see of a handle's state on this rank. */
typedef struct {
  double time;
  int64_t steps, local, global, nlost;
  double diag[5];
  size_t n; /* bytes in `bytes` */
  unsigned char *bytes;
} State;

static void append(State *s, const void *p, size_t n) {
  s->bytes = realloc(s->bytes, s->n + n + 1);
  memcpy(s->bytes + s->n, p, n);
  s->n += n;
}

static void capture(GimletSim *sim, State *s) {
  memset(s, 0, sizeof *s);
  EXPECT_OK(gimlet_time(sim, &s->time, &s->steps));
  EXPECT_OK(gimlet_particle_count(sim, &s->local, &s->global));
  EXPECT_OK(gimlet_diagnostics(sim, &s->diag[0], &s->diag[1], &s->diag[2], &s->diag[3], &s->diag[4]));
  const int fields[] = {GIMLET_FIELD_POSITION, GIMLET_FIELD_VELOCITY, GIMLET_FIELD_STRESS,  GIMLET_FIELD_STRAIN,
                        GIMLET_FIELD_DEFGRAD,  GIMLET_FIELD_HALF_LENGTH, GIMLET_FIELD_MASS, GIMLET_FIELD_LEVEL,
                        GIMLET_FIELD_VOLUME0,  GIMLET_FIELD_REFERENCE, GIMLET_FIELD_PLASTIC_STRAIN,
                        GIMLET_FIELD_CONTACT_PRESSURE, GIMLET_FIELD_AFFINE, GIMLET_FIELD_HOOP_STRETCH};
  for (size_t k = 0; k < sizeof fields / sizeof fields[0]; k++) {
    int nc = 0;
    int64_t m = 0;
    EXPECT_OK(gimlet_field_components(sim, fields[k], &nc));
    EXPECT_OK(gimlet_get_field(sim, fields[k], NULL, 0, &m));
    double *v = malloc(sizeof(double) * (size_t)(nc * m + 1));
    EXPECT_OK(gimlet_get_field(sim, fields[k], v, m, &m));
    append(s, &m, sizeof m);
    append(s, v, sizeof(double) * (size_t)(nc * m));
    free(v);
  }
  int64_t m = 0;
  EXPECT_OK(gimlet_get_ids(sim, NULL, 0, &m));
  uint64_t *ids = malloc(sizeof(uint64_t) * (size_t)(m + 1));
  EXPECT_OK(gimlet_get_ids(sim, ids, m, &m));
  append(s, ids, sizeof(uint64_t) * (size_t)m);
  free(ids);
  EXPECT_OK(gimlet_lost_particles(sim, NULL, NULL, 0, &s->nlost));
  ids = malloc(sizeof(uint64_t) * (size_t)(s->nlost + 1));
  double *xy = malloc(sizeof(double) * (size_t)(2 * s->nlost + 1));
  EXPECT_OK(gimlet_lost_particles(sim, ids, xy, s->nlost, &m));
  append(s, ids, sizeof(uint64_t) * (size_t)m);
  append(s, xy, sizeof(double) * (size_t)(2 * m));
  free(ids);
  free(xy);
}

/* Bitwise equality of two captured states (on this rank). */
static int same(const State *a, const State *b) {
  return memcmp(&a->time, &b->time, sizeof a->time) == 0 && a->steps == b->steps && a->local == b->local &&
         a->global == b->global && a->nlost == b->nlost && memcmp(a->diag, b->diag, sizeof a->diag) == 0 &&
         a->n == b->n && memcmp(a->bytes, b->bytes, a->n) == 0;
}

static void release(State *s) {
  free(s->bytes);
  s->bytes = NULL;
}

/* Retries the failed step of `a` with dt halved until it succeeds (down
 * to `fmin` dt), each failure with status `fail`; `b` (which never failed)
 * takes the step that succeeds. Returns whether one did. */
static int retry_smaller(GimletSim *a, GimletSim *b, double dt, double fmin, int fail) {
  for (double f = 0.5; f > fmin; f *= 0.5) {
    int rc = gimlet_step(a, f * dt, NULL, NULL);
    if (rc == GIMLET_OK) {
      EXPECT_OK(gimlet_step(b, f * dt, NULL, NULL));
      return 1;
    }
    EXPECT_TRUE(rc == fail);
  }
  return 0;
}

/* Whether `a` and `b` hold the same state (bitwise); `sa`, `sb` receive
 * their states. */
static int same_runs(GimletSim *a, GimletSim *b, State *sa, State *sb) {
  capture(a, sa);
  capture(b, sb);
  return same(sa, sb);
}

/* Frees a case's states and handles. */
static void finish(State *s, int n, GimletSim **a, GimletSim **b) {
  for (int k = 0; k < n; k++) release(&s[k]);
  EXPECT_OK(gimlet_destroy(a));
  EXPECT_OK(gimlet_destroy(b));
}

/* ------------------------------------------------------------ 1. outflow */

/* Gives every particle of `s` the velocity (20 + sin 3y, 0.2 cos 2x): a
 * flight to the right, sheared, that crosses patches and levels. */
static void wavy_velocity(GimletSim *s) {
  int64_t m = 0;
  EXPECT_OK(gimlet_get_field(s, GIMLET_FIELD_POSITION, NULL, 0, &m));
  double *x = malloc(sizeof(double) * (size_t)(2 * m + 2)), *v = malloc(sizeof(double) * (size_t)(2 * m + 2));
  EXPECT_OK(gimlet_get_field(s, GIMLET_FIELD_POSITION, x, m, &m));
  for (int64_t i = 0; i < m; i++) {
    v[2 * i] = 20.0 + 1.0 * sin(3.0 * x[2 * i + 1]);
    v[2 * i + 1] = 0.2 * cos(2.0 * x[2 * i]);
  }
  EXPECT_OK(gimlet_set_field(s, GIMLET_FIELD_VELOCITY, v, m));
  free(x);
  free(v);
}

/* A 2-level scene: 8 x 4 domain, cells of 0.25, refined on [2, 6] x [0, 2],
 * a block on [0.5, 3] x [0.25, 1.5] moving right at 20 (about 20 times
 * its wave speed, so the motion and not the waves sets the stable step),
 * its velocity varied with height so that it deforms. */
static GimletSim *outflow_scene(void) {
  GimletSim *s = NULL;
  EXPECT_OK(gimlet_create(MPI_COMM_WORLD, 0, 0, 8, 4, 0.25, &s));
  set_transfer(s);
  double box[4] = {2, 0, 6, 2};
  EXPECT_OK(gimlet_add_level(s, box, 1));
  EXPECT_OK(gimlet_set_patch_size(s, 0, 8, 8));
  EXPECT_OK(gimlet_set_patch_size(s, 1, 8, 8));
  int id = -1;
  EXPECT_OK(gimlet_add_material_neo_hookean(s, 1e3, 0.3, 1000, &id));
  EXPECT_OK(gimlet_fill_rectangle(s, 0.5, 0.25, 3, 1.5, 2, id, 1000, 20.0, 0.0, NULL));
  wavy_velocity(s);
  /* A second block at rest, pressed by a cylinder moving down at 1. */
  EXPECT_OK(gimlet_fill_rectangle(s, 3, 2.25, 5, 3.25, 2, id, 1000, 0, 0, NULL));
  int ind = -1;
  EXPECT_OK(gimlet_add_indenter_cylinder(s, 0.5, 4.0, 3.3, &ind));
  double t0 = 0, v0 = 1.0;
  EXPECT_OK(gimlet_set_indenter_motion(s, ind, GIMLET_MOTION_VELOCITY, 1, &t0, &v0));
  return s;
}

/* The indenter's state, for bitwise comparison. */
static void indenter(GimletSim *s, double out[5]) {
  int64_t n = 0;
  EXPECT_OK(gimlet_indenter_state(s, 0, &out[0], &out[1], &out[2], &n));
  out[4] = (double)n;
}

/* `n` steps of `frac` times the stable step. */
static int steps(GimletSim *s, int n, double frac) {
  for (int k = 0; k < n; k++) {
    double dt = 0;
    if (gimlet_stable_dt(s, &dt) != GIMLET_OK) return -1;
    int rc = gimlet_step(s, frac * dt, NULL, NULL);
    if (rc != GIMLET_OK) return rc;
  }
  return GIMLET_OK;
}

static void outflow(void) {
  int n0 = g_failures;
  GimletSim *a = outflow_scene(), *b = outflow_scene();
  /* 45 good steps: the snapshot is taken at step 32, 13 steps to replay. */
  EXPECT_OK(steps(a, 45, 0.25));
  EXPECT_OK(steps(b, 45, 0.25));
  /* Steps of the largest allowed dt until one fails (particles would
   * leave at x = 8); b takes the same good steps. */
  int rc = GIMLET_OK, good = 0;
  State before, after;
  memset(&before, 0, sizeof before);
  double dt = 0, ind_before[5], ind_after[5];
  for (int k = 0; k < 400 && rc == GIMLET_OK; k++) {
    release(&before);
    capture(a, &before);
    indenter(a, ind_before);
    EXPECT_OK(gimlet_stable_dt(a, &dt));
    rc = gimlet_step(a, dt, NULL, NULL);
    if (rc == GIMLET_OK) {
      EXPECT_OK(gimlet_step(b, dt, NULL, NULL));
      good++;
    }
  }
  all_true(rc == GIMLET_ERR_PARTICLES_LEFT, "a step of the stable size fails with GIMLET_ERR_PARTICLES_LEFT");
  all_true(message_names("undone"), "the PARTICLES_LEFT message says the step was undone");
  capture(a, &after);
  all_true(same(&before, &after), "the failed step (PARTICLES_LEFT) changed nothing (bitwise)");
  all_true(after.nlost == 0, "no particle was recorded as lost");
  indenter(a, ind_after);
  double touching = ind_before[4];
  all_true(touching > 0, "the cylinder is in contact when the step fails");
  all_true(memcmp(ind_before, ind_after, sizeof ind_before) == 0, "the indenter's state is unchanged (bitwise)");
  /* A second failure from the same state fails the same way. */
  EXPECT_STATUS(gimlet_step(a, dt, NULL, NULL), GIMLET_ERR_PARTICLES_LEFT, "undone");
  release(&after);
  capture(a, &after);
  all_true(same(&before, &after), "a second failed step changed nothing (bitwise)");
  /* Retry with smaller steps: a and b (never failed) take them alike. */
  all_true(retry_smaller(a, b, dt, 1e-3, GIMLET_ERR_PARTICLES_LEFT), "a retry with a smaller dt succeeds");
  State st[4] = {before, after};
  all_true(same_runs(a, b, &st[2], &st[3]), "the retried run equals the run that never failed (bitwise)");
  indenter(a, ind_after);
  indenter(b, ind_before);
  all_true(memcmp(ind_before, ind_after, sizeof ind_before) == 0, "so does the indenter's state (bitwise)");
  /* With GIMLET_OUTFLOW_REMOVE the particles go and are recorded. */
  EXPECT_OK(gimlet_set_outflow(a, GIMLET_OUTFLOW_REMOVE));
  EXPECT_OK(gimlet_stable_dt(a, &dt));
  EXPECT_OK(gimlet_step(a, dt, NULL, NULL));
  int64_t loc = 0, glob = 0, nl = 0, nlg = 0;
  EXPECT_OK(gimlet_particle_count(a, &loc, &glob));
  EXPECT_OK(gimlet_lost_particles(a, NULL, NULL, 0, &nl));
  MPI_Allreduce(&nl, &nlg, 1, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);
  all_true(nlg > 0 && glob + nlg == st[2].global, "under REMOVE the particles that left are recorded (count + lost = initial)");
  if (rank == 0)
    printf("outflow: %d good steps of the stable size after 45 small ones, then PARTICLES_LEFT with nothing changed (%g particles under the cylinder), a retry at a smaller dt bitwise equal to a run that never failed; REMOVE recorded %lld lost; %s\n",
           good, touching, (long long)nlg, g_failures == n0 ? "ok" : "FAILED");
  finish(st, 4, &a, &b);
}

/* ------------------------------------------------------------ 2. unstable */

/* A linear-elastic block across two levels under an initial tension of
 * 100 E (the stress of the Jaumann-rate law persists), edges free. */
static GimletSim *tension_scene(void) {
  GimletSim *s = NULL;
  EXPECT_OK(gimlet_create(MPI_COMM_WORLD, 0, 0, 8, 4, 0.25, &s));
  set_geometry(s);
  set_transfer(s);
  double box[4] = {2, 1, 6, 3};
  EXPECT_OK(gimlet_add_level(s, box, 1));
  EXPECT_OK(gimlet_set_patch_size(s, 0, 8, 8));
  EXPECT_OK(gimlet_set_patch_size(s, 1, 8, 8));
  int id = -1;
  EXPECT_OK(gimlet_add_material_linear_elastic(s, 1e3, 0.3, 1000, &id));
  EXPECT_OK(gimlet_fill_rectangle(s, 1.0, 1.5, 7.0, 2.5, 2, id, 1000, 0.0, 0.0, NULL));
  int64_t m = 0;
  EXPECT_OK(gimlet_get_field(s, GIMLET_FIELD_POSITION, NULL, 0, &m));
  double *sg = malloc(sizeof(double) * (size_t)(4 * m + 4));
  for (int64_t i = 0; i < m; i++) {
    sg[4 * i] = sg[4 * i + 1] = 1e5;
    sg[4 * i + 2] = sg[4 * i + 3] = 0;
  }
  EXPECT_OK(gimlet_set_field(s, GIMLET_FIELD_STRESS, sg, m));
  free(sg);
  return s;
}

static void unstable(void) {
  int n0 = g_failures;
  GimletSim *a = tension_scene(), *b = tension_scene();
  /* 40 small steps (snapshot at 32, 8 to replay). */
  EXPECT_OK(steps(a, 40, 0.001));
  EXPECT_OK(steps(b, 40, 0.001));
  State before, after;
  capture(a, &before);
  double dt = 0;
  EXPECT_OK(gimlet_stable_dt(a, &dt));
  int rc = gimlet_step(a, dt, NULL, NULL);
  all_true(rc == GIMLET_ERR_UNSTABLE, "a step of the stable size fails with GIMLET_ERR_UNSTABLE");
  if (rc == GIMLET_ERR_UNSTABLE) {
    const char *m = last_error();
    /* The message names the particle, level and patch (on the failing rank;
     * on another rank it says "failed on rank r"). */
    all_true(strstr(m, "particle id") != NULL && strstr(m, "level") != NULL && strstr(m, "patch") != NULL,
             "the UNSTABLE message names the particle id, level and patch");
    if (rank == 0) printf("unstable: message: %s\n", m);
  }
  capture(a, &after);
  all_true(same(&before, &after), "the failed step (UNSTABLE) changed nothing (bitwise)");
  /* Retry smaller; b (never failed) takes the same step. */
  all_true(retry_smaller(a, b, dt, 1e-4, GIMLET_ERR_UNSTABLE), "a retry with a smaller dt succeeds");
  /* A few more steps on both. */
  EXPECT_OK(steps(a, 5, 0.01));
  EXPECT_OK(steps(b, 5, 0.01));
  State st[4] = {before, after};
  all_true(same_runs(a, b, &st[2], &st[3]), "the retried run equals the run that never failed (bitwise)");
  if (rank == 0)
    printf("unstable: UNSTABLE after 40 small steps with nothing changed, a retry at a smaller dt bitwise equal to a run that never failed; %s\n",
           g_failures == n0 ? "ok" : "FAILED");
  finish(st, 4, &a, &b);
}

/* ------------------------------------------------------------ 3. levels */

/* The reproducer of issue item 7, with the weights and transfer it was
 * filed with (uGIMP, FLIP: the defaults then; "xpic" still sets XPIC). The
 * scene steps 1e8 times beyond its particles' stable step (material
 * density 9.3e18, particle density 1000) and survives its first two steps
 * only on the round-off of the FLIP transfer; with the present defaults
 * (cpGIMP, APIC) the second step ends non-finite (UNSTABLE, undone), which
 * is right, before any particle reaches the level boundary. */
static GimletSim *transfer_scene(void) {
  GimletSim *s = NULL;
  EXPECT_OK(gimlet_create(MPI_COMM_WORLD, -2, 3, 8, 4, 0.5, &s));
  EXPECT_OK(gimlet_set_shape(s, GIMLET_SHAPE_UGIMP));
  EXPECT_OK(gimlet_set_transfer(s, GIMLET_TRANSFER_FLIP));
  set_transfer(s);
  double box[4] = {-1.5, 5.5, 6, 7};
  EXPECT_OK(gimlet_add_level(s, box, 1));
  int id = -1;
  EXPECT_OK(gimlet_add_material_neo_hookean(s, 8.8e7, 0.2, 9.3e18, &id));
  EXPECT_OK(gimlet_set_scheme(s, GIMLET_SCHEME_USF));
  EXPECT_OK(gimlet_fill_rectangle(s, -1.355081725512127, 5.116803085201675, 4.9719097514683392, 5.8712732031240016, 2,
                                  0, 1000, -0.23220415843605813, 0, NULL));
  return s;
}

static void transfers(void) {
  int n0 = g_failures;
  /* Under REMOVE: both steps succeed, nothing vanishes unrecorded. */
  GimletSim *s = transfer_scene();
  int64_t g0 = 0, glob = 0, nl = 0, nlg = 0;
  EXPECT_OK(gimlet_particle_count(s, NULL, &g0));
  EXPECT_OK(gimlet_set_outflow(s, GIMLET_OUTFLOW_REMOVE));
  int rc1 = gimlet_step(s, 0, NULL, NULL);
  int rc2 = gimlet_step(s, 0, NULL, NULL);
  all_true(rc1 == GIMLET_OK && rc2 == GIMLET_OK, "the reproducer's two stable steps succeed under REMOVE");
  if (rc1 != GIMLET_OK || rc2 != GIMLET_OK) fprintf(stderr, "rank %d: %d %d: %s\n", rank, rc1, rc2, last_error());
  EXPECT_OK(gimlet_particle_count(s, NULL, &glob));
  EXPECT_OK(gimlet_lost_particles(s, NULL, NULL, 0, &nl));
  MPI_Allreduce(&nl, &nlg, 1, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);
  all_true(glob + nlg == g0, "particles + lost = initial after the reproducer's steps");
  /* More stable steps (the scene's stable step is set by a density 1e16
   * times the particles' own, so it blows up and the particles fly out of
   * the domain from both levels): nothing vanishes unrecorded, every step
   * succeeds (or fails the same way on every rank, changing nothing). */
  int more = 0, failed = 0;
  for (; more < 20 && glob > 0; more++) {
    State before, after;
    capture(s, &before);
    int r = gimlet_step(s, 0, NULL, NULL);
    int rs[2] = {r, -r}, red[2];
    MPI_Allreduce(rs, red, 2, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    all_true(red[0] == -red[1], "every rank has the same status");
    if (r != GIMLET_OK) {
      failed++;
      capture(s, &after);
      all_true(same(&before, &after), "a failed step changed nothing (bitwise)");
      release(&after);
    }
    release(&before);
    EXPECT_OK(gimlet_particle_count(s, NULL, &glob));
    EXPECT_OK(gimlet_lost_particles(s, NULL, NULL, 0, &nl));
    MPI_Allreduce(&nl, &nlg, 1, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);
    all_true(glob + nlg == g0, "particles + lost = initial after every step");
    if (r != GIMLET_OK) break;
  }
  if (rank == 0)
    printf("transfers: reproducer under REMOVE: 2 + %d stable steps (%d failed, undone), %lld particles + %lld lost = %lld (initial %lld)\n",
           more, failed, (long long)glob, (long long)nlg, (long long)(glob + nlg), (long long)g0);
  EXPECT_OK(gimlet_destroy(&s));

  /* Under FAIL (the default): each step succeeds or fails with
   * PARTICLES_LEFT on every rank, changing nothing. */
  s = transfer_scene();
  int outcomes[2] = {-1, -1};
  for (int k = 0; k < 2; k++) {
    State before, after;
    capture(s, &before);
    int r = gimlet_step(s, 0, NULL, NULL);
    outcomes[k] = r;
    int rs[2] = {r, -r}, red[2];
    MPI_Allreduce(rs, red, 2, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    all_true(red[0] == -red[1], "every rank has the same status");
    all_true(r == GIMLET_OK || r == GIMLET_ERR_PARTICLES_LEFT, "the step succeeds or fails with PARTICLES_LEFT");
    if (r != GIMLET_OK) {
      capture(s, &after);
      all_true(same(&before, &after), "the failed step changed nothing (bitwise)");
      release(&after);
    }
    release(&before);
  }
  EXPECT_OK(gimlet_particle_count(s, NULL, &glob));
  EXPECT_OK(gimlet_lost_particles(s, NULL, NULL, 0, &nl));
  MPI_Allreduce(&nl, &nlg, 1, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);
  all_true(glob + nlg == g0 && nlg == 0, "under FAIL no particle is lost or vanishes");
  if (rank == 0)
    printf("transfers: reproducer under FAIL: statuses %d, %d, %lld particles; %s\n", outcomes[0], outcomes[1],
           (long long)glob, g_failures == n0 ? "ok" : "FAILED");
  EXPECT_OK(gimlet_destroy(&s));
}

/* ------------------------------------------------------------ 4. prepared */

/* One level of 4 x 4-cell patches over an 8 x 4 domain (cells of 0.25): a
 * block moving right at about 20, its velocity varied with height, a
 * ramped traction on its top; gravity (0, -1). */
static GimletSim *prepared_scene(int scheme) {
  GimletSim *s = NULL;
  EXPECT_OK(gimlet_create(MPI_COMM_WORLD, 0, 0, 8, 4, 0.25, &s));
  set_geometry(s);
  EXPECT_OK(gimlet_set_patch_size(s, 0, 4, 4));
  EXPECT_OK(gimlet_set_scheme(s, scheme));
  EXPECT_OK(gimlet_set_gravity(s, 0, -1));
  EXPECT_OK(gimlet_set_load_ramp(s, 0.01));
  int id = -1;
  EXPECT_OK(gimlet_add_material_neo_hookean(s, 1e3, 0.3, 1000, &id));
  EXPECT_OK(gimlet_fill_rectangle(s, 0.5, 0.25, 3, 1.5, 2, id, 1000, 20.0, 0.0, NULL));
  wavy_velocity(s);
  EXPECT_OK(gimlet_apply_traction(s, GIMLET_FACE_TOP, 1.5, 1.0, 2.5, 0.0, -100.0, NULL));
  return s;
}

/* `n` steps of `frac` times the stable step of `a`, taken by `a` and by
 * `b`, `b` after a call that changes nothing (it forgets the mapping its
 * last step prepared). */
static int paired_steps(GimletSim *a, GimletSim *b, int n, double frac) {
  for (int k = 0; k < n; k++) {
    double dt = 0;
    if (gimlet_stable_dt(a, &dt) != GIMLET_OK) return -1;
    int rc = gimlet_step(a, frac * dt, NULL, NULL);
    if (rc != GIMLET_OK) return rc;
    EXPECT_OK(gimlet_set_gravity(b, 0, -1));
    EXPECT_OK(gimlet_step(b, frac * dt, NULL, NULL));
  }
  return GIMLET_OK;
}

static void prepared(void) {
  const int schemes[3] = {GIMLET_SCHEME_USF, GIMLET_SCHEME_USL, GIMLET_SCHEME_MUSL};
  const char *names[3] = {"USF", "USL", "MUSL"};
  for (int k = 0; k < 3; k++) {
    int n0 = g_failures;
    GimletSim *a = prepared_scene(schemes[k]), *b = prepared_scene(schemes[k]);
    EXPECT_OK(paired_steps(a, b, 45, 0.25));
    State st[4];
    all_true(same_runs(a, b, &st[0], &st[1]), "prepared and separate first mappings agree after 45 steps (bitwise)");
    release(&st[0]);
    release(&st[1]);
    /* Steps of the stable size until one fails (particles would leave at
     * x = 8); the run that fails keeps its prepared grids until then. */
    int rc = GIMLET_OK, good = 0;
    for (int j = 0; j < 400 && rc == GIMLET_OK; j++) {
      rc = paired_steps(a, b, 1, 1.0);
      good += rc == GIMLET_OK;
    }
    all_true(rc == GIMLET_ERR_PARTICLES_LEFT, "a step of the stable size fails with GIMLET_ERR_PARTICLES_LEFT");
    all_true(same_runs(a, b, &st[0], &st[1]), "the failed step changed nothing (bitwise, against the other run)");
    /* Retry with halved steps until one succeeds, on both. */
    int retried = 0;
    for (double f = 0.5; f > 1e-3 && !retried; f *= 0.5) retried = paired_steps(a, b, 1, f) == GIMLET_OK;
    all_true(retried, "a retry with a smaller dt succeeds");
    all_true(same_runs(a, b, &st[2], &st[3]), "after the retry the runs agree (bitwise)");
    int64_t crossings = 0;
    EXPECT_OK(gimlet_patch_crossings(a, &crossings));
    all_true(crossings >= 100, "the block crosses at least 100 patch borders");
    if (rank == 0)
      printf("prepared %s: 45 steps, %d of the stable size, a failed one (PARTICLES_LEFT, undone) and a smaller retry, %lld patch crossings: prepared and separate first mappings bitwise equal; %s\n",
             names[k], good, (long long)crossings, g_failures == n0 ? "ok" : "FAILED");
    finish(st, 4, &a, &b);
  }
}

int main(int argc, char **argv) {
  check_begin(&argc, &argv);
  g_flip = argc > 1 && strcmp(argv[1], "flip") == 0;
  g_xpic = argc > 1 && strcmp(argv[1], "xpic") == 0;
  g_axisym = argc > 1 && strcmp(argv[1], "axisym") == 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  if (!g_axisym) {
    /* (Their indenter and fills lie off the axis.) */
    transfers();
    outflow();
  }
  unstable();
  prepared();
  return check_end("test_transaction");
}
