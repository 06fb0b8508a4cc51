/* A flat punch pushed slowly into the paper's aluminium block, starting
 * from rest: the quasi-static loading a user runs, with the library's
 * default scheme (cpGIMP, MUSL, APIC).
 *
 * The block, levels and patches are those of wedge_indentation.c (a
 * 60 um x 40 um block modelled by its half, x in [0, W] with the symmetry
 * plane at x = 0 (roller) and the bottom fixed in y (roller), 2 x 2
 * particles per cell; level l covers [0, B / 2^(l-1)] x [H - B / 2^(l-1),
 * H + 1 um] with B = 10 um; 2 x 2 patches per level). The punch is flat,
 * half-width 2 um, sharp corners, its face centred on the symmetry axis at
 * the top surface. Its depth follows
 *
 *   d(t) = D (t/T - sin(2 pi t/T) / (2 pi)),   T = 2 D / v_peak,
 *
 * zero speed and acceleration at the start, peak speed v_peak at T/2, at
 * rest at depth D at T (given to the library as the speed D/T (1 - cos(2 pi
 * t/T)) sampled at 2001 points, linear in between).
 *
 *   slow_punch [--material elastic|j2] [--levels L] [--h0 M] [--uniform M] [--depth M]
 *              [--peak-speed V] [--stop M] [--width M] [--height M] [--box M]
 *              [--every N] [--watch N] [--check-fast V TOL] [--check-linear TOL]
 *
 *   --material K  j2 (default: elastic-perfectly-plastic aluminium, E = 70
 *                 GPa, nu = 0.33, sigma_y = 300 MPa, no hardening) or elastic
 *   --levels L    number of levels (default 3: 500/250/125 nm)
 *   --h0 M        coarse cell size (default 5e-7)
 *   --uniform M   one level of cell size M instead (e.g. 1.25e-7)
 *   --depth M     D, the final depth (default 2e-7)
 *   --peak-speed V  v_peak (default 0.5 m/s)
 *   --stop M      stop once the depth reaches M (default: D)
 *   --width M, --height M  the half block's width and height (default 30e-6,
 *                 40e-6)
 *   --box M       B, the width of level 1's box (default 10e-6)
 *   --every N     a progress line every N coarse steps (default 500; 0: none)
 *   --watch N     every N coarse steps, the owned particle with the largest
 *                 speed (level, position, velocity)
 *   --check-fast V TOL  then push the same scene at peak speed V to 10 nm
 *                 and exit with status 1 unless the two loads at 10 nm agree
 *                 within TOL (relative) and no step was refused
 *   --check-linear TOL  exit with status 1 unless no step was refused and
 *                 the load at the end over the load at 10 nm is the ratio
 *                 of the depths within TOL (relative): a rigid flat punch
 *                 keeps its contact width, so while the yielded zones at
 *                 its corners stay small the load is linear in the depth
 *                 (the test slow_punch_levels_j2_np2: 0.997 from 10 to
 *                 12 nm; 0 before the fix of the J2 ring field, whose
 *                 load fell to nothing)
 *
 * Prints the load on the full (mirrored) body per metre of thickness,
 * linearly interpolated between steps, when the depth passes 10, 50, 100 and
 * 200 nm (those reached), as lines "load at <d> nm: <P> N/m", and the load
 * at the end. A refused step (a particle would leave the domain) is printed
 * with the library's message and ends the run with status 1. */
#include <math.h>
#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "gimlet.h"

static int rank_ = 0;
/* The depth and load at the end of the last run. */
static double final_depth_ = 0, final_load_ = 0;

#define CHECK(call)                                                      \
  do {                                                                   \
    if ((call) != GIMLET_OK) {                                           \
      char m_[1024];                                                     \
      gimlet_last_error(m_, sizeof m_, NULL);                            \
      fprintf(stderr, "rank %d: %s failed: %s\n", rank_, #call, m_);     \
      MPI_Abort(MPI_COMM_WORLD, 1);                                      \
    }                                                                    \
  } while (0)

/* Prints the owned particle with the largest speed (id, level, position,
 * velocity) over all ranks. */
static void fastest(GimletSim *sim, int64_t step) {
  int64_t n = 0;
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_POSITION, NULL, 0, &n));
  double *p = malloc(sizeof(double) * (2 * n + 2)), *v = malloc(sizeof(double) * (2 * n + 2)),
         *lev = malloc(sizeof(double) * (n + 1));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_POSITION, p, n, &n));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_VELOCITY, v, n, &n));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_LEVEL, lev, n, &n));
  struct { double s; int r; } best = {-1, rank_}, all;
  double mine[5] = {0};
  for (int64_t i = 0; i < n; i++) {
    double s = hypot(v[2 * i], v[2 * i + 1]);
    if (s > best.s) {
      best.s = s;
      mine[0] = p[2 * i], mine[1] = p[2 * i + 1], mine[2] = v[2 * i], mine[3] = v[2 * i + 1], mine[4] = lev[i];
    }
  }
  MPI_Allreduce(&best, &all, 1, MPI_DOUBLE_INT, MPI_MAXLOC, MPI_COMM_WORLD);
  MPI_Bcast(mine, 5, MPI_DOUBLE, all.r, MPI_COMM_WORLD);
  if (rank_ == 0)
    printf("  step %6lld fastest: level %.0f at (%.4f, %.4f) um, v = (%.4g, %.4g) m/s\n", (long long)step,
           mine[4], mine[0] * 1e6, mine[1] * 1e6, mine[2], mine[3]);
  free(p), free(v), free(lev);
}

/* The set-up of a run (see the comment at the top). */
typedef struct {
  int levels, j2, every, watch;
  double h0, uniform, D, vpeak, stop, W, Hb, B;
} Setup;

/* Runs the push of `c` and returns the load at 10 nm (NAN when not
 * reached); 1 in *refused when a step was refused (a particle would leave
 * the domain). */
static double run(Setup c, int *refused) {
  int levels = c.levels, j2 = c.j2, every = c.every, watch = c.watch;
  double h0 = c.h0, uniform = c.uniform, D = c.D, vpeak = c.vpeak, stop = c.stop, W = c.W, Hb = c.Hb, B = c.B;
  const double um = 1e-6;
  double load10 = NAN;
  *refused = 0;
  if (uniform > 0) h0 = uniform, levels = 1;
  if (!(stop > 0) || stop > D) stop = D;
  const double top = 1 * um, right = 1 * um;
  GimletSim *sim = NULL;
  CHECK(gimlet_create(MPI_COMM_WORLD, 0, 0, W + right, Hb + top, h0, &sim));
  CHECK(gimlet_set_thickness(sim, 1 * um));
  for (int l = 1; l < levels; l++) {
    double w = B / (1 << (l - 1));
    double box[4] = {0, Hb - w, w, Hb + top};
    CHECK(gimlet_add_level(sim, box, 1));
  }
  for (int l = 0; l < levels; l++) {
    int nboxes, npatches;
    int64_t count = 0;
    double hl, b[4];
    CHECK(gimlet_level_info(sim, l, &hl, &nboxes, &npatches));
    CHECK(gimlet_level_boxes(sim, l, b, 1, &count));
    int wx = (int)lround((b[2] - b[0]) / hl) + (l ? 4 : 0), wy = (int)lround((b[3] - b[1]) / hl) + (l ? 4 : 0);
    CHECK(gimlet_set_patch_size(sim, l, (wx + 1) / 2, (wy + 1) / 2));
  }
  int al;
  const double E = 70e9, nu = 0.33, rho = 2700.0;
  if (j2)
    CHECK(gimlet_add_material_j2_linear(sim, E, nu, rho, 300e6, 0.0, &al));
  else
    CHECK(gimlet_add_material_linear_elastic(sim, E, nu, rho, &al));
  CHECK(gimlet_set_face_bc(sim, GIMLET_FACE_LEFT, GIMLET_BC_ROLLER));
  CHECK(gimlet_set_face_bc(sim, GIMLET_FACE_BOTTOM, GIMLET_BC_ROLLER));
  CHECK(gimlet_fill_rectangle(sim, 0, 0, W, Hb, 2, al, rho, 0, 0, NULL));
  int punch;
  CHECK(gimlet_add_indenter_flat_punch(sim, 2 * um, 0.0, 5 * um, 0.0, Hb, &punch));
  const double T = 2 * D / vpeak;
  enum { K = 2001 };
  double *ts = malloc(sizeof(double) * K), *vs = malloc(sizeof(double) * K);
  for (int k = 0; k < K; k++) {
    ts[k] = T * k / (K - 1);
    vs[k] = D / T * (1 - cos(2 * M_PI * k / (K - 1)));
  }
  CHECK(gimlet_set_indenter_motion(sim, punch, GIMLET_MOTION_VELOCITY, K, ts, vs));
  free(ts);
  free(vs);
  double dt0;
  CHECK(gimlet_stable_dt(sim, &dt0));
  const int64_t nsteps = (int64_t)ceil(T / (0.8 * dt0));
  const double dt = T / (double)nsteps;
  if (rank_ == 0)
    printf("slow punch: %s, %d level(s) (finest cell %.4g nm), depth %g nm at peak speed %g m/s over %g ns, "
           "%lld coarse steps of %.4g s\n",
           j2 ? "J2 perfectly plastic" : "linear elastic", levels, h0 / (1 << (levels - 1)) * 1e9, D * 1e9,
           vpeak, T * 1e9, (long long)nsteps, dt);
  const double marks[4] = {10e-9, 50e-9, 100e-9, 200e-9};
  int next_mark = 0;
  double d_prev = 0, load_prev = 0, t = 0, wall = MPI_Wtime();
  for (int64_t step = 1; step <= nsteps; step++) {
    int64_t steps;
    int rc = gimlet_step(sim, dt, &t, &steps);
    if (rc == GIMLET_ERR_PARTICLES_LEFT) {
      char m[1024];
      gimlet_last_error(m, sizeof m, NULL);
      if (rank_ == 0) fprintf(stderr, "step %lld (depth %.4g nm): %s\n", (long long)step, d_prev * 1e9, m);
      *refused = 1;
      break;
    }
    CHECK(rc);
    double d, f[2];
    int64_t nc;
    CHECK(gimlet_indenter_state(sim, punch, &d, NULL, f, &nc));
    double load = 2 * f[1];
    while (next_mark < 4 && d >= marks[next_mark] - 1e-15) {
      double s = d > d_prev ? (marks[next_mark] - d_prev) / (d - d_prev) : 1.0;
      double lm = load_prev + s * (load - load_prev);
      if (rank_ == 0) printf("load at %g nm: %.6g N/m\n", marks[next_mark] * 1e9, lm);
      if (next_mark == 0) load10 = lm;
      next_mark++;
    }
    if (rank_ == 0 && every > 0 && step % every == 0) {
      printf("  step %6lld  t %8.3f ns  depth %7.3f nm  load %10.4f N/m  contacts %4lld  wall %.0f s\n",
             (long long)step, t * 1e9, d * 1e9, load, (long long)nc, MPI_Wtime() - wall);
      fflush(stdout);
    }
    if (watch > 0 && step % watch == 0) fastest(sim, step);
    d_prev = d, load_prev = load;
    if (d >= stop - 1e-15) break;
  }
  if (rank_ == 0) printf("final: depth %.4g nm, load %.6g N/m, wall %.1f s\n", d_prev * 1e9, load_prev, MPI_Wtime() - wall);
  final_depth_ = d_prev, final_load_ = load_prev;
  CHECK(gimlet_destroy(&sim));
  return load10;
}

int main(int argc, char **argv) {
  MPI_Init(&argc, &argv);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  const double um = 1e-6;
  int levels = 3, j2 = 1, every = 500, watch = 0;
  double h0 = 0.5 * um, uniform = 0, D = 0.2 * um, vpeak = 0.5, stop = 0, W = 30 * um, Hb = 40 * um, B = 10 * um;
  double check_speed = 0, check_tol = 0, linear_tol = 0;
  for (int i = 1; i < argc; i++) {
    const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : "";
    if (!strcmp(a, "--material")) {
      if (!strcmp(v, "j2")) j2 = 1;
      else if (!strcmp(v, "elastic")) j2 = 0;
      else {
        if (rank_ == 0) fprintf(stderr, "--material %s: must be elastic or j2\n", v);
        MPI_Finalize();
        return 2;
      }
      i++;
    } else if (!strcmp(a, "--levels")) levels = atoi(v), i++;
    else if (!strcmp(a, "--uniform")) uniform = atof(v), i++;
    else if (!strcmp(a, "--h0")) h0 = atof(v), i++;
    else if (!strcmp(a, "--depth")) D = atof(v), i++;
    else if (!strcmp(a, "--peak-speed")) vpeak = atof(v), i++;
    else if (!strcmp(a, "--stop")) stop = atof(v), i++;
    else if (!strcmp(a, "--width")) W = atof(v), i++;
    else if (!strcmp(a, "--height")) Hb = atof(v), i++;
    else if (!strcmp(a, "--box")) B = atof(v), i++;
    else if (!strcmp(a, "--every")) every = atoi(v), i++;
    else if (!strcmp(a, "--watch")) watch = atoi(v), i++;
    else if (!strcmp(a, "--check-linear")) linear_tol = atof(v), i++;
    else if (!strcmp(a, "--check-fast") && i + 2 < argc) check_speed = atof(v), check_tol = atof(argv[i + 2]), i += 2;
    else {
      if (rank_ == 0) fprintf(stderr, "unknown argument %s (see the comment at the top of slow_punch.c)\n", a);
      MPI_Finalize();
      return 2;
    }
  }
  Setup c = {levels, j2, every, watch, h0, uniform, D, vpeak, stop, W, Hb, B};
  int refused = 0;
  double slow = run(c, &refused), fast = NAN;
  int status = refused;
  if (linear_tol > 0) {
    double ratio = (final_load_ / slow) / (final_depth_ / 10e-9);
    int ok = !refused && isfinite(slow) && slow > 0 && final_depth_ > 10.5e-9 && fabs(ratio - 1) <= linear_tol;
    if (rank_ == 0)
      printf("check: load %.6g N/m at %.4g nm over %.6g N/m at 10 nm, over the depth ratio: %.4f (bound 1 +- %g): %s\n",
             final_load_, final_depth_ * 1e9, slow, ratio, linear_tol, ok ? "ok" : "FAILED");
    status |= !ok;
  }
  if (check_speed > 0) {
    /* The same scene pushed fast to 10 nm: the reference of the check. */
    c.vpeak = check_speed;
    c.stop = 10.5e-9;
    c.watch = 0;
    int refused_fast = 0;
    fast = run(c, &refused_fast);
    int ok = !refused && !refused_fast && isfinite(slow) && isfinite(fast) && fabs(slow / fast - 1) <= check_tol;
    if (rank_ == 0)
      printf("check: load at 10 nm %.6g N/m at peak speed %g m/s, %.6g N/m at %g m/s: ratio %.4f (bound 1 +- %g): %s\n",
             slow, vpeak, fast, check_speed, slow / fast, check_tol, ok ? "ok" : "FAILED");
    status |= !ok;
  }
  MPI_Finalize();
  return status;
}
