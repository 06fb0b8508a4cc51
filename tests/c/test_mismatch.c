/* Collective agreement on 2 ranks, for every collective call of gimlet.h:
 *
 *   (a) the two ranks pass different arguments: both ranks must fail with
 *       GIMLET_ERR_INVALID_ARGUMENT and the same message, naming the call
 *       and the differing argument;
 *   (b) an argument valid on one rank and invalid on the other: both ranks
 *       must fail with the same status and message (the rejecting rank's);
 *   (c) for calls without a collective argument, the ranks make different
 *       calls at the same point: both must fail, naming the call.
 *
 * After every case the handle must still be usable (the collective queries
 * of the snapshot succeed) and its state unchanged (time, step count,
 * particle counts, diagnostics, levels, stable step). Prints the table
 * (call, case, status on rank 0 / rank 1, rank 0's message) and exits
 * non-zero on any failed check. Run with mpiexec -n 2:
 *
 *   test_mismatch DIR [WORD]
 *
 * DIR receives the checkpoints, outputs and CSV files the cases write.
 * With WORD, only the cases whose call or description contains it run (the
 * set-up between them runs all the same). tests/mismatch_coverage.rs reads
 * the cases' call names here and fails when a call that gimlet.h documents
 * as collective has none. */
#include <math.h>
#include <mpi.h>
#include <stdint.h>
#include <unistd.h>
#include "check.h"

static int rank = 0, size = 1;
static int rows = 0, agreed = 0;
/* Only the cases whose call or description contains this (NULL: all). */
static const char *only = NULL;

static int selected(const char *call, const char *kind) {
  return only == NULL || strstr(call, only) != NULL || strstr(kind, only) != NULL;
}

/* The state a rejected call must leave as it was. */
typedef struct {
  double time;
  int64_t steps, local, global;
  int nlevels;
  double diag[5];
  double stable;
} Snap;

static int snap(GimletSim *sim, Snap *s, int stepable) {
  memset(s, 0, sizeof *s);
  int ok = 1;
  ok &= gimlet_time(sim, &s->time, &s->steps) == GIMLET_OK;
  ok &= gimlet_num_levels(sim, &s->nlevels) == GIMLET_OK;
  ok &= gimlet_particle_count(sim, &s->local, &s->global) == GIMLET_OK;
  ok &= gimlet_diagnostics(sim, &s->diag[0], &s->diag[1], &s->diag[2], &s->diag[3], &s->diag[4]) == GIMLET_OK;
  if (stepable) ok &= gimlet_stable_dt(sim, &s->stable) == GIMLET_OK;
  return ok;
}

static int same_snap(const Snap *a, const Snap *b) {
  return a->time == b->time && a->steps == b->steps && a->local == b->local &&
         a->global == b->global && a->nlevels == b->nlevels &&
         memcmp(a->diag, b->diag, sizeof a->diag) == 0 && a->stable == b->stable;
}

/* Checks one case: `rc` from the call on this rank; the call's name and
 * (when non-NULL) a word the message must contain (the differing argument).
 * Both ranks must return the same error status and the same message. */
static void report(const char *call, const char *kind, int rc, const char *word) {
  char msg[768], full[768];
  snprintf(msg, sizeof msg, "%s", rc == GIMLET_OK ? "" : last_error());
  snprintf(full, sizeof full, "%s", msg);
  /* Ranks in different calls: each message starts with its own call's name
   * (checked here); the rest must be the same. */
  int other_call = strncmp(kind, "rank 1 in ", 10) == 0;
  if (other_call) {
    char own[64];
    /* Rank 1's call is the word after "rank 1 in ". */
    snprintf(own, sizeof own, "%.*s", rank == 0 ? (int)strlen(call) : (int)strcspn(kind + 10, " "),
             rank == 0 ? call : kind + 10);
    const char *colon = strstr(msg, ": ");
    int own_ok = strncmp(msg, own, strlen(own)) == 0;
    if (!own_ok || colon == NULL) {
      g_failures++;
      fprintf(stderr, "FAILED %s (%s) on rank %d: \"%s\" does not start with its own call\n", call, kind, rank, msg);
    }
    memmove(msg, colon ? colon : msg, strlen(colon ? colon : msg) + 1);
  }
  int rcs[2] = {0, 0};
  MPI_Allgather(&rc, 1, MPI_INT, rcs, 1, MPI_INT, MPI_COMM_WORLD);
  static char all[2][768];
  MPI_Allgather(msg, 768, MPI_CHAR, all, 768, MPI_CHAR, MPI_COMM_WORLD);
  /* A case of differing arguments names the argument as the library does:
   * "... different values of WORD". */
  char named[96];
  snprintf(named, sizeof named, "%s%s", strncmp(kind, "different ", 10) == 0 ? "values of " : "", word ? word : "");
  int ok = rcs[0] == rcs[1] && rcs[0] != GIMLET_OK && strcmp(all[0], all[1]) == 0 &&
           strlen(all[0]) > 0 && (other_call || strstr(all[0], call) != NULL) &&
           (word == NULL || strstr(all[0], named) != NULL);
  g_checks++;
  rows++;
  if (ok) {
    agreed++;
  } else {
    g_failures++;
    if (rank == 0)
      fprintf(stderr, "FAILED %s (%s): rank 0 -> %d \"%s\", rank 1 -> %d \"%s\" (expected the words \"%s\")\n",
              call, kind, rcs[0], all[0], rcs[1], all[1], named);
  }
  if (rank == 0) {
    char excerpt[121];
    snprintf(excerpt, sizeof excerpt, "%s", full);
    printf("| %-33s | %-34s | %2d / %2d | %-4s | %s%s |\n", call, kind, rcs[0], rcs[1], ok ? "yes" : "NO",
           excerpt, strlen(full) > 120 ? "..." : "");
  }
}

/* A case on `sim`: the snapshot before and after must agree, and the
 * snapshot's collective queries must succeed (the handle is usable). */
#define CASE(sim, stepable, call, kind, word, expr)                                  \
  do {                                                                               \
    if (!selected(call, kind)) break;                                                \
    Snap b_, a_;                                                                     \
    EXPECT_TRUE(snap(sim, &b_, stepable));                                           \
    int rc_ = (expr);                                                                \
    report(call, kind, rc_, word);                                                   \
    EXPECT_TRUE(snap(sim, &a_, stepable));                                           \
    if (!same_snap(&b_, &a_)) {                                                      \
      g_failures++;                                                                  \
      if (rank == 0) fprintf(stderr, "FAILED %s (%s): the state changed\n", call, kind); \
    }                                                                                \
  } while (0)

int main(int argc, char **argv) {
  check_begin(&argc, &argv);
  rank = rank_, size = size_;
  if (size != 2 || argc < 2 || argc > 3) {
    if (rank == 0) fprintf(stderr, "usage: mpiexec -n 2 %s DIR [WORD]\n", argv[0]);
    MPI_Finalize();
    return 2;
  }
  const char *dir = argv[1];
  only = argc > 2 ? argv[2] : NULL;
  if (rank == 0) {
    char cmd[1200];
    snprintf(cmd, sizeof cmd, "mkdir -p '%s'", dir);
    if (system(cmd) != 0) MPI_Abort(MPI_COMM_WORLD, 2);
  }
  MPI_Barrier(MPI_COMM_WORLD);
  char p_a[1024], p_b[1024], p_dir_a[1024], p_dir_b[1024], csv_a[1024], csv_b[1024], xdmf[1024];
  snprintf(p_a, sizeof p_a, "%s/ck_a.h5", dir);
  snprintf(p_b, sizeof p_b, "%s/ck_b.h5", dir);
  snprintf(p_dir_a, sizeof p_dir_a, "%s/out_a", dir);
  snprintf(p_dir_b, sizeof p_dir_b, "%s/out_b", dir);
  snprintf(csv_a, sizeof csv_a, "%s/a.csv", dir);
  snprintf(csv_b, sizeof csv_b, "%s/b.csv", dir);
  snprintf(xdmf, sizeof xdmf, "%s/out_a/run.xdmf", dir);
  const double nan = NAN;
  int r = rank; /* 0 or 1: the per-rank selector of the cases */

  if (rank == 0) {
    printf("| call | case | status rank 0 / rank 1 | agree | message on rank 0 |\n");
    printf("|---|---|---|---|---|\n");
  }

  /* Creation: no handle may appear on either rank. */
  if (selected("gimlet_create", "") || selected("gimlet_create_f", "")) {
    GimletSim *s2 = NULL;
    int rc = gimlet_create(MPI_COMM_WORLD, 0, 0, r ? 8 : 4, 4, 0.25, &s2);
    report("gimlet_create", "different lx", rc, "lx");
    EXPECT_TRUE(s2 == NULL);
    rc = gimlet_create(MPI_COMM_WORLD, 0, 0, 8, 4, r ? -0.25 : 0.25, &s2);
    report("gimlet_create", "h invalid on rank 1", rc, "h");
    EXPECT_TRUE(s2 == NULL);
    rc = gimlet_create(MPI_COMM_WORLD, 0, 0, 8, 4, 0.25, r ? NULL : &s2);
    report("gimlet_create", "out NULL on rank 1", rc, "out");
    EXPECT_TRUE(s2 == NULL);
    MPI_Fint fw = MPI_Comm_c2f(MPI_COMM_WORLD);
    rc = gimlet_create_f(fw, r ? 1.0 : 0.0, 0, 8, 4, 0.25, &s2);
    report("gimlet_create_f", "different x0", rc, "x0");
    EXPECT_TRUE(s2 == NULL);
    rc = gimlet_create_f(fw, 0, 0, 8, r ? 4.1 : 4, 0.25, &s2);
    report("gimlet_create_f", "ly/h invalid on rank 1", rc, "ly");
    EXPECT_TRUE(s2 == NULL);
  }

  GimletSim *sim = NULL;
  EXPECT_OK(gimlet_create(MPI_COMM_WORLD, 0, 0, 8, 4, 0.25, &sim));
  if (!sim) MPI_Abort(MPI_COMM_WORLD, 1);

  /* The layout, before any particle. */
  CASE(sim, 0, "gimlet_set_thickness", "different thickness", "thickness",
       gimlet_set_thickness(sim, r ? 2.0 : 1.0));
  CASE(sim, 0, "gimlet_set_thickness", "NaN on rank 1", "thickness", gimlet_set_thickness(sim, r ? nan : 1.0));
  CASE(sim, 0, "gimlet_set_geometry", "different geometry", "geometry",
       gimlet_set_geometry(sim, r ? GIMLET_AXISYMMETRIC : GIMLET_PLANE_STRAIN));
  CASE(sim, 0, "gimlet_set_geometry", "7 on rank 1", "geometry", gimlet_set_geometry(sim, r ? 7 : 0));
  CASE(sim, 0, "gimlet_set_nesting_buffer", "different cells", "cells", gimlet_set_nesting_buffer(sim, r ? 5 : 4));
  CASE(sim, 0, "gimlet_set_nesting_buffer", "0 on rank 1", "cells = 0", gimlet_set_nesting_buffer(sim, r ? 0 : 4));
  CASE(sim, 0, "gimlet_set_nesting_buffer", "6 on rank 1 (default 4 on rank 0)", "cells",
       gimlet_set_nesting_buffer(sim, r ? 6 : 4));
  double box_a[4] = {2, 1, 6, 3}, box_b[4] = {2, 1, 5, 3}, box_mis[4] = {2.1, 1, 6, 3};
  CASE(sim, 0, "gimlet_add_level", "different boxes", "boxes", gimlet_add_level(sim, r ? box_b : box_a, 1));
  CASE(sim, 0, "gimlet_add_level", "misaligned on rank 1", "aligned", gimlet_add_level(sim, r ? box_mis : box_a, 1));
  CASE(sim, 0, "gimlet_add_level", "nboxes 0 on rank 1", "nboxes", gimlet_add_level(sim, box_a, r ? 0 : 1));
  CASE(sim, 0, "gimlet_set_patch_size", "different px", "px", gimlet_set_patch_size(sim, 0, r ? 8 : 16, 16));
  CASE(sim, 0, "gimlet_set_patch_size", "py -1 on rank 1", "py", gimlet_set_patch_size(sim, 0, 16, r ? -1 : 16));
  EXPECT_OK(gimlet_add_level(sim, box_a, 1));
  EXPECT_OK(gimlet_set_patch_size(sim, 0, 16, 16));
  CASE(sim, 0, "gimlet_set_nesting_buffer", "different cells after a level", "cells",
       gimlet_set_nesting_buffer(sim, r ? 5 : 4));

  /* Materials. */
  int id = -1;
  CASE(sim, 0, "gimlet_add_material_linear_elastic", "different e", "e",
       gimlet_add_material_linear_elastic(sim, r ? 2e9 : 1e9, 0.3, 1000, &id));
  CASE(sim, 0, "gimlet_add_material_linear_elastic", "nu 0.5 on rank 1", "nu",
       gimlet_add_material_linear_elastic(sim, 1e9, r ? 0.5 : 0.3, 1000, &id));
  CASE(sim, 0, "gimlet_add_material_neo_hookean", "different rho", "rho",
       gimlet_add_material_neo_hookean(sim, 1e9, 0.3, r ? 2000 : 1000, &id));
  CASE(sim, 0, "gimlet_add_material_neo_hookean", "id NULL on rank 1", "id",
       gimlet_add_material_neo_hookean(sim, 1e9, 0.3, 1000, r ? NULL : &id));
  CASE(sim, 0, "gimlet_add_material_j2_linear", "different sigma_y", "sigma_y",
       gimlet_add_material_j2_linear(sim, 1e9, 0.3, 1000, r ? 2e6 : 1e6, 0, &id));
  CASE(sim, 0, "gimlet_add_material_j2_linear", "h -1 on rank 1", "h",
       gimlet_add_material_j2_linear(sim, 1e9, 0.3, 1000, 1e6, r ? -1.0 : 0.0, &id));
  CASE(sim, 0, "gimlet_add_material_j2_power", "different n", "n",
       gimlet_add_material_j2_power(sim, 1e9, 0.3, 1000, 1e6, r ? 0.2 : 0.1, 1e-3, &id));
  CASE(sim, 0, "gimlet_add_material_j2_power", "eps_0 0 on rank 1", "eps_0",
       gimlet_add_material_j2_power(sim, 1e9, 0.3, 1000, 1e6, 0.1, r ? 0.0 : 1e-3, &id));
  EXPECT_TRUE(id == -1);
  EXPECT_OK(gimlet_add_material_linear_elastic(sim, 1e9, 0.3, 1000, &id));
  EXPECT_TRUE(id == 0);
  /* Different calls: adding a material on rank 1 while rank 0 fills (both
   * with valid arguments), and the other way round. */
  CASE(sim, 0, "gimlet_fill_rectangle", "rank 1 in gimlet_add_material_neo_hookean", "different calls",
       r ? gimlet_add_material_neo_hookean(sim, 1e9, 0.3, 1000, &id) : gimlet_fill_rectangle(sim, 0, 0, 8, 2, 2, 0, 1000, 0, 0, NULL));
  CASE(sim, 0, "gimlet_add_material_neo_hookean", "rank 1 in gimlet_fill_rectangle", "different calls",
       r ? gimlet_fill_rectangle(sim, 0, 0, 8, 2, 2, 0, 1000, 0, 0, NULL) : gimlet_add_material_neo_hookean(sim, 1e9, 0.3, 1000, &id));
  EXPECT_TRUE(id == 0);

  /* Particles: insertion (per-rank arrays) and fill. */
  double x[2] = {0.6 + r, 1.1 + r}, y[2] = {0.6, 0.6}, lp[2] = {0.0625, 0.0625}, v0[2] = {0, 0};
  double rho[2] = {1000, 1000}, xbad[2] = {0.6, 99};
  int mat[2] = {0, 0};
  CASE(sim, 0, "gimlet_insert_particles", "x outside on rank 1", "outside",
       gimlet_insert_particles(sim, 2, r ? xbad : x, y, lp, lp, v0, v0, NULL, rho, mat));
  double vbig[2] = {0, 1e200};
  CASE(sim, 0, "gimlet_insert_particles", "vy 1e200 on rank 1", "vy",
       gimlet_insert_particles(sim, 2, x, y, lp, lp, v0, r ? vbig : v0, NULL, rho, mat));
  CASE(sim, 0, "gimlet_fill_rectangle", "different density", "density",
       gimlet_fill_rectangle(sim, 0, 0, 8, 2, 2, 0, r ? 2000 : 1000, 0, 0, NULL));
  CASE(sim, 0, "gimlet_fill_rectangle", "different rectangle", "xhi",
       gimlet_fill_rectangle(sim, 0, 0, r ? 7 : 8, 2, 2, 0, 1000, 0, 0, NULL));
  CASE(sim, 0, "gimlet_fill_rectangle", "material 3 on rank 1", "material",
       gimlet_fill_rectangle(sim, 0, 0, 8, 2, 2, r ? 3 : 0, 1000, 0, 0, NULL));
  EXPECT_OK(gimlet_insert_particles(sim, 2, x, y, lp, lp, v0, v0, NULL, rho, mat));
  int64_t added = 0;
  EXPECT_OK(gimlet_fill_rectangle(sim, 0, 0, 8, 2, 2, 0, 1000, 0, 0, &added));
  EXPECT_TRUE(added > 0);
  CASE(sim, 1, "gimlet_fill_rectangle", "rank 1 in gimlet_add_material_neo_hookean (particles exist)",
       "different calls",
       r ? gimlet_add_material_neo_hookean(sim, 1e9, 0.3, 1000, &id) : gimlet_fill_rectangle(sim, 0, 2, 8, 3, 2, 0, 1000, 0, 0, NULL));
  EXPECT_TRUE(id == 0);

  /* Run settings. */
  CASE(sim, 1, "gimlet_set_shape", "different shape", "shape", gimlet_set_shape(sim, r ? GIMLET_SHAPE_MPM : GIMLET_SHAPE_CPGIMP));
  CASE(sim, 1, "gimlet_set_shape", "7 on rank 1", "shape", gimlet_set_shape(sim, r ? 7 : GIMLET_SHAPE_CPGIMP));
  CASE(sim, 1, "gimlet_set_scheme", "different scheme", "scheme", gimlet_set_scheme(sim, r ? GIMLET_SCHEME_USF : GIMLET_SCHEME_USL));
  CASE(sim, 1, "gimlet_set_scheme", "-1 on rank 1", "scheme", gimlet_set_scheme(sim, r ? -1 : GIMLET_SCHEME_USL));
  CASE(sim, 1, "gimlet_set_flip", "different flip", "flip", gimlet_set_flip(sim, r ? 0.9 : 0.95));
  CASE(sim, 1, "gimlet_set_flip", "1.5 on rank 1", "flip", gimlet_set_flip(sim, r ? 1.5 : 0.95));
  CASE(sim, 1, "gimlet_set_transfer", "different transfer", "transfer",
       gimlet_set_transfer(sim, r ? GIMLET_TRANSFER_APIC : GIMLET_TRANSFER_FLIP));
  CASE(sim, 1, "gimlet_set_transfer", "3 on rank 1", "transfer", gimlet_set_transfer(sim, r ? 3 : GIMLET_TRANSFER_FLIP));
  CASE(sim, 1, "gimlet_set_xpic_order", "different order", "order", gimlet_set_xpic_order(sim, r ? 3 : 5));
  CASE(sim, 1, "gimlet_set_xpic_order", "0 on rank 1", "xpic order", gimlet_set_xpic_order(sim, r ? 0 : 5));
  CASE(sim, 1, "gimlet_set_cfl", "different cfl", "cfl", gimlet_set_cfl(sim, r ? 0.4 : 0.3));
  CASE(sim, 1, "gimlet_set_cfl", "0 on rank 1", "cfl", gimlet_set_cfl(sim, r ? 0.0 : 0.3));
  CASE(sim, 1, "gimlet_set_gravity", "different gy", "gy", gimlet_set_gravity(sim, 0, r ? -9.8 : -9.81));
  CASE(sim, 1, "gimlet_set_gravity", "1e300 on rank 1", "gravity", gimlet_set_gravity(sim, 0, r ? 1e300 : -9.81));
  CASE(sim, 1, "gimlet_set_face_bc", "different face", "face", gimlet_set_face_bc(sim, r ? GIMLET_FACE_LEFT : GIMLET_FACE_BOTTOM, GIMLET_BC_FIXED));
  CASE(sim, 1, "gimlet_set_face_bc", "bc 9 on rank 1", "bc", gimlet_set_face_bc(sim, GIMLET_FACE_BOTTOM, r ? 9 : GIMLET_BC_FIXED));
  CASE(sim, 1, "gimlet_set_load_ramp", "different t_ramp", "t_ramp", gimlet_set_load_ramp(sim, r ? 2e-3 : 1e-3));
  CASE(sim, 1, "gimlet_set_load_ramp", "-1 on rank 1", "t_ramp", gimlet_set_load_ramp(sim, r ? -1 : 1e-3));
  CASE(sim, 1, "gimlet_set_outflow", "different policy", "policy", gimlet_set_outflow(sim, r ? GIMLET_OUTFLOW_REMOVE : GIMLET_OUTFLOW_FAIL));
  CASE(sim, 1, "gimlet_set_outflow", "3 on rank 1", "policy", gimlet_set_outflow(sim, r ? 3 : GIMLET_OUTFLOW_FAIL));
  CASE(sim, 1, "gimlet_apply_traction", "different ty", "ty",
       gimlet_apply_traction(sim, GIMLET_FACE_TOP, 2, 0, 8, 0, r ? -2e6 : -1e6, NULL));
  CASE(sim, 1, "gimlet_apply_traction", "lo > hi on rank 1", "lo",
       gimlet_apply_traction(sim, GIMLET_FACE_TOP, 2, r ? 9 : 0, 8, 0, -1e6, NULL));
  CASE(sim, 1, "gimlet_apply_follower_traction", "different follow", "follow",
       gimlet_apply_follower_traction(sim, GIMLET_FACE_TOP, 2, 0, 8, 0, -1e6, r ? GIMLET_FOLLOW_FACE : GIMLET_FOLLOW_AREA,
                                      NULL));
  CASE(sim, 1, "gimlet_apply_follower_traction", "different tx", "tx",
       gimlet_apply_follower_traction(sim, GIMLET_FACE_TOP, 2, 0, 8, r ? 1e5 : 0, -1e6, GIMLET_FOLLOW_AREA, NULL));
  CASE(sim, 1, "gimlet_apply_follower_traction", "follow 5 on rank 1", "follow",
       gimlet_apply_follower_traction(sim, GIMLET_FACE_TOP, 2, 0, 8, 0, -1e6, r ? 5 : GIMLET_FOLLOW_AREA, NULL));

  /* Indenters, their motion, the contact options. */
  int ind = -1;
  CASE(sim, 1, "gimlet_add_indenter_wedge", "different half-angle", "half_angle_deg",
       gimlet_add_indenter_wedge(sim, r ? 70.0 : 65.0, 2, 4, 8, &ind));
  CASE(sim, 1, "gimlet_add_indenter_wedge", "height NaN on rank 1", "height",
       gimlet_add_indenter_wedge(sim, 65.0, r ? nan : 2, 4, 8, &ind));
  CASE(sim, 1, "gimlet_add_indenter_cylinder", "different radius", "radius",
       gimlet_add_indenter_cylinder(sim, r ? 2.0 : 1.0, 4, 8, &ind));
  CASE(sim, 1, "gimlet_add_indenter_cylinder", "radius 0 on rank 1", "radius",
       gimlet_add_indenter_cylinder(sim, r ? 0.0 : 1.0, 4, 8, &ind));
  CASE(sim, 1, "gimlet_add_indenter_flat_punch", "different corner radius", "corner_radius",
       gimlet_add_indenter_flat_punch(sim, 1.0, r ? 0.2 : 0.1, 1, 4, 8, &ind));
  CASE(sim, 1, "gimlet_add_indenter_flat_punch", "corner radius > half-width on rank 1", "corner_radius",
       gimlet_add_indenter_flat_punch(sim, 1.0, r ? 2.0 : 0.1, 1, 4, 8, &ind));
  {
    double sq[8] = {-1, 0, 1, 0, 1, 1, -1, 1}, sq2[8] = {-1, 0, 1, 0, 1, 2, -1, 2};
    double bow[8] = {0, 0, 2, 1, 0, 2, 1, 1}; /* a dart: not convex */
    CASE(sim, 1, "gimlet_add_indenter_polygon", "different vertices", "xy",
         gimlet_add_indenter_polygon(sim, 4, r ? sq2 : sq, 4, 8, &ind));
    CASE(sim, 1, "gimlet_add_indenter_polygon", "non-convex on rank 1", "convex",
         gimlet_add_indenter_polygon(sim, 4, r ? bow : sq, 4, 8, &ind));
  }
  EXPECT_OK(gimlet_add_indenter_cylinder(sim, 1.0, 4, 9, &ind));
  {
    double t[2] = {0, 1e-3}, d[2] = {0, 1e-2}, d2[2] = {0, 2e-2}, tb[2] = {1e-3, 0};
    CASE(sim, 1, "gimlet_set_indenter_motion", "different depths", "values",
         gimlet_set_indenter_motion(sim, ind, GIMLET_MOTION_DEPTH, 2, t, r ? d2 : d));
    CASE(sim, 1, "gimlet_set_indenter_motion", "times decreasing on rank 1", "times",
         gimlet_set_indenter_motion(sim, ind, GIMLET_MOTION_DEPTH, 2, r ? tb : t, d));
  }
  CASE(sim, 1, "gimlet_set_indenter_friction", "different mu", "mu",
       gimlet_set_indenter_friction(sim, ind, r ? 0.2 : 0.1));
  CASE(sim, 1, "gimlet_set_indenter_friction", "mu -1 on rank 1", "mu",
       gimlet_set_indenter_friction(sim, ind, r ? -1.0 : 0.1));
  {
    double t[2] = {0, 1e-3}, x[2] = {0, 1e-2}, x2[2] = {0, 2e-2}, tb[2] = {1e-3, 0};
    CASE(sim, 1, "gimlet_set_indenter_lateral", "different x", "x",
         gimlet_set_indenter_lateral(sim, ind, 2, t, r ? x2 : x));
    CASE(sim, 1, "gimlet_set_indenter_lateral", "times decreasing on rank 1", "times",
         gimlet_set_indenter_lateral(sim, ind, 2, r ? tb : t, x));
  }
  CASE(sim, 1, "gimlet_set_contact_option", "different value", "value",
       gimlet_set_contact_option(sim, GIMLET_CONTACT_BAND, r ? 0.1 : 0.05));
  CASE(sim, 1, "gimlet_set_contact_option", "option 9 on rank 1", "option",
       gimlet_set_contact_option(sim, r ? 9 : GIMLET_CONTACT_BAND, 0.05));
  CASE(sim, 1, "gimlet_set_petsc_options", "different options", "options",
       gimlet_set_petsc_options(sim, r ? "-gimlet_contact_ksp_type gmres" : "-gimlet_contact_ksp_type cg"));
  CASE(sim, 1, "gimlet_set_petsc_options", "NULL on rank 1", "options",
       gimlet_set_petsc_options(sim, r ? NULL : "-gimlet_contact_ksp_type cg"));

  /* Fields (per-rank values, collective field index). */
  int64_t nloc = 0;
  EXPECT_OK(gimlet_get_field(sim, GIMLET_FIELD_VELOCITY, NULL, 0, &nloc));
  double *vel = calloc((size_t)(4 * nloc + 4), sizeof(double));
  CASE(sim, 1, "gimlet_set_field", "different field", "fld",
       gimlet_set_field(sim, r ? GIMLET_FIELD_STRESS : GIMLET_FIELD_VELOCITY, vel, nloc));
  if (r == 1 && nloc > 0) vel[1] = nan;
  CASE(sim, 1, "gimlet_set_field", "NaN on rank 1", "values", gimlet_set_field(sim, GIMLET_FIELD_VELOCITY, vel, nloc));
  vel[1] = 0;
  CASE(sim, 1, "gimlet_set_field", "n wrong on rank 1", "local particles",
       gimlet_set_field(sim, GIMLET_FIELD_VELOCITY, vel, r ? nloc + 1 : nloc));
  free(vel);

  /* Queries without collective arguments: invalid outputs, different calls. */
  double sdt = 0;
  CASE(sim, 1, "gimlet_stable_dt", "dt NULL on rank 1", "dt", gimlet_stable_dt(sim, r ? NULL : &sdt));
  int64_t cr = 0, cnt = 0;
  CASE(sim, 1, "gimlet_patch_crossings", "crossings NULL rank 1", "crossings", gimlet_patch_crossings(sim, r ? NULL : &cr));
  CASE(sim, 1, "gimlet_particle_count", "rank 1 in gimlet_diagnostics", "different calls",
       r ? gimlet_diagnostics(sim, NULL, NULL, NULL, NULL, NULL) : gimlet_particle_count(sim, &cnt, &cnt));
  CASE(sim, 1, "gimlet_diagnostics", "rank 1 in gimlet_patch_crossings", "different calls",
       r ? gimlet_patch_crossings(sim, &cr) : gimlet_diagnostics(sim, NULL, NULL, NULL, NULL, NULL));

  /* Steps. */
  EXPECT_OK(gimlet_stable_dt(sim, &sdt));
  CASE(sim, 1, "gimlet_step", "different dt", "dt", gimlet_step(sim, r ? 0.5 * sdt : 0.25 * sdt, NULL, NULL));
  CASE(sim, 1, "gimlet_step", "NaN on rank 1", "dt", gimlet_step(sim, r ? nan : 0.5 * sdt, NULL, NULL));
  CASE(sim, 1, "gimlet_step", "4x stable dt on rank 1", "dt", gimlet_step(sim, r ? 4 * sdt : 0.5 * sdt, NULL, NULL));
  CASE(sim, 1, "gimlet_advance_to", "different t_end", "t_end", gimlet_advance_to(sim, r ? 3 * sdt : 2 * sdt, 10, NULL, NULL));
  CASE(sim, 1, "gimlet_advance_to", "max_steps 0 on rank 1", "max_steps", gimlet_advance_to(sim, 2 * sdt, r ? 0 : 10, NULL, NULL));
  EXPECT_OK(gimlet_step(sim, 0.0, NULL, NULL));
  CASE(sim, 1, "gimlet_fill_rectangle", "rank 1 in gimlet_add_material_neo_hookean (after a step)", "different calls",
       r ? gimlet_add_material_neo_hookean(sim, 1e9, 0.3, 1000, &id) : gimlet_fill_rectangle(sim, 0, 2, 8, 3, 2, 0, 1000, 0, 0, NULL));
  EXPECT_TRUE(id == 0);

  /* Output and checkpoints. */
  CASE(sim, 1, "gimlet_output_open", "different dir", "dir", gimlet_output_open(sim, r ? p_dir_b : p_dir_a, "run"));
  CASE(sim, 1, "gimlet_output_open", "basename a/b on rank 1", "basename", gimlet_output_open(sim, p_dir_a, r ? "a/b" : "run"));
  CASE(sim, 1, "gimlet_write_output", "rank 1 in gimlet_csv_append", "different calls",
       r ? gimlet_csv_append(sim) : gimlet_write_output(sim));
  EXPECT_OK(gimlet_output_open(sim, p_dir_a, "run"));
  EXPECT_OK(gimlet_write_output(sim));
  CASE(sim, 1, "gimlet_csv_open", "different path", "path", gimlet_csv_open(sim, r ? csv_b : csv_a));
  CASE(sim, 1, "gimlet_csv_open", "path NULL on rank 1", "path", gimlet_csv_open(sim, r ? NULL : csv_a));
  CASE(sim, 1, "gimlet_csv_append", "rank 1 in gimlet_write_output", "different calls",
       r ? gimlet_write_output(sim) : gimlet_csv_append(sim));
  EXPECT_OK(gimlet_csv_open(sim, csv_a));
  EXPECT_OK(gimlet_csv_append(sim));
  CASE(sim, 1, "gimlet_check_xdmf", "different path", "path", gimlet_check_xdmf(sim, r ? csv_a : xdmf, &cnt));
  CASE(sim, 1, "gimlet_check_xdmf", "items NULL on rank 1", "items", gimlet_check_xdmf(sim, xdmf, r ? NULL : &cnt));
  CASE(sim, 1, "gimlet_write_checkpoint", "different path", "path", gimlet_write_checkpoint(sim, r ? p_b : p_a));
  CASE(sim, 1, "gimlet_write_checkpoint", "empty path on rank 1", "path", gimlet_write_checkpoint(sim, r ? "" : p_a));
  EXPECT_OK(gimlet_write_checkpoint(sim, p_a));
  EXPECT_OK(gimlet_write_checkpoint(sim, p_b));
  CASE(sim, 1, "gimlet_read_checkpoint", "different path", "path", gimlet_read_checkpoint(sim, r ? p_b : p_a));
  CASE(sim, 1, "gimlet_read_checkpoint", "path NULL on rank 1", "path", gimlet_read_checkpoint(sim, r ? NULL : p_a));
  if (selected("gimlet_create_from_checkpoint", "") || selected("gimlet_create_from_checkpoint_f", "")) {
    GimletSim *s2 = NULL;
    int rc = gimlet_create_from_checkpoint(MPI_COMM_WORLD, r ? p_b : p_a, &s2);
    report("gimlet_create_from_checkpoint", "different path", rc, "path");
    EXPECT_TRUE(s2 == NULL);
    rc = gimlet_create_from_checkpoint(MPI_COMM_WORLD, p_a, r ? NULL : &s2);
    report("gimlet_create_from_checkpoint", "out NULL on rank 1", rc, "out");
    EXPECT_TRUE(s2 == NULL);
    MPI_Fint fw = MPI_Comm_c2f(MPI_COMM_WORLD);
    rc = gimlet_create_from_checkpoint_f(fw, r ? p_b : p_a, &s2);
    report("gimlet_create_from_checkpoint_f", "different path", rc, "path");
    EXPECT_TRUE(s2 == NULL);
    rc = gimlet_create_from_checkpoint_f(fw, r ? "" : p_a, &s2);
    report("gimlet_create_from_checkpoint_f", "empty path on rank 1", rc, "path");
    EXPECT_TRUE(s2 == NULL);
    /* And a valid one still works afterwards. */
    EXPECT_OK(gimlet_create_from_checkpoint(MPI_COMM_WORLD, p_a, &s2));
    EXPECT_OK(gimlet_destroy(&s2));
  }

  /* The handle steps on after all of it, and both ranks agree on the state. */
  double t = 0;
  int64_t steps = 0;
  EXPECT_OK(gimlet_step(sim, 0.0, &t, &steps));
  double ts[2];
  MPI_Allgather(&t, 1, MPI_DOUBLE, ts, 1, MPI_DOUBLE, MPI_COMM_WORLD);
  EXPECT_TRUE(ts[0] == ts[1] && steps == 2);
  EXPECT_OK(gimlet_destroy(&sim));

  if (rank == 0)
    printf("test_mismatch: %d cases, %d agreed on both ranks (same error status and message, handle usable and "
           "unchanged)\n",
           rows, agreed);
  EXPECT(rows > 0, "no case matches \"%s\"", only ? only : "");
  return check_end("test_mismatch");
}
