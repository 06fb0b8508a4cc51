/* Robustness on 1 and 2 ranks (issue "Never abort, never hang"):
 *
 *   1. communicators: MPI_COMM_NULL, a NULL handle, invalid Fortran handles
 *      (-1, 99999), a freed communicator (its handle variable, a stale copy,
 *      its Fortran handle) and an inter-communicator are rejected with a
 *      status, the process goes on, the caller's error handler is intact;
 *   2. bounds: absurd but finite inputs are rejected naming the bound; the
 *      extreme accepted material and velocity give a finite, nonzero stable
 *      step; a 65000 x 65000-cell domain with one particle is refused at
 *      the insertion (patch too large) instead of aborting on a 33 GB
 *      allocation, and works once tiled; an 8-level fill and a fill of a
 *      level of three boxes give every point of the filled area one
 *      particle (mass = rho x area) and ids 0 .. n-1; dt <= 0 without
 *      particles;
 *   3. long paths (300 and 1000 bytes, and a 250-byte file name): checkpoint
 *      write / read / create-from, output series and XDMF check, CSV; a
 *      5000-byte path is refused with a status;
 *   4. checkpoints without particles round-trip;
 *   5. after MPI_Finalize, a call on a live handle returns a status.
 * Prints one line per section with its figures; exits non-zero on any
 * failed check. Usage: test_robust <work-dir>. */
#include <math.h>
#include <mpi.h>
#include <stdint.h>
#include <sys/stat.h>
#include "check.h"

static int rank = 0, size = 1;

/* Every rank's status must be `want`. */
static void all_ranks(int rc, int want, const char *word, const char *what) {
  int bad = rc != want || !message_names(word);
  if (bad) fprintf(stderr, "rank %d: %s returned %d (expected %d): %s\n", rank, what, rc, want, last_error());
  int any = 0;
  MPI_Allreduce(&bad, &any, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  g_checks++;
  if (any && rank == 0) g_failures++;
}

static void mkdirs(const char *dir) {
  if (rank == 0) {
    char cmd[6000];
    snprintf(cmd, sizeof cmd, "mkdir -p '%s'", dir);
    if (system(cmd) != 0) fprintf(stderr, "mkdir -p failed\n");
  }
  MPI_Barrier(MPI_COMM_WORLD);
}

/* A small scene: 8 x 4 domain, cells of 0.25, a refined box, one material,
 * a filled block (when `fill`). */
static GimletSim *scene(int fill) {
  GimletSim *s = NULL;
  EXPECT_OK(gimlet_create(MPI_COMM_WORLD, 0, 0, 8, 4, 0.25, &s));
  double box[4] = {2, 0, 6, 2};
  EXPECT_OK(gimlet_add_level(s, box, 1));
  int id = -1;
  EXPECT_OK(gimlet_add_material_linear_elastic(s, 1e9, 0.3, 1000, &id));
  if (fill) EXPECT_OK(gimlet_fill_rectangle(s, 1, 0, 7, 1.5, 2, id, 1000, 1.0, -0.5, NULL));
  return s;
}

/* A fingerprint of a handle's state: time, steps, counts, diagnostics. */
static void state(GimletSim *s, double out[9]) {
  int64_t st = 0, loc = 0, glob = 0;
  gimlet_time(s, &out[0], &st);
  gimlet_particle_count(s, &loc, &glob);
  out[1] = (double)st;
  out[2] = (double)glob;
  gimlet_diagnostics(s, &out[3], &out[4], &out[5], &out[6], &out[7]);
  out[8] = 0;
  gimlet_stable_dt(s, &out[8]);
}

static void communicators(void) {
  GimletSim *s = NULL;
  int n0 = g_failures;
  EXPECT_STATUS(gimlet_create(MPI_COMM_NULL, 0, 0, 1, 1, 0.25, &s), GIMLET_ERR_INVALID_ARGUMENT, "MPI_COMM_NULL");
  EXPECT_STATUS(gimlet_create((MPI_Comm)NULL, 0, 0, 1, 1, 0.25, &s), GIMLET_ERR_INVALID_ARGUMENT, "comm");
  EXPECT_STATUS(gimlet_create_f(-1, 0, 0, 1, 1, 0.25, &s), GIMLET_ERR_INVALID_ARGUMENT, "fcomm = -1");
  EXPECT_STATUS(gimlet_create_f(99999, 0, 0, 1, 1, 0.25, &s), GIMLET_ERR_INVALID_ARGUMENT, "fcomm = 99999");
  EXPECT_STATUS(gimlet_create_from_checkpoint_f(-1, "x.h5", &s), GIMLET_ERR_INVALID_ARGUMENT, "fcomm");
  EXPECT_STATUS(gimlet_create_from_checkpoint(MPI_COMM_NULL, "x.h5", &s), GIMLET_ERR_INVALID_ARGUMENT, "comm");
  /* A freed communicator: the variable (MPI_COMM_NULL after the free), a
   * stale copy of the handle, and its Fortran handle. */
  MPI_Comm c, stale;
  MPI_Comm_dup(MPI_COMM_WORLD, &c);
  stale = c;
  MPI_Fint fc = MPI_Comm_c2f(c);
  MPI_Comm_free(&c);
  EXPECT_STATUS(gimlet_create(c, 0, 0, 1, 1, 0.25, &s), GIMLET_ERR_INVALID_ARGUMENT, "MPI_COMM_NULL");
  EXPECT_STATUS(gimlet_create(stale, 0, 0, 1, 1, 0.25, &s), GIMLET_ERR_INVALID_ARGUMENT, "not a live communicator");
  EXPECT_STATUS(gimlet_create_f(fc, 0, 0, 1, 1, 0.25, &s), GIMLET_ERR_INVALID_ARGUMENT, "fcomm");
  EXPECT_TRUE(s == NULL);
  /* An inter-communicator (2 ranks: one group per rank). */
  if (size >= 2) {
    MPI_Comm half, inter;
    MPI_Comm_split(MPI_COMM_WORLD, rank % 2, rank, &half);
    MPI_Intercomm_create(half, 0, MPI_COMM_WORLD, rank % 2 ? 0 : 1, 7, &inter);
    EXPECT_STATUS(gimlet_create(inter, 0, 0, 1, 1, 0.25, &s), GIMLET_ERR_INVALID_ARGUMENT, "inter-communicator");
    MPI_Comm_free(&inter);
    MPI_Comm_free(&half);
  }
  /* Valid communicators still work: MPI_COMM_SELF (one handle per rank), a
   * split communicator, MPI_COMM_WORLD by its Fortran handle. */
  EXPECT_OK(gimlet_create(MPI_COMM_SELF, 0, 0, 1, 1, 0.25, &s));
  int r = -1, n = -1;
  EXPECT_OK(gimlet_comm_info(s, &r, &n));
  EXPECT_TRUE(r == 0 && n == 1);
  EXPECT_OK(gimlet_destroy(&s));
  EXPECT_OK(gimlet_create_f(MPI_Comm_c2f(MPI_COMM_WORLD), 0, 0, 1, 1, 0.25, &s));
  EXPECT_OK(gimlet_comm_info(s, &r, &n));
  EXPECT_TRUE(r == rank && n == size);
  EXPECT_OK(gimlet_destroy(&s));
  /* The caller's error handler is the one it had. */
  MPI_Errhandler eh;
  MPI_Comm_get_errhandler(MPI_COMM_WORLD, &eh);
  EXPECT_TRUE(eh == MPI_ERRORS_ARE_FATAL);
  MPI_Errhandler_free(&eh);
  if (rank == 0)
    printf("communicators: MPI_COMM_NULL, NULL, fcomm -1 and 99999, freed (variable, stale copy, Fortran), inter-communicator rejected; %s\n",
           g_failures == n0 ? "ok" : "FAILED");
}

static void bounds(void) {
  int n0 = g_failures, rejected = 0;
  GimletSim *s = NULL;
#define REJECT(expr, word) do { EXPECT_STATUS(expr, GIMLET_ERR_INVALID_ARGUMENT, word); rejected++; } while (0)
  REJECT(gimlet_create(MPI_COMM_WORLD, 0, 0, 1, 1, 1e-300, &s), "h = 1e-300");
  REJECT(gimlet_create(MPI_COMM_WORLD, 0, 0, 1e300, 1, 1e299, &s), "lx");
  REJECT(gimlet_create(MPI_COMM_WORLD, 1e20, 0, 1, 1, 0.25, &s), "h = 0.25");
  s = scene(0);
  int id = -1;
  REJECT(gimlet_add_material_linear_elastic(s, 1e308, 0.3, 1000, &id), "e = 1e308");
  REJECT(gimlet_add_material_neo_hookean(s, 1e9, 0.3, 1e-300, &id), "rho = 1e-300");
  REJECT(gimlet_add_material_neo_hookean(s, 1e9, 0.3, 1e308, &id), "rho = 1e308");
  REJECT(gimlet_set_thickness(s, 1e300), "thickness");
  REJECT(gimlet_set_gravity(s, 0, 1e300), "gravity");
  REJECT(gimlet_set_load_ramp(s, 1e300), "t_ramp");
  REJECT(gimlet_fill_rectangle(s, 1, 0, 7, 1, 2, 0, 1e308, 0, 0, NULL), "density");
  REJECT(gimlet_fill_rectangle(s, 1, 0, 7, 1, 2, 0, 1000, 1e200, 0, NULL), "vx");
  double x = 1.1, y = 0.6, lp = 0.0625, v = 0, big = 1e200, m = 1e308, tiny = 1e-300, rho = 1000;
  int mat = 0;
  int k = rank == 0; /* one particle, on rank 0 */
  REJECT(gimlet_insert_particles(s, k, &x, &y, &lp, &lp, &big, &v, NULL, &rho, &mat), "vx");
  REJECT(gimlet_insert_particles(s, k, &x, &y, &lp, &lp, &v, &v, &m, NULL, &mat), "mass");
  REJECT(gimlet_insert_particles(s, k, &x, &y, &tiny, &lp, &v, &v, NULL, &rho, &mat), "lpx");
  EXPECT_OK(gimlet_fill_rectangle(s, 1, 0, 7, 1, 2, 0, 1000, 0, 0, NULL));
  REJECT(gimlet_apply_traction(s, GIMLET_FACE_TOP, 1, 1, 7, 0, -1e300, NULL), "ty");
  REJECT(gimlet_step(s, 1e300, NULL, NULL), "dt");
  int64_t nloc = 0;
  EXPECT_OK(gimlet_get_field(s, GIMLET_FIELD_VELOCITY, NULL, 0, &nloc));
  double *vel = calloc((size_t)(2 * nloc + 2), sizeof(double));
  if (nloc > 0) vel[0] = 1e200;
  int rc = gimlet_set_field(s, GIMLET_FIELD_VELOCITY, vel, nloc);
  all_ranks(rc, size == 1 || nloc > 0 ? GIMLET_ERR_INVALID_ARGUMENT : rc, "values", "set_field 1e200");
  rejected++;
  free(vel);
  double dt = 0;
  EXPECT_OK(gimlet_stable_dt(s, &dt));
  EXPECT_TRUE(isfinite(dt) && dt > 0);
  EXPECT_OK(gimlet_step(s, 0, NULL, NULL));
  EXPECT_OK(gimlet_destroy(&s));

  /* The extreme accepted inputs: E = 1e30 with rho = 1e-30 (c ~ 1e30) and
   * |v| = 1e30: the stable step is finite and > 0, a step succeeds, and the
   * energies stay finite. */
  EXPECT_OK(gimlet_create(MPI_COMM_WORLD, 0, 0, 8, 4, 0.25, &s));
  EXPECT_OK(gimlet_add_material_linear_elastic(s, 1e30, 0.3, 1e-30, &id));
  EXPECT_OK(gimlet_fill_rectangle(s, 1, 1, 7, 3, 2, id, 1e-30, 1e30, 0, NULL));
  dt = 0;
  EXPECT_OK(gimlet_stable_dt(s, &dt));
  EXPECT_TRUE(isfinite(dt) && dt > 0);
  double t = 0, ke = NAN;
  EXPECT_OK(gimlet_step(s, 0, &t, NULL));
  EXPECT_TRUE(t > 0);
  EXPECT_OK(gimlet_diagnostics(s, &ke, NULL, NULL, NULL, NULL));
  EXPECT_TRUE(isfinite(ke) && ke > 0);
  EXPECT_OK(gimlet_destroy(&s));
  double extreme_dt = dt;

  /* 65000 x 65000 cells, one particle: refused at the insertion, naming
   * the patch and the call that fixes it; a patch size that makes too many
   * patches is refused too; tiled, it works (only the patch holding the
   * particle gets a grid). */
  EXPECT_OK(gimlet_create(MPI_COMM_WORLD, 0, 0, 65000, 65000, 1.0, &s));
  EXPECT_OK(gimlet_add_material_linear_elastic(s, 1e9, 0.3, 1000, &id));
  double px = 100.5, py = 100.5, plp = 0.25;
  rc = gimlet_insert_particles(s, k, &px, &py, &plp, &plp, &v, &v, NULL, &rho, &mat);
  all_ranks(rc, GIMLET_ERR_INVALID_ARGUMENT, "gimlet_set_patch_size", "insert into a 65000^2 patch");
  rejected++;
  rc = gimlet_set_patch_size(s, 0, 256, 256);
  all_ranks(rc, GIMLET_ERR_INVALID_ARGUMENT, "patches", "65000^2 in patches of 256^2");
  rejected++;
  EXPECT_OK(gimlet_set_patch_size(s, 0, 1024, 1024));
  EXPECT_OK(gimlet_insert_particles(s, k, &px, &py, &plp, &plp, &v, &v, NULL, &rho, &mat));
  int64_t steps = 0;
  EXPECT_OK(gimlet_step(s, 0, NULL, &steps));
  EXPECT_TRUE(steps == 1);
  EXPECT_OK(gimlet_destroy(&s));

  /* A deep hierarchy (8 levels of 64 x 64-cell boxes nested at a corner,
   * finest cell 1/8192 of the domain) filled whole: about 130,000
   * particles, accepted. The memory bound counts the cells of the levels'
   * boxes, not each level's whole domain (that bound, 1.1e9 particles and
   * about 250 GB for the finest level alone, refused the paper's 6-level
   * scene). The same fill over the whole domain refined to the finest
   * level everywhere would be refused. */
  EXPECT_OK(gimlet_create(MPI_COMM_WORLD, 0, 0, 1, 1, 1.0 / 64, &s));
  for (int l = 1; l < 8; l++) {
    double e = ldexp(1.0, -l), box[4] = {0, 0, e, e};
    EXPECT_OK(gimlet_add_level(s, box, 1));
  }
  EXPECT_OK(gimlet_add_material_linear_elastic(s, 1e9, 0.3, 1000, &id));
  EXPECT_OK(gimlet_fill_rectangle(s, 0, 0, 1, 1, 2, id, 1000, 0, 0, NULL));
  int64_t deep_n = 0;
  EXPECT_OK(gimlet_particle_count(s, NULL, &deep_n));
  EXPECT_TRUE(deep_n > 100000 && deep_n < 200000);
  /* Every point of the square holds exactly one particle's rectangle: the
   * mass is rho times the area (a cell filled twice or missed, on any
   * level, would show by at least one particle's mass, 1000 / 8192^2 / 4). */
  double deep_mass = 0;
  EXPECT_OK(gimlet_diagnostics(s, NULL, NULL, NULL, NULL, &deep_mass));
  EXPECT_TRUE(fabs(deep_mass - 1000.0) <= 1e-9 * 1000.0);
  EXPECT_OK(gimlet_destroy(&s));

  /* A level of two disjoint boxes sharing rows, with a gap between them,
   * and a third box above: the fill walks each row's boxes left to right
   * (gimlet_fill_rectangle visits only the cells of each level's boxes).
   * The mass is rho times the area, and the ids are 0 .. n-1. */
  EXPECT_OK(gimlet_create(MPI_COMM_WORLD, 0, 0, 4, 2, 0.125, &s));
  {
    double boxes[12] = {0.5, 0.25, 1.5, 1.0, 2.5, 0.5, 3.5, 1.25, 1.0, 1.5, 3.0, 2.0};
    EXPECT_OK(gimlet_add_level(s, boxes, 3));
  }
  EXPECT_OK(gimlet_add_material_linear_elastic(s, 1e9, 0.3, 1000, &id));
  EXPECT_OK(gimlet_fill_rectangle(s, 0.25, 0.125, 3.75, 1.875, 2, id, 1000, 0, 0, NULL));
  double box_mass = 0;
  int64_t box_n = 0, lvl1 = 0;
  EXPECT_OK(gimlet_diagnostics(s, NULL, NULL, NULL, NULL, &box_mass));
  EXPECT_OK(gimlet_particle_count(s, NULL, &box_n));
  EXPECT_OK(gimlet_level_particle_count(s, 1, &lvl1));
  int64_t lvl1_all = 0;
  MPI_Allreduce(&lvl1, &lvl1_all, 1, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);
  EXPECT_TRUE(fabs(box_mass - 1000.0 * 3.5 * 1.75) <= 1e-9 * box_mass);
  EXPECT_TRUE(lvl1_all > 0);
  {
    int64_t nl = 0;
    EXPECT_OK(gimlet_get_ids(s, NULL, 0, &nl));
    uint64_t *ids = malloc(sizeof(uint64_t) * (size_t)(nl + 1));
    EXPECT_OK(gimlet_get_ids(s, ids, nl, &nl));
    uint64_t lo = UINT64_MAX, hi = 0, glo = 0, ghi = 0;
    for (int64_t i = 0; i < nl; i++) {
      if (ids[i] < lo) lo = ids[i];
      if (ids[i] > hi) hi = ids[i];
    }
    MPI_Allreduce(&lo, &glo, 1, MPI_UINT64_T, MPI_MIN, MPI_COMM_WORLD);
    MPI_Allreduce(&hi, &ghi, 1, MPI_UINT64_T, MPI_MAX, MPI_COMM_WORLD);
    EXPECT_TRUE(glo == 0 && ghi == (uint64_t)(box_n - 1));
    free(ids);
  }
  EXPECT_OK(gimlet_destroy(&s));

  /* dt <= 0 without particles: INVALID_STATE, nothing changes; dt > 0
   * advances the clock; advance_to lands on t_end in one step. */
  EXPECT_OK(gimlet_create(MPI_COMM_WORLD, 0, 0, 8, 4, 0.25, &s));
  EXPECT_STATUS(gimlet_step(s, 0, NULL, NULL), GIMLET_ERR_INVALID_STATE, "material");
  EXPECT_OK(gimlet_add_material_linear_elastic(s, 1e9, 0.3, 1000, &id));
  EXPECT_STATUS(gimlet_step(s, 0, NULL, NULL), GIMLET_ERR_INVALID_STATE, "without particles");
  EXPECT_STATUS(gimlet_step(s, -1, NULL, NULL), GIMLET_ERR_INVALID_STATE, "without particles");
  t = -1;
  EXPECT_OK(gimlet_time(s, &t, &steps));
  EXPECT_TRUE(t == 0 && steps == 0);
  EXPECT_OK(gimlet_step(s, 1e-3, &t, &steps));
  EXPECT_TRUE(t == 1e-3 && steps == 1);
  EXPECT_OK(gimlet_advance_to(s, 2e-3, 5, &t, &steps));
  EXPECT_TRUE(t == 2e-3 && steps == 2);
  EXPECT_OK(gimlet_destroy(&s));
  if (rank == 0)
    printf("bounds: %d absurd inputs rejected naming the bound; extreme accepted material (E = 1e30, rho = 1e-30, |v| = 1e30): stable dt %.3e; 65000^2 domain refused untiled, stepped tiled; 8-level fill of %lld particles accepted; dt <= 0 without particles refused; %s\n",
           rejected, extreme_dt, (long long)deep_n, g_failures == n0 ? "ok" : "FAILED");
#undef REJECT
}

/* A path of exactly `len` bytes: `base`, nested directories, `name`. */
static void long_path(char *out, size_t cap, const char *base, size_t len, const char *name) {
  snprintf(out, cap, "%s", base);
  size_t tail = strlen(name) + 1;
  while (strlen(out) + tail < len) {
    size_t room = len - strlen(out) - tail; /* bytes still to add before "/name" */
    char seg[64];
    size_t n = room > 41 ? 40 : room - 1; /* "/" + n letters */
    if (room <= 1) n = 0;
    if (n == 0) break;
    memset(seg, 'd', n);
    seg[n] = 0;
    strcat(out, "/");
    strcat(out, seg);
  }
  mkdirs(out);
  strcat(out, "/");
  strcat(out, name);
}

static void paths(const char *work) {
  int n0 = g_failures;
  GimletSim *s = scene(1);
  EXPECT_OK(gimlet_step(s, 0, NULL, NULL));
  double ref[9];
  state(s, ref);
  char p[6000], q[6000], name250[251];
  memset(name250, 'f', 247);
  strcpy(name250 + 247, ".h5");
  const size_t lens[2] = {300, 1000};
  for (int i = 0; i < 3; i++) {
    if (i < 2) {
      long_path(p, sizeof p, work, lens[i], "ck.h5");
    } else {
      snprintf(p, sizeof p, "%s", work);
      mkdirs(p);
      strcat(p, "/");
      strcat(p, name250);
    }
    int w = gimlet_write_checkpoint(s, p);
    EXPECT_OK(w);
    GimletSim *r = NULL;
    int c = gimlet_create_from_checkpoint(MPI_COMM_WORLD, p, &r);
    EXPECT_OK(c);
    double got[9] = {0};
    if (r) {
      state(r, got);
      EXPECT_TRUE(memcmp(ref, got, sizeof ref) == 0);
      EXPECT_OK(gimlet_read_checkpoint(r, p));
      EXPECT_OK(gimlet_destroy(&r));
    }
    /* Output series and CSV in the long directory. */
    snprintf(q, sizeof q, "%s", p);
    *strrchr(q, '/') = 0;
    int o = gimlet_output_open(s, q, "run");
    EXPECT_OK(o);
    EXPECT_OK(gimlet_write_output(s));
    strcat(q, "/run.xdmf");
    int64_t items = 0;
    int x = gimlet_check_xdmf(s, q, &items);
    EXPECT_OK(x);
    EXPECT_TRUE(items > 0);
    *strrchr(q, '/') = 0;
    strcat(q, "/series.csv");
    EXPECT_OK(gimlet_csv_open(s, q));
    EXPECT_OK(gimlet_csv_append(s));
    if (rank == 0)
      printf("long path (%zu bytes%s): write_checkpoint %d, create_from_checkpoint %d, output + XDMF check %d/%d (%lld datasets), restored state %s\n",
             strlen(p), i == 2 ? ", 250-byte file name" : "", w, c, o, x, (long long)items,
             memcmp(ref, got, sizeof ref) == 0 ? "identical" : "DIFFERENT");
  }
  /* Beyond what the system allows: a status, not an abort. */
  memset(q, 'x', 5000);
  q[0] = '/';
  q[5000] = 0;
  int rc = gimlet_write_checkpoint(s, q);
  all_ranks(rc, GIMLET_ERR_INVALID_ARGUMENT, "5000 bytes", "a 5000-byte path");
  int rc2 = gimlet_read_checkpoint(s, q);
  all_ranks(rc2, GIMLET_ERR_INVALID_ARGUMENT, "5000 bytes", "reading a 5000-byte path");
  /* A 300-byte file name (more than NAME_MAX = 255) in a short directory. */
  snprintf(q, sizeof q, "%s/", work);
  memset(q + strlen(q), 'n', 300);
  q[strlen(work) + 1 + 300] = 0;
  int rc3 = gimlet_write_checkpoint(s, q);
  all_ranks(rc3, GIMLET_ERR_INVALID_ARGUMENT, "255 bytes", "a 300-byte file name");
  if (rank == 0)
    printf("long path (5000 bytes): write %d, read %d; 300-byte file name: write %d (refused with a status)\n", rc, rc2, rc3);
  EXPECT_OK(gimlet_destroy(&s));
  if (rank == 0) printf("paths: %s\n", g_failures == n0 ? "ok" : "FAILED");
}

static void empty_checkpoints(const char *work) {
  int n0 = g_failures;
  char p[2048];
  /* No particle, levels and a material defined; and a bare handle. */
  for (int bare = 0; bare < 2; bare++) {
    GimletSim *s = NULL;
    if (bare) {
      EXPECT_OK(gimlet_create(MPI_COMM_WORLD, 0, 0, 8, 4, 0.25, &s));
    } else {
      s = scene(0);
    }
    snprintf(p, sizeof p, "%s/empty_%d.h5", work, bare);
    EXPECT_OK(gimlet_write_checkpoint(s, p));
    GimletSim *r = NULL;
    EXPECT_OK(gimlet_create_from_checkpoint(MPI_COMM_WORLD, p, &r));
    if (r) {
      int64_t loc = -1, glob = -1;
      int nl = 0;
      EXPECT_OK(gimlet_particle_count(r, &loc, &glob));
      EXPECT_OK(gimlet_num_levels(r, &nl));
      EXPECT_TRUE(glob == 0 && nl == (bare ? 1 : 2));
      /* The restored handle takes particles and steps like the original. */
      int id = 0;
      if (bare) EXPECT_OK(gimlet_add_material_linear_elastic(r, 1e9, 0.3, 1000, &id));
      EXPECT_OK(gimlet_fill_rectangle(r, 1, 0, 7, 1.5, 2, id, 1000, 1.0, -0.5, NULL));
      EXPECT_OK(gimlet_step(r, 0, NULL, NULL));
      EXPECT_OK(gimlet_destroy(&r));
    }
    EXPECT_OK(gimlet_destroy(&s));
  }
  if (rank == 0) printf("empty checkpoints (levels + material, and a bare handle): round-trip %s\n", g_failures == n0 ? "ok" : "FAILED");
}

int main(int argc, char **argv) {
  check_begin(&argc, &argv);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  const char *work = argc > 1 ? argv[1] : "robust-out";
  mkdirs(work);
  communicators();
  bounds();
  paths(work);
  empty_checkpoints(work);

  /* After MPI_Finalize: a status, not an abort. */
  GimletSim *late = scene(0);
  int total = 0;
  MPI_Allreduce(&g_failures, &total, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
  MPI_Finalize();
  int64_t c = 0;
  int rc = gimlet_particle_count(late, &c, &c);
  if (rc != GIMLET_ERR_INVALID_STATE) {
    fprintf(stderr, "rank %d: a call after MPI_Finalize returned %d: %s\n", rank, rc, last_error());
    total++;
  }
  rc = gimlet_destroy(&late);
  if (rc != GIMLET_OK || late != NULL) total++;
  if (rank == 0)
    printf("after MPI_Finalize: gimlet_particle_count -> %d (GIMLET_ERR_INVALID_STATE), gimlet_destroy -> 0\n"
           "test_robust: %d checks per rank on %d rank(s), %d failure(s)\n",
           GIMLET_ERR_INVALID_STATE, g_checks, size, total);
  return total == 0 ? 0 : 1;
}
