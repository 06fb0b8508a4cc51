/* Contact with rigid indenters through the C API, each case against a bound
 * that means something. The scenes (Block in scenes.h) are an
 * elastic block, half model (symmetry plane x = 0), bottom on rollers,
 * E = 1e7 Pa, nu = 0.3, rho = 1000 kg/m^3 (P-wave speed 116 m/s), 1 x 1 m,
 * with nested levels refining the corner under the indenter.
 *
 *   test_contact early       no early contact: a punch, a cylinder and a
 *                            wedge brought to rest 0.1 fine cell above the
 *                            block put exactly zero force on it and leave it
 *                            bitwise at rest
 *   test_contact separation  no late separation: a pressed punch withdrawn
 *                            faster than the surface can follow lets go by
 *                            the step after the geometric separation, not
 *                            while pressed in; on 2 levels its held load
 *                            within 1 % of the uniform fine twin's
 *   test_contact punch       flat punch: the pressure profile against the
 *                            half-space form P / (pi sqrt(a^2 - x^2)) for
 *                            |x| < 0.8 a, and the load at a given depth
 *                            converging under refinement (2, 3, 4 levels)
 *   test_contact hertz       rigid cylinder (Hertz line contact): contact
 *                            half-width and peak pressure against
 *                            a^2 = 4PR/(pi E*), p0 = 2P/(pi a) within 5 %, and
 *                            the profile's RMS error over |x| < 0.9 a
 *   test_contact separation_cpgimp, hertz_cpgimp
 *                            the same two with cpGIMP particles (whose
 *                            positions follow MUSL's re-mapped velocity)
 *   test_contact quasistatic halving the indenter speed changes the load at
 *                            the final depth by less than 1 %
 *   test_contact write FILE  the invariance scene (3 levels, a cylinder
 *                            pressed and released), its load history and
 *                            final contact pressures written to FILE
 *   test_contact compare FILE PXxPY [petsc] [friction]
 *                            the same scene with PX x PY patches per level
 *                            on this many ranks (with `petsc`, every linear
 *                            solve through PETSc): every load and pressure
 *                            within 1e-10 relative of FILE
 *
 * Every case runs on any number of ranks. */
#include "scenes.h"

/* Advances to time `t_end` with stable steps. */
static void run_to(GimletSim *sim, double t_end) {
  double t = 0;
  MUST(gimlet_time(sim, &t, NULL));
  while (t < t_end * (1 - 1e-12)) {
    double dt;
    MUST(gimlet_stable_dt(sim, &dt));
    if (t + dt > t_end) dt = t_end - t;
    MUST(gimlet_step(sim, dt, &t, NULL));
  }
}

/* Depth history: a smooth (cosine) ramp from 0 to `d` over [t0, t0 + tr],
 * sampled at K points, constant after. */
enum { K = 33 };
static void ramp_depth(GimletSim *sim, int ind, double d, double tr) {
  double t[K], v[K];
  for (int i = 0; i < K; i++) {
    double s = (double)i / (K - 1);
    t[i] = s * tr;
    v[i] = d * 0.5 * (1 - cos(M_PI * s));
  }
  MUST(gimlet_set_indenter_motion(sim, ind, GIMLET_MOTION_DEPTH, K, t, v));
}

/* Time averages over `steps` steps of the indenter's vertical force, and of
 * each contact particle's pressure (by id, ids < nid; NAN where never in
 * contact); `xs` receives each one's last x. */
static double hold_average(GimletSim *sim, int ind, int steps, double *p, double *xs, int64_t nid) {
  double acc = 0;
  int *seen = calloc(nid, sizeof(int));
  for (int64_t i = 0; i < nid; i++) p[i] = 0, xs[i] = NAN;
  for (int k = 0; k < steps; k++) {
    MUST(gimlet_step(sim, 0, NULL, NULL));
    double f[2];
    MUST(gimlet_indenter_state(sim, ind, NULL, NULL, f, NULL));
    acc += f[1];
    Contacts c = contacts_get(sim, ind);
    for (int64_t i = 0; i < c.n; i++)
      if (c.id[i] >= 0 && c.id[i] < nid) {
        p[c.id[i]] += c.p[i];
        xs[c.id[i]] = c.x[2 * i];
        seen[c.id[i]] = 1;
      }
    contacts_free(&c);
  }
  for (int64_t i = 0; i < nid; i++) p[i] = seen[i] ? p[i] / steps : NAN;
  free(seen);
  return acc / steps;
}

static int64_t global_count(GimletSim *sim) {
  int64_t n = 0;
  MUST(gimlet_particle_count(sim, NULL, &n));
  return n;
}

/* ------------------------------------------------------------------ early */

static void case_early(void) {
  const char *names[3] = {"flat punch", "cylinder", "wedge"};
  for (int shape = 0; shape < 3; shape++) {
    Block s = block_defaults();
    s.levels = 2;
    s.shape = shape;
    s.size = shape == SHAPE_PUNCH ? 0.125 : shape == SHAPE_CYLINDER ? 0.5 : 65.0;
    double hf = s.h0 / (1 << (s.levels - 1));
    s.gap0 = 2 * hf;
    int ind;
    GimletSim *sim = block_build(&s, &ind);
    int64_t n = 0;
    MUST(gimlet_get_field(sim, GIMLET_FIELD_POSITION, NULL, 0, &n));
    double *x0 = malloc(sizeof(double) * (2 * n + 2)), *x = malloc(sizeof(double) * (2 * n + 2));
    double *v = malloc(sizeof(double) * (2 * n + 2));
    MUST(gimlet_get_field(sim, GIMLET_FIELD_POSITION, x0, n, &n));
    /* Down to 0.1 fine cell above the surface over 20 wave transits of a
     * fine cell... fast enough to be seen within a few hundred steps. */
    double c = wave_speed(&s), tr = 50 * hf / c;
    ramp_depth(sim, ind, s.gap0 - 0.1 * hf, tr);
    double fmax = 0;
    int64_t cmax = 0, steps = 0;
    double t = 0;
    while (t < 2 * tr) {
      MUST(gimlet_step(sim, 0, &t, NULL));
      double f[2];
      int64_t nc;
      MUST(gimlet_indenter_state(sim, ind, NULL, NULL, f, &nc));
      fmax = fmax > fabs(f[0]) + fabs(f[1]) ? fmax : fabs(f[0]) + fabs(f[1]);
      cmax = cmax > nc ? cmax : nc;
      steps++;
    }
    MUST(gimlet_get_field(sim, GIMLET_FIELD_POSITION, x, n, &n));
    MUST(gimlet_get_field(sim, GIMLET_FIELD_VELOCITY, v, n, &n));
    int64_t moved = 0;
    for (int64_t i = 0; i < 2 * n; i++) moved += (x[i] != x0[i]) || (v[i] != 0.0);
    int64_t all_moved = 0;
    MPI_Allreduce(&moved, &all_moved, 1, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);
    double depth, gap;
    MUST(gimlet_indenter_state(sim, ind, &depth, NULL, NULL, NULL));
    gap = s.gap0 - depth;
    int64_t nall = global_count(sim);
    if (rank_ == 0)
      printf("early %-10s: tip stopped %.3g fine cells above the block after %lld steps: largest |force| %g, "
             "largest contact set %lld, particle values changed %lld of %lld\n",
             names[shape], gap / hf, (long long)steps, fmax, (long long)cmax, (long long)all_moved,
             (long long)(2 * nall));
    EXPECT(fabs(gap / hf - 0.1) < 1e-9, "tip %g fine cells above the surface", gap / hf);
    EXPECT(fmax == 0.0, "force %g on an indenter above the block", fmax);
    EXPECT(cmax == 0, "%lld contacts above the block", (long long)cmax);
    EXPECT(all_moved == 0, "%lld particle values changed", (long long)all_moved);
    /* The level statistics count 2^l steps of level l per coarse step. */
    for (int l = 0; l < s.levels; l++) {
      double lt[5];
      int64_t lc[2];
      MUST(gimlet_level_stats(sim, l, lt, lc));
      EXPECT(lc[0] == steps << l, "level %d took %lld steps in %lld coarse steps", l, (long long)lc[0],
             (long long)steps);
      for (int k = 0; k < 5; k++) EXPECT(lt[k] >= 0 && isfinite(lt[k]), "level %d time %d = %g", l, k, lt[k]);
    }
    free(x0);
    free(x);
    free(v);
    MUST(gimlet_destroy(&sim));
  }
}

/* ------------------------------------------------------------- separation */

/* The smallest separation between the (sharp, rectangular) punch
 * {|x| <= a, y >= y_face} and the particles' rectangles, over all ranks:
 * the Euclidean distance when apart, minus the overlap when they overlap. */
static double punch_gap(GimletSim *sim, double a, double y_face) {
  int64_t n = 0;
  MUST(gimlet_get_field(sim, GIMLET_FIELD_POSITION, NULL, 0, &n));
  double *x = malloc(sizeof(double) * (2 * n + 2)), *l = malloc(sizeof(double) * (2 * n + 2));
  MUST(gimlet_get_field(sim, GIMLET_FIELD_POSITION, x, n, &n));
  MUST(gimlet_get_field(sim, GIMLET_FIELD_HALF_LENGTH, l, n, &n));
  double g = INFINITY;
  for (int64_t i = 0; i < n; i++) {
    double dx = fabs(x[2 * i]) - l[2 * i] - a, dy = y_face - (x[2 * i + 1] + l[2 * i + 1]);
    double gi = dx > 0 || dy > 0 ? hypot(dx > 0 ? dx : 0, dy > 0 ? dy : 0) : (dx > dy ? dx : dy);
    if (gi < g) g = gi;
  }
  double all;
  MPI_Allreduce(&g, &all, 1, MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
  free(x);
  free(l);
  return all;
}

static const double SEP_HALF_WIDTH = 0.125; /* the punch's half-width */

/* The separation scene with `weights`: 2 levels (fine cells hf = 1/32), or
 * with `uniform` its uniform twin at the fine cell everywhere. The punch
 * is pressed to d0 = 0.1 hf over 10 transits of the block's height, held
 * for 2, then withdrawn at 0.2 m/s: slower than the released surface
 * first moves (about sigma / (rho c) ~ 0.8 m/s), so the surface follows
 * the punch for a while, pushing less and less, then falls behind.
 * Returns the simulation at the end of the hold; `tt` and `dd` receive the
 * motion's K + 2 points, `*hf` the fine cell, `*ind` the punch. */
static GimletSim *separation_scene(Weights weights, int uniform, int *ind, double *hf, double *tt, double *dd) {
  Block s = block_defaults();
  s.levels = uniform ? 1 : 2;
  if (uniform) s.h0 /= 2;
  s.shape = SHAPE_PUNCH;
  s.size = SEP_HALF_WIDTH;
  s.weights = weights;
  GimletSim *sim = block_build(&s, ind);
  double c = wave_speed(&s), d0;
  *hf = uniform ? s.h0 : s.h0 / 2;
  d0 = 0.1 * *hf;
  double t1 = 10 * s.hb / c, t2 = t1 + 2 * s.hb / c, vw = 0.2;
  for (int i = 0; i < K; i++) {
    double q = (double)i / (K - 1);
    tt[i] = q * t1;
    dd[i] = d0 * 0.5 * (1 - cos(M_PI * q));
  }
  tt[K] = t2;
  dd[K] = d0;
  tt[K + 1] = t2 + 10 * *hf / vw;
  dd[K + 1] = d0 - 10 * *hf;
  MUST(gimlet_set_indenter_motion(sim, *ind, GIMLET_MOTION_DEPTH, K + 2, tt, dd));
  run_to(sim, t2);
  return sim;
}

/* `weights`: UGIMP_FLIP, CPGIMP_FLIP or WEIGHTS_DEFAULT (the library's
 * defaults, cpGIMP with APIC). The force must vanish when the surface
 * leaves the punch: at the first step with zero force the surface is not
 * pressed into the punch by more than 1e-3 fine cells (not early), and the
 * force is zero by the step after the surface is 1e-3 fine cells clear of
 * it (not late). The surface leaves at about 5e-4 fine cells per step, so
 * the force may vanish a few steps before that clearance with the surface
 * just clear (measured, 2026-12-07, coarse velocities prescribed on the
 * fine ghost ring: uGIMP step 61 against 63, gap +1.9e-4 fine cells; the
 * uniform fine twin 7 of its steps early, gap +4.9e-5).
 *
 * With uGIMP weights the load held before the withdrawal is also compared
 * with that of the uniform twin at the fine cell (the punch, 4 fine cells
 * wide, stays inside the refined region): within 1 %. Measured: 23266.5
 * against 23286.3 N/m (-0.09 %); before the fine ghost ring moved with the
 * coarse level the levels held 24457.8 N/m (+5.0 %, the boundary between
 * the levels acting as a spring in series with a dashpot). */
static void case_separation(Weights weights) {
  int ind;
  double hf, tt[K + 2], dd[K + 2];
  GimletSim *sim = separation_scene(weights, 0, &ind, &hf, tt, dd);
  const double d0 = dd[K], vw = 10 * hf / (tt[K + 1] - tt[K]), t2 = tt[K];
  const double hb = block_defaults().hb;
  double f[2];
  MUST(gimlet_indenter_state(sim, ind, NULL, NULL, f, NULL));
  double f_hold = f[1];
  int n_sep = -1, n_zero = -1, late = 0, early_release = 0;
  double t = t2, gap_zero = NAN;
  for (int n = 0; n < 4000 && t < tt[K + 1] && !(n_sep >= 0 && n > n_sep + 100); n++) {
    MUST(gimlet_step(sim, 0, &t, NULL));
    double depth;
    MUST(gimlet_indenter_state(sim, ind, &depth, NULL, f, NULL));
    /* Separated: every particle's rectangle more than 1e-3 fine cells from
     * the punch. (The contact constraint holds the particles' contact faces
     * on the punch; their rectangles, which move with the particle centre,
     * then stay within about 1e-4 cells of it while touching.) */
    double g = punch_gap(sim, SEP_HALF_WIDTH, hb - depth);
    if (getenv("GIMLET_TEST_TRACE") && rank_ == 0) printf("  step %d gap %.3e fine cells, load %.6g\n", n, g / hf, 2 * f[1]);
    if (n_sep < 0 && g > 1e-3 * hf) n_sep = n;
    if (n_zero < 0 && f[1] == 0.0) n_zero = n, gap_zero = g;
    if (n_zero >= 0 && f[1] != 0.0) late++;          /* force came back */
    if (n_sep < 0 && g < -1e-3 * hf && f[1] == 0.0) early_release++;
  }
  if (rank_ == 0)
    printf("separation (%s weights): held at %g fine cells with load %g N/m, withdrawn at %g m/s: surface clear "
           "of the punch from step %d, force zero from step %d with the surface %+.2e fine cells clear (and stays "
           "zero: %s)\n",
           weights_name(weights), d0 / hf, 2 * f_hold, vw, n_sep, n_zero,
           gap_zero / hf, late ? "no" : "yes");
  EXPECT(f_hold > 0, "no load while pressed");
  EXPECT(n_sep >= 0 && n_zero >= 0, "the punch never separated (surface %d, force %d)", n_sep, n_zero);
  EXPECT(n_zero <= n_sep + 1, "force zero at step %d, surface separated at step %d", n_zero, n_sep);
  EXPECT(gap_zero >= -1e-3 * hf, "force zero at step %d with the surface %.3e fine cells into the punch", n_zero,
         -gap_zero / hf);
  if (weights == UGIMP_FLIP) {
    int ind_u;
    double hf_u, tt_u[K + 2], dd_u[K + 2], fu[2];
    GimletSim *twin = separation_scene(weights, 1, &ind_u, &hf_u, tt_u, dd_u);
    MUST(gimlet_indenter_state(twin, ind_u, NULL, NULL, fu, NULL));
    MUST(gimlet_destroy(&twin));
    if (rank_ == 0)
      printf("separation: held load %.6g N/m, the uniform twin at the fine cell %.6g N/m: %+.3f %% (bound 1 %%)\n",
             2 * f_hold, 2 * fu[1], 100 * (f_hold / fu[1] - 1));
    EXPECT(fabs(f_hold / fu[1] - 1) <= 0.01, "held load %g N/m, uniform twin %g N/m", 2 * f_hold, 2 * fu[1]);
  }
  EXPECT(late == 0, "the force came back in %d steps after separation", late);
  EXPECT(early_release == 0, "the force was zero in %d steps while the punch still pressed", early_release);
  MUST(gimlet_destroy(&sim));
}

/* ---------------------------------------------------------------- punch */

/* Presses a flat punch of half-width a to depth d (smoothly over 20 transit
 * times), holds 200 steps; returns the average load on the full punch and
 * (when p != NULL) each particle's average pressure by id. */
static double punch_run(double h0, int levels, double a, double d, double **p, double **xs, int64_t *nid) {
  Block s = block_defaults();
  s.h0 = h0;
  s.levels = levels;
  s.shape = SHAPE_PUNCH;
  s.size = a;
  s.scheme = GIMLET_SCHEME_MUSL;
  s.flip = 0.95;
  int ind;
  GimletSim *sim = block_build(&s, &ind);
  double c = wave_speed(&s), tr = 20 * s.hb / c;
  ramp_depth(sim, ind, d, tr);
  run_to(sim, tr);
  *nid = 4 * global_count(sim);
  double *pp = calloc(*nid, sizeof(double)), *xx = calloc(*nid, sizeof(double));
  double f = hold_average(sim, ind, 200, pp, xx, *nid);
  if (p) {
    *p = pp;
    *xs = xx;
  } else {
    free(pp);
    free(xx);
  }
  MUST(gimlet_destroy(&sim));
  return 2 * f;
}

static void case_punch(void) {
  double a = 0.125, d = 1e-3 * a;
  double *p, *xs;
  int64_t nid;
  double P3 = punch_run(1.0 / 16, 3, a, d, &p, &xs, &nid);
  /* Profile against P / (pi sqrt(a^2 - x^2)) for |x| < 0.8 a. */
  double e2 = 0, pm = 0;
  int n = 0;
  for (int64_t i = 0; i < nid; i++) {
    if (isnan(p[i]) || fabs(xs[i]) >= 0.8 * a) continue;
    double ex = P3 / (M_PI * sqrt(a * a - xs[i] * xs[i]));
    e2 += (p[i] - ex) * (p[i] - ex);
    pm += ex;
    n++;
  }
  double rms = sqrt(e2 / (n ? n : 1)) / (pm / (n ? n : 1));
  free(p);
  free(xs);
  /* The load under refinement: 2 levels (the finer covering [0, 0.5] x
   * [0.5, 1], four punch half-widths) with coarse cells of 1/8, 1/16 and
   * 1/32 (finest 1/16 to 1/64: 2 to 8 cells under the half-punch). */
  double L1 = punch_run(1.0 / 8, 2, a, d, NULL, NULL, &nid);
  double L2 = punch_run(1.0 / 16, 2, a, d, NULL, NULL, &nid);
  double L3 = punch_run(1.0 / 32, 2, a, d, NULL, NULL, &nid);
  if (rank_ == 0) {
    printf("punch a = %g, depth %g: pressure RMS error over |x| < 0.8 a (%d particles) %.2f %% of the mean "
           "closed-form pressure there\n",
           a, d, n, 100 * rms);
    printf("punch load at depth %g by finest cell: 1/16 %.6g, 1/32 %.6g, 1/64 %.6g N/m: changes %.3g %%, %.3g %% "
           "(ratio %.2f)\n",
           d, L1, L2, L3, 100 * fabs(L2 - L1) / L3, 100 * fabs(L3 - L2) / L3, fabs(L3 - L2) / fabs(L2 - L1));
  }
  EXPECT(n >= 12, "only %d particles under |x| < 0.8 a", n);
  EXPECT(rms < 0.05, "pressure profile RMS error %.3g", rms);
  EXPECT(fabs(L3 - L2) < 0.6 * fabs(L2 - L1), "load not converging: %g %g %g", L1, L2, L3);
  EXPECT(fabs(L3 - L2) < 0.05 * L3, "load changes by %.3g %% at the finest refinement", 100 * fabs(L3 - L2) / L3);
}

/* ---------------------------------------------------------------- hertz */

/* `weights`: UGIMP_FLIP, CPGIMP_FLIP or WEIGHTS_DEFAULT (the library's
 * defaults, cpGIMP with APIC); the bounds are the same for all (cpGIMP measured: half-width
 * +2.47 %, peak pressure -1.98 %, profile RMS 1.54 % of p0). */
static void case_hertz(Weights weights) {
  Block s = block_defaults();
  s.levels = 3;
  s.shape = SHAPE_CYLINDER;
  s.weights = weights;
  /* R = 5 and a depth giving a ~ 0.1: peak strain p0 / E* = a / 2R = 1 %
   * (at R = 1 the 5 % strain of the same contact width takes the finite
   * deformation 5 % away from Hertz's small-strain theory); finest cell
   * 1/128, 26 particles over the half-width. */
  s.size = 5.0; /* R */
  s.h0 = 1.0 / 32;
  s.scheme = GIMLET_SCHEME_MUSL;
  s.flip = 0.95;
  int ind;
  GimletSim *sim = block_build(&s, &ind);
  double c = wave_speed(&s), tr = 20 * s.hb / c, d = 0.0035;
  ramp_depth(sim, ind, d, tr);
  run_to(sim, tr);
  int64_t nid = 4 * global_count(sim);
  double *p = calloc(nid, sizeof(double)), *xs = calloc(nid, sizeof(double));
  double P = 2 * hold_average(sim, ind, 400, p, xs, nid);
  double R = s.size, es = s.e / (1 - s.nu * s.nu);
  double aH = sqrt(4 * P * R / (M_PI * es)), p0H = 2 * P / (M_PI * aH);
  /* Least squares of p^2 = p0^2 - (p0^2 / a^2) x^2 over |x| < 0.9 aH. */
  double sx = 0, sy = 0, sxx = 0, sxy = 0, e2 = 0;
  int n = 0;
  for (int64_t i = 0; i < nid; i++) {
    if (isnan(p[i]) || fabs(xs[i]) >= 0.9 * aH) continue;
    double u = xs[i] * xs[i], v = p[i] * p[i];
    sx += u, sy += v, sxx += u * u, sxy += u * v;
    double ex = p0H * sqrt(1 - xs[i] * xs[i] / (aH * aH));
    e2 += (p[i] - ex) * (p[i] - ex);
    n++;
  }
  if (getenv("GIMLET_TEST_TRACE") && rank_ == 0)
    for (int64_t i = 0; i < nid; i++)
      if (!isnan(p[i]))
        printf("  x %.5f p %.5g hertz %.5g\n", xs[i], p[i],
               fabs(xs[i]) < aH ? p0H * sqrt(1 - xs[i] * xs[i] / (aH * aH)) : 0.0);
  double slope = (n * sxy - sx * sy) / (n * sxx - sx * sx), icpt = (sy - slope * sx) / n;
  double p0 = sqrt(icpt), a = sqrt(-icpt / slope), rms = sqrt(e2 / n) / p0H;
  if (rank_ == 0)
    printf("hertz (%s weights) R = %g, depth %g: load %.6g N/m; contact half-width %.5g (Hertz %.5g, %+.2f %%), peak pressure "
           "%.5g (Hertz %.5g, %+.2f %%), profile RMS error over |x| < 0.9 a %.2f %% of p0 (%d particles)\n",
           weights_name(weights), R, d, P, a, aH, 100 * (a / aH - 1), p0, p0H, 100 * (p0 / p0H - 1), 100 * rms, n);
  EXPECT(n >= 15, "only %d particles in the contact", n);
  EXPECT(fabs(a / aH - 1) < 0.05, "half-width %g vs Hertz %g", a, aH);
  EXPECT(fabs(p0 / p0H - 1) < 0.05, "peak pressure %g vs Hertz %g", p0, p0H);
  EXPECT(rms < 0.05, "profile RMS error %.3g of p0", rms);
  free(p);
  free(xs);
  MUST(gimlet_destroy(&sim));
}

/* ---------------------------------------------------------- quasistatic */

/* A wedge pushed at `speed` (ramped over 2 transit times) to depth d; the
 * load at d, averaged over the last 5 % of the push. */
static double wedge_push(double speed, double d) {
  Block s = block_defaults();
  s.levels = 3;
  s.shape = SHAPE_WEDGE;
  s.size = 65.0;
  s.scheme = GIMLET_SCHEME_MUSL;
  s.flip = 0.95;
  int ind;
  GimletSim *sim = block_build(&s, &ind);
  double c = wave_speed(&s), tr = 2 * s.hb / c, t2 = d / speed;
  double tt[4] = {0, tr, t2, t2 + tr}, vv[4] = {0, speed, speed, 0};
  MUST(gimlet_set_indenter_motion(sim, ind, GIMLET_MOTION_VELOCITY, 4, tt, vv));
  double t = 0, acc = 0, dt;
  int n = 0;
  /* Equal steps that land on the end (a last step much shorter than the
   * others would report its impulse over a tiny time). */
  MUST(gimlet_stable_dt(sim, &dt));
  int nsteps = (int)ceil((t2 + tr) / (0.95 * dt));
  dt = (t2 + tr) / nsteps;
  for (int k = 0; k < nsteps; k++) {
    MUST(gimlet_step(sim, dt, &t, NULL));
    if (getenv("GIMLET_TEST_TRACE") && rank_ == 0) {
      double f[2], dd;
      MUST(gimlet_indenter_state(sim, ind, &dd, NULL, f, NULL));
      printf("  t %.5f depth %.6f load %.6g\n", t, dd, 2 * f[1]);
    }
    if (k >= nsteps - nsteps / 20) {
      double f[2];
      MUST(gimlet_indenter_state(sim, ind, NULL, NULL, f, NULL));
      acc += 2 * f[1];
      n++;
    }
  }
  MUST(gimlet_destroy(&sim));
  return acc / n;
}

/* The push at 0.0025 of the wave speed and at half that: the loads at the
 * end within 1 %. At 0.005 and 0.0025 they were 0.62 % apart with the
 * nearest-point contact gap and 1.19 % with the faces' mean gap (the
 * default since 2026-11-28); at 0.0025 and 0.00125, 1.00 % and 0.81 %,
 * and 0.23 % with the faces' mean since the fine ghost ring moves with the
 * coarse level (2026-12-07): what remains at these speeds is the ringing's
 * phase at the last 5 % of the push, not a trend. GIMLET_TEST_CONTACT_GAP=G runs another gap. */
static void case_quasistatic(void) {
  Block s = block_defaults();
  double c = wave_speed(&s), d = 0.03, v = 0.0025 * c;
  double P1 = wedge_push(v, d), P2 = wedge_push(0.5 * v, d);
  if (rank_ == 0)
    printf("quasi-static: wedge to depth %g at %g m/s (%.3g of the wave speed): load %.6g N/m; at half the speed "
           "%.6g N/m: %.3f %% apart\n",
           d, v, v / c, P1, P2, 100 * fabs(P1 - P2) / P2);
  EXPECT(fabs(P1 - P2) < 0.01 * P2, "loads %g and %g differ by more than 1 %%", P1, P2);
}

/* ----------------------------------------------------------- invariance */

/* With the argument `friction`: the invariance scene with Coulomb friction
 * (mu = 0.5; the block's Poisson expansion under the cylinder slides
 * outward at the contact's edges and sticks in its middle), and the
 * tangential tractions and stick flags at the deepest point compared too. */
static int friction_ = 0;

/* The invariance scene: 3 levels, PX x PY patches per level, a cylinder
 * pressed 1.5 fine cells deep and released; per coarse step the indenter
 * force (x, y) and at the end the contact pressures of the deepest point,
 * by id. Returns the number of values written to `out` (size >= cap). */
static int64_t invariance_run(int px, int py, int petsc, double *out, int64_t cap) {
  Block s = block_defaults();
  s.levels = 3;
  s.px = px;
  s.py = py;
  s.shape = SHAPE_CYLINDER;
  s.size = 0.5;
  int ind;
  GimletSim *sim = block_build(&s, &ind);
  if (petsc) MUST(gimlet_set_contact_option(sim, GIMLET_CONTACT_DENSE_MAX, 0));
  if (friction_) {
    MUST(gimlet_set_indenter_friction(sim, ind, 0.5));
  }
  double c = wave_speed(&s), hf = s.h0 / 4, tr = 4 * s.hb / c;
  double tt[3] = {0, tr, 2 * tr}, dd[3] = {0, 1.5 * hf, 0};
  MUST(gimlet_set_indenter_motion(sim, ind, GIMLET_MOTION_DEPTH, 3, tt, dd));
  int64_t k = 0;
  double t = 0, dt;
  MUST(gimlet_stable_dt(sim, &dt));
  dt *= 0.9; /* a fixed step, the same on every layout */
  int step = 0;
  while (t < 2 * tr && k + 2 <= cap) {
    MUST(gimlet_step(sim, dt, &t, NULL));
    double f[2];
    MUST(gimlet_indenter_state(sim, ind, NULL, NULL, f, NULL));
    out[k++] = f[0];
    out[k++] = f[1];
    if (++step == (int)(tr / dt)) {
      /* The deepest point: every contact pressure, ordered by id. */
      Contacts cc = contacts_get(sim, ind);
      for (int64_t i = 0; i < cc.n && k + 2 <= cap; i++) {
        out[k++] = (double)cc.id[i];
        out[k++] = cc.p[i];
      }
      if (friction_ && cc.n > 0) {
        /* Tractions and stick flags, in the order of gimlet_get_contacts
         * (the same on every layout: by level, then id). */
        int64_t n = 0;
        double *tr_ = malloc(sizeof(double) * cc.n);
        int *st = malloc(sizeof(int) * cc.n);
        MUST(gimlet_get_contact_friction(sim, ind, cc.n, &n, tr_, NULL, st));
        int sticks = 0;
        for (int64_t i = 0; i < n && k + 2 <= cap; i++) {
          out[k++] = tr_[i];
          out[k++] = st[i];
          sticks += st[i];
        }
        EXPECT(sticks > 0 && sticks < n, "friction scene: %d of %lld contact particles stick (want both stick and slip)",
               sticks, (long long)n);
        free(tr_);
        free(st);
      }
      contacts_free(&cc);
    }
  }
  if (friction_ && rank_ == 0) {
    int64_t fc[3];
    MUST(gimlet_friction_stats(sim, ind, NULL, fc));
    printf("friction: %lld frictional solves, %lld staggered iterations (%.1f per solve, at most %lld)\n",
           (long long)fc[0], (long long)fc[1], fc[0] ? (double)fc[1] / fc[0] : 0.0, (long long)fc[2]);
  }
  MUST(gimlet_destroy(&sim));
  return k;
}

static void case_write(const char *path) {
  int64_t cap = 1 << 20;
  double *v = malloc(sizeof(double) * cap);
  int64_t n = invariance_run(1, 1, 0, v, cap);
  if (rank_ == 0) {
    FILE *f = fopen(path, "wb");
    EXPECT(f != NULL, "cannot write %s", path);
    if (f) {
      fwrite(&n, sizeof n, 1, f);
      fwrite(v, sizeof(double), n, f);
      fclose(f);
    }
    double fmax = 0;
    for (int64_t i = 1; i < n; i += 2) fmax = fmax > fabs(v[i]) ? fmax : fabs(v[i]);
    printf("invariance reference: %lld values (loads of every step, pressures at the deepest point), largest "
           "load %g N/m\n",
           (long long)n, 2 * fmax);
    EXPECT(fmax > 0, "the cylinder never touched the block");
  }
  free(v);
}

static void case_compare(const char *path, const char *layout, int petsc) {
  int px = 1, py = 1;
  sscanf(layout, "%dx%d", &px, &py);
  int64_t cap = 1 << 20, nref = 0;
  double *ref = malloc(sizeof(double) * cap), *v = malloc(sizeof(double) * cap);
  FILE *f = fopen(path, "rb");
  EXPECT(f != NULL, "cannot read %s", path);
  if (f) {
    if (fread(&nref, sizeof nref, 1, f) != 1 || nref > cap || fread(ref, sizeof(double), nref, f) != (size_t)nref)
      nref = -1;
    fclose(f);
  }
  int64_t n = invariance_run(px, py, petsc, v, cap);
  double scale = 0, worst = 0;
  for (int64_t i = 0; i < nref && i < n; i++) scale = scale > fabs(ref[i]) ? scale : fabs(ref[i]);
  for (int64_t i = 0; i < nref && i < n; i++) {
    /* With friction, differences are taken relative to the largest load or
     * pressure: the indenter's x force is then a small difference of large
     * tangential contributions (about 1 % of the load), and its round-off
     * is that of the load. A stick flag that flips differs by 1. */
    double floor_ = friction_ ? scale : 1e-3 * scale;
    double e = fabs(v[i] - ref[i]) / (fabs(ref[i]) > floor_ ? fabs(ref[i]) : floor_);
    worst = worst > e ? worst : e;
  }
  if (rank_ == 0)
    printf("invariance %d rank(s), %dx%d patches per level%s: %lld values against %lld, largest relative "
           "difference %.3g\n",
           size_, px, py, petsc ? ", every solve with PETSc" : "", (long long)n, (long long)nref, worst);
  EXPECT(n == nref, "%lld values, the reference has %lld (contact sets differ)", (long long)n, (long long)nref);
  /* With friction the staggered iteration stops when nothing changes by
   * more than 1e-8 of the largest pressure (the default tolerance), and
   * another layout's round-off can stop it one iteration earlier or later,
   * so the bound is that tolerance, 1e-8 of the largest load (measured:
   * 7.3e-11 to 5.6e-9 on 2x2 and 4x4 patches, with PETSc too, the smallest
   * 2.7e-11 before ring copies kept their owners' values; the largest,
   * 2x2 patches with PETSc, since ring copies keep their owners' values,
   * 2026-12-07; it was 3.6e-10 before). */
  double bound = friction_ ? 1e-8 : 1e-10;
  EXPECT(worst <= bound, "largest relative difference %g (bound %g)", worst, bound);
  free(ref);
  free(v);
}

int main(int argc, char **argv) {
  check_begin(&argc, &argv);
  const char *which = argc > 1 ? argv[1] : "";
  for (int i = 2; i < argc; i++)
    if (!strcmp(argv[i], "friction")) friction_ = 1;
  if (!strcmp(which, "early")) case_early();
  else if (!strcmp(which, "separation")) case_separation(UGIMP_FLIP);
  else if (!strcmp(which, "separation_cpgimp")) case_separation(CPGIMP_FLIP);
  else if (!strcmp(which, "separation_default")) case_separation(WEIGHTS_DEFAULT);
  else if (!strcmp(which, "punch")) case_punch();
  else if (!strcmp(which, "hertz")) case_hertz(UGIMP_FLIP);
  else if (!strcmp(which, "hertz_cpgimp")) case_hertz(CPGIMP_FLIP);
  else if (!strcmp(which, "hertz_default")) case_hertz(WEIGHTS_DEFAULT);
  else if (!strcmp(which, "quasistatic")) case_quasistatic();
  else if (!strcmp(which, "write") && argc > 2) case_write(argv[2]);
  else if (!strcmp(which, "compare") && argc > 3) case_compare(argv[2], argv[3], (argc > 4 && !strcmp(argv[4], "petsc")) || (argc > 5 && !strcmp(argv[5], "petsc")));
  else {
    if (rank_ == 0)
      fprintf(stderr, "usage: %s early|separation[_cpgimp|_default]|punch|hertz[_cpgimp|_default]|quasistatic | write FILE | "
                      "compare FILE PXxPY [petsc]\n",
              argv[0]);
    g_failures++;
  }
  return check_end(which);
}
