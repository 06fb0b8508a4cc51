/* Rank and patch invariance. Runs a scene on the ranks it is started with
 * and a given patch layout, gathers positions and stresses by global id on
 * rank 0, and either writes them (mode "write") or compares them with a
 * reference file written by a 1-rank, 1-patch run (mode "compare"). The
 * bound is 1e-12 relative: position differences over the largest
 * coordinate, stress differences over the largest stress component (a
 * component that vanishes analytically, like the plate's shear, is measured
 * against the stress scale, not against its own round-off).
 *
 *   rank_invariance write|compare FILE SCENE PATCHES STEPS [WEIGHTS]
 *
 * PATCHES is "PXxPY" (patches along x and y, e.g. 2x1) or one number N for
 * N x N. WEIGHTS is "ugimp_flip" (the default here: uGIMP weights with
 * the FLIP transfer, the paper's, which the examples and the main job use)
 * or "cpgimp_apic" (the library's default, cpGIMP weights with the APIC
 * transfer; both are set explicitly. cpGIMP with APIC is the
 * combination whose affine matrices once depended on the patch layout
 * through the nodes beyond the roller plane that only the tails of the
 * cpGIMP domains reach); the reference must be written with
 * the same WEIGHTS.
 *
 * Scenes: "plate" (vibrating plate, rollers on all faces, amplitude about
 * one cell so particles cross patch boundaries), "plastic" (the plate with
 * J2 power-law plasticity, as in test_restart.c: it yields in the first
 * steps, so the J2 particles' nodal average of the dilatation, summed
 * over patches, is exercised across patch borders) and "pressure" (the
 * paper's indentation of silicon by a ramped surface pressure, half
 * model). */
#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <math.h>
#include "gimlet.h"
#include "weights.h"

static int rank_ = 0;

#define CHECK(call)                                                       \
  do {                                                                    \
    int rc_ = (call);                                                     \
    if (rc_ != GIMLET_OK) {                                               \
      char m_[512];                                                       \
      gimlet_last_error(m_, sizeof m_, NULL);                             \
      fprintf(stderr, "rank %d: %s -> %d: %s\n", rank_, #call, rc_, m_);  \
      MPI_Abort(MPI_COMM_WORLD, 2);                                       \
    }                                                                     \
  } while (0)

typedef struct { uint64_t id; double v[6]; } Rec; /* x, y, sxx, syy, sxy, szz */

static int by_id(const void *a, const void *b) {
  uint64_t x = ((const Rec *)a)->id, y = ((const Rec *)b)->id;
  return x < y ? -1 : x > y;
}

/* The weights and transfer of the run: 1 for cpGIMP with APIC, 0 for
 * uGIMP with FLIP (see the usage notes). */
static int cpgimp_apic = 0;

/* Builds the scene; returns the fixed step size. */
static double setup(GimletSim **sim, const char *scene, int px, int py) {
  if (strcmp(scene, "plate") == 0 || strcmp(scene, "plastic") == 0) {
    const double L = 1.0, h = L / 32, E = 1e4, nu = 0.3, rho = 1.0;
    CHECK(gimlet_create(MPI_COMM_WORLD, 0, 0, L, L, h, sim));
    CHECK(weights_set(*sim, cpgimp_apic));
    CHECK(gimlet_set_patch_size(*sim, 0, (32 + px - 1) / px, (32 + py - 1) / py));
    int m;
    if (strcmp(scene, "plastic") == 0)
      CHECK(gimlet_add_material_j2_power(*sim, E, nu, rho, 0.01 * E, 0.2, 0.01, &m));
    else
      CHECK(gimlet_add_material_neo_hookean(*sim, E, nu, rho, &m));
    for (int f = 0; f < 4; f++) CHECK(gimlet_set_face_bc(*sim, f, GIMLET_BC_ROLLER));
    /* v_i = v0 sin(pi X_i / L), amplitude v0/omega = one cell. */
    double lam = E * nu / ((1 + nu) * (1 - 2 * nu)), mu = E / (2 * (1 + nu));
    double omega = M_PI / L * sqrt((lam + 2 * mu) / rho), v0 = omega * h;
    int np = 32 * 32 * 4, k = 0;
    double *x = malloc(8 * np), *y = malloc(8 * np), *lp = malloc(8 * np), *vx = malloc(8 * np),
           *vy = malloc(8 * np), *d = malloc(8 * np);
    int *mat = malloc(sizeof(int) * np);
    /* Rank 0 inserts the lattice (ids follow its array order, the same on
     * any number of ranks); the library sends each particle to its owner. */
    int mine = 0;
    for (int j = 0; j < 64; j++)
      for (int i = 0; i < 64; i++, k++) {
        if (rank_ != 0) continue;
        x[mine] = (i + 0.5) * h / 2;
        y[mine] = (j + 0.5) * h / 2;
        lp[mine] = h / 4;
        vx[mine] = v0 * sin(M_PI * x[mine] / L);
        vy[mine] = v0 * sin(M_PI * y[mine] / L);
        d[mine] = rho;
        mat[mine] = m;
        mine++;
      }
    CHECK(gimlet_insert_particles(*sim, mine, x, y, lp, lp, vx, vy, NULL, d, mat));
    free(x); free(y); free(lp); free(vx); free(vy); free(d); free(mat);
    double dt;
    CHECK(gimlet_stable_dt(*sim, &dt));
    return 0.8 * dt;
  }
  /* The paper's pressure indentation, half model: 40 um x 40 um silicon,
   * 1 um cells, symmetry roller at x = 0, bottom fixed; pressure 2 GPa on
   * the top surface for x < 5 um, ramped over 1500 steps of 20 ps. */
  const double um = 1e-6;
  CHECK(gimlet_create(MPI_COMM_WORLD, 0, 0, 40 * um, 40 * um, 1 * um, sim));
  CHECK(weights_set(*sim, cpgimp_apic));
  CHECK(gimlet_set_patch_size(*sim, 0, (40 + px - 1) / px, (40 + py - 1) / py));
  CHECK(gimlet_set_thickness(*sim, 1 * um));
  int m;
  CHECK(gimlet_add_material_linear_elastic(*sim, 170e9, 0.18, 2330.0, &m));
  CHECK(gimlet_set_face_bc(*sim, GIMLET_FACE_LEFT, GIMLET_BC_ROLLER));
  CHECK(gimlet_set_face_bc(*sim, GIMLET_FACE_BOTTOM, GIMLET_BC_FIXED));
  CHECK(gimlet_fill_rectangle(*sim, 0, 0, 40 * um, 40 * um, 2, m, 2330.0, 0, 0, NULL));
  int64_t loaded = 0;
  CHECK(gimlet_apply_traction(*sim, GIMLET_FACE_TOP, 40 * um, 0, 5 * um, 0, -2e9, &loaded));
  CHECK(gimlet_set_load_ramp(*sim, 1500 * 20e-12));
  return 20e-12;
}

int main(int argc, char **argv) {
  MPI_Init(&argc, &argv);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  int size;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  if (argc != 6 && argc != 7) {
    if (rank_ == 0)
      fprintf(stderr, "usage: %s write|compare FILE SCENE PXxPY STEPS [ugimp_flip|cpgimp_apic]\n", argv[0]);
    MPI_Finalize();
    return 2;
  }
  if (argc == 7 && (cpgimp_apic = weights_parse(argv[6])) < 0) {
    if (rank_ == 0) fprintf(stderr, "unknown weights %s\n", argv[6]);
    MPI_Finalize();
    return 2;
  }
  const char *mode = argv[1], *file = argv[2], *scene = argv[3];
  int px = 1, py = 1, steps = atoi(argv[5]);
  if (sscanf(argv[4], "%dx%d", &px, &py) != 2) py = px = atoi(argv[4]);
  if (px < 1 || py < 1 || steps < 1) {
    if (rank_ == 0) fprintf(stderr, "PATCHES and STEPS must be positive\n");
    MPI_Finalize();
    return 2;
  }
  GimletSim *sim = NULL;
  double dt = setup(&sim, scene, px, py);
  for (int s = 0; s < steps; s++) CHECK(gimlet_step(sim, dt, NULL, NULL));
  int64_t crossings = 0;
  CHECK(gimlet_patch_crossings(sim, &crossings));
  /* The plate must exercise migration: particles cross patch boundaries. */
  int no_crossing = strcmp(scene, "plate") == 0 && px * py > 1 && crossings == 0;
  if (rank_ == 0)
    printf("%s%s %d ranks %dx%d patches: %lld patch crossings in %d steps\n", scene,
           cpgimp_apic ? " (cpGIMP, APIC)" : "", size, px, py, (long long)crossings, steps);

  int64_t n = 0;
  CHECK(gimlet_get_ids(sim, NULL, 0, &n));
  uint64_t *ids = malloc(8 * (n + 1));
  double *pos = malloc(16 * (n + 1)), *sig = malloc(32 * (n + 1));
  CHECK(gimlet_get_ids(sim, ids, n, &n));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_POSITION, pos, n, &n));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_STRESS, sig, n, &n));
  Rec *mine = malloc(sizeof(Rec) * (n + 1));
  for (int64_t i = 0; i < n; i++) {
    mine[i].id = ids[i];
    mine[i].v[0] = pos[2 * i];
    mine[i].v[1] = pos[2 * i + 1];
    for (int c = 0; c < 4; c++) mine[i].v[2 + c] = sig[4 * i + c];
  }
  int cnt = (int)n * (int)sizeof(Rec), *counts = malloc(sizeof(int) * size), *displ = malloc(sizeof(int) * size);
  MPI_Gather(&cnt, 1, MPI_INT, counts, 1, MPI_INT, 0, MPI_COMM_WORLD);
  int total = 0;
  if (rank_ == 0)
    for (int r = 0; r < size; r++) { displ[r] = total; total += counts[r]; }
  Rec *all = malloc(total + sizeof(Rec));
  MPI_Gatherv(mine, cnt, MPI_BYTE, all, counts, displ, MPI_BYTE, 0, MPI_COMM_WORLD);
  int fail = 0;
  if (rank_ == 0) {
    int64_t nall = total / (int)sizeof(Rec);
    qsort(all, nall, sizeof(Rec), by_id);
    if (strcmp(mode, "write") == 0) {
      FILE *f = fopen(file, "wb");
      if (!f || fwrite(&nall, 8, 1, f) != 1 || fwrite(all, sizeof(Rec), nall, f) != (size_t)nall) fail = 1;
      if (f) fclose(f);
      printf("%s: wrote %lld particles after %d steps (%d ranks, %dx%d patches)\n", scene, (long long)nall, steps, size, px, py);
    } else {
      FILE *f = fopen(file, "rb");
      int64_t nref = -1;
      if (!f || fread(&nref, 8, 1, f) != 1 || nref != nall) {
        fprintf(stderr, "reference %s missing or has %lld particles, this run has %lld\n", file, (long long)nref, (long long)nall);
        fail = 1;
      } else {
        Rec *ref = malloc(sizeof(Rec) * (nref + 1));
        if (fread(ref, sizeof(Rec), nref, f) != (size_t)nref) fail = 1;
        double scale[6] = {0}, err[6] = {0};
        for (int64_t i = 0; i < nall && !fail; i++) {
          if (ref[i].id != all[i].id) { fail = 1; fprintf(stderr, "id mismatch at %lld\n", (long long)i); break; }
          for (int c = 0; c < 6; c++) {
            scale[c] = fmax(scale[c], fabs(ref[i].v[c]));
            err[c] = fmax(err[c], fabs(ref[i].v[c] - all[i].v[c]));
          }
        }
        const char *names[6] = {"x", "y", "sxx", "syy", "sxy", "szz"};
        double pscale = fmax(scale[0], scale[1]), sscale = 0;
        for (int c = 2; c < 6; c++) sscale = fmax(sscale, scale[c]);
        for (int c = 0; c < 6 && !fail; c++) {
          double sc = c < 2 ? pscale : sscale;
          double rel = sc > 0 ? err[c] / sc : err[c];
          printf("%s %d ranks %dx%d patches: max |d%s| / %s scale = %.3e\n", scene, size, px, py, names[c], c < 2 ? "position" : "stress", rel);
          if (!(rel <= 1e-12)) fail = 1;
        }
        free(ref);
      }
      if (f) fclose(f);
    }
  }
  MPI_Bcast(&fail, 1, MPI_INT, 0, MPI_COMM_WORLD);
  if (no_crossing) {
    if (rank_ == 0) fprintf(stderr, "no particle crossed a patch boundary: the test does not exercise migration\n");
    fail = 1;
  }
  CHECK(gimlet_destroy(&sim));
  free(ids); free(pos); free(sig); free(mine); free(counts); free(displ); free(all);
  MPI_Finalize();
  return fail;
}
