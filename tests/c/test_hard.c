/* Hard cases: the stability suite (issue 13 item 8). One case per run,
 * each with a bound that means something; every case prints its figure.
 *
 *   test_hard CASE
 *
 * Every case runs the library's default scheme (cpGIMP weights, MUSL,
 * APIC) unless its name says otherwise.
 *
 * Cases (see each function for the scene and the bound):
 *   rotation_flip  a free elastic block spun rigidly through a full turn
 *              with uGIMP and FLIP (the paper's): the stress after the
 *              turn, relative to E (the 1e-8 E is not reached with
 *              FLIP; the case says why);
 *   rotation_apic  a free block turned with the affine transfer (APIC) at
 *              a rate whose physical centrifugal stress is below the
 *              bound: 1e-8 E met and asserted, uGIMP linear elastic;
 *              rotation_apic_nh: Neo-Hookean, uGIMP; rotation_apic_cpgimp:
 *              Neo-Hookean with the default weights and transfer;
 *   free_flight  momentum of a free vibrating block crossing cells, with
 *              nodes of nearly zero mass at its edges (1e-13 relative);
 *   runaway    an absurd traction is caught at the first step (UNSTABLE,
 *              state unchanged), a legitimate one is not;
 *   impact     a block at 0.2 c hits a block at rest: det F, momentum,
 *              energy not growing;
 *   crossings  a vibrating block flies through a refined level tiled by
 *              small patches: thousands of patch crossings, nothing lost,
 *              mass and momentum kept, 2 ranks equal to 1;
 *   crossings_order  the vibrating block's momentum change across the
 *              level boundary against the cell size and the vibration:
 *              linear in the stress, falling with the cell size;
 *   long_run   100,000 steps of a vibrating block: the energy drift,
 *              reported and bounded;
 *   bar        a Neo-Hookean bar pulled by a follower traction past 50 %
 *              engineering strain: the end displacement against the
 *              closed form, the loaded end intact;
 *   bar_ugimp  the same bar with uGIMP weights and APIC to 30 %.
 * Exits non-zero on any failed check.
 *
 * Measured with the default (1 rank; uGIMP with FLIP, the paper's and the
 * default before, in brackets; HARD_SHAPE=1 HARD_TRANSFER=0 reproduces
 * them): free_flight momentum 1.0e-15 (1.1e-15); impact det F 0.843
 * (0.779), momentum 1.9e-15 (1.6e-15), largest energy +0 (+8.8 %), final
 * -64 % (+6.9 %); crossings rigid momentum 2.8e-14 (1.8e-15; before ring
 * copies kept their owners' values, 2026-12-07: 2.0e-14), vibrating 2.1e-2
 * (before ring copies kept their owners' values, 2026-12-07: 1.3e-2;
 * before the fine ghost ring moved with the coarse level,
 * 2026-12-07: 2.0e-2, uGIMP with FLIP 4.4e-2), 2 ranks equal to 1 bitwise; long_run swing 0.59
 * (0.67), energy -55 % after 1000 steps, -99.2 % at the end (+3.1 %,
 * -4.3 %: FLIP keeps the vibration's energy as particle-scale noise, see
 * long_run); bar +0.07 % at 52 % (cpGIMP with FLIP +0.12 %; uGIMP with
 * FLIP tears from 3-5 %). */
#include "scenes.h"

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

/* HARD_SCHEME, HARD_SHAPE, HARD_FLIP, HARD_TRANSFER (0 FLIP/PIC, 1 APIC,
 * 2 XPIC), HARD_XPIC_ORDER and HARD_CFL override the defaults of any case
 * (the bar's cpGIMP too), for measurements. */
static void env_overrides(GimletSim *s) {
  if (getenv("HARD_SCHEME")) MUST(gimlet_set_scheme(s, atoi(getenv("HARD_SCHEME"))));
  if (getenv("HARD_SHAPE")) MUST(gimlet_set_shape(s, atoi(getenv("HARD_SHAPE"))));
  if (getenv("HARD_FLIP")) MUST(gimlet_set_flip(s, atof(getenv("HARD_FLIP"))));
  if (getenv("HARD_TRANSFER")) MUST(gimlet_set_transfer(s, atoi(getenv("HARD_TRANSFER"))));
  if (getenv("HARD_XPIC_ORDER")) MUST(gimlet_set_xpic_order(s, atoi(getenv("HARD_XPIC_ORDER"))));
  if (getenv("HARD_CFL")) MUST(gimlet_set_cfl(s, atof(getenv("HARD_CFL"))));
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
 * Run with uGIMP and FLIP, the paper's weights and transfer (the
 * default is cpGIMP with APIC, which meets the bound: rotation_apic_cpgimp).
 * The bound, 1e-8 E, is NOT reached with this transfer, and the
 * case shows why (rotation_apic meets it with APIC): the
 * nodal velocities are mass-weighted averages of the particle velocities,
 * v_i = w x xbar_i with xbar_i the mass centroid of the node's support,
 * which is not the node at the block's edge (a surface node sees particles
 * on one side only). The velocity gradient of a rigid field is then not
 * skew at the edge particles: a strain rate of order w there, an elastic
 * response of order E w h / c, first order in w (measured: 1.4e-2, 8.3e-3,
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
  MUST(gimlet_set_shape(s, GIMLET_SHAPE_UGIMP));
  MUST(gimlet_set_transfer(s, GIMLET_TRANSFER_FLIP));
  env_overrides(s);
  int m;
  MUST(gimlet_add_material_linear_elastic(s, E, nu, rho, &m));
  MUST(gimlet_fill_rectangle(s, 0.5 - a, 0.5 - a, 0.5 + a, 0.5 + a, 2, m, rho, 0, 0, NULL));
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
    printf("rotation_flip: w a / c = %.3g, %lld steps through 2 pi: max |stress| = %.3e E (issue's bound 1e-8 E: %s; "
           "asserted: below 2 E w a / c = %.3e E), angular momentum change %.3e relative\n",
           w * a / c, (long long)steps, smax / E, smax < 1e-8 * E ? "met" : "NOT met", 2 * w * a / c,
           fabs(l1 - l0) / fabs(l0));
  all_true(isfinite(smax) && smax < 2 * E * w * a / c, "rotation_flip: stress after a full turn below 2 E w a / c");
  free(x);
  free(v);
  MUST(gimlet_destroy(&s));
}

/* The spin part of the APIC angular momentum of one particle per unit
 * mass and per C entry: its weights' second moment along one axis, D =
 * sum_i S_i (x_i - x_p)^2 (uGIMP, cell size h, half-length lp). A GIMP
 * weight is the mean of the node hat over [x - lp, x + lp], so D is the
 * mean over that interval of the hat's own moment t (1 - t) (t the
 * position in the cell) plus the interval's lp^2 / 3. */
static double weight_moment(double x, double lp, double h) {
  /* Antiderivative of t (1 - t), t = s - floor(s), over whole cells. */
  double u = x / h, l = lp / h, a = u - l, b = u + l;
  double ka = floor(a), kb = floor(b), ta = a - ka, tb = b - kb;
  double fa = ka / 6 + ta * ta / 2 - ta * ta * ta / 3, fb = kb / 6 + tb * tb / 2 - tb * tb * tb / 3;
  return h * h * ((fb - fa) / (2 * l) + l * l / 3);
}

/* The APIC angular momentum about c: sum m (x x v + C_yx D_xx - C_xy D_yy)
 * (the particle's affine velocity field carries m (C D) : eps; D of the
 * uGIMP weights, see weight_moment), summed over ranks; `orbital` gets the
 * x x m v part alone. */
static double apic_angular_momentum(GimletSim *s, double cx, double cy, double h, double *orbital) {
  int64_t n;
  double *x = field(s, GIMLET_FIELD_POSITION, &n), *v = field(s, GIMLET_FIELD_VELOCITY, &n);
  double *m = field(s, GIMLET_FIELD_MASS, &n), *c = field(s, GIMLET_FIELD_AFFINE, &n);
  double *lp = field(s, GIMLET_FIELD_HALF_LENGTH, &n), l[2] = {0, 0}, g[2];
  for (int64_t i = 0; i < n; i++) {
    double orb = (x[2 * i] - cx) * v[2 * i + 1] - (x[2 * i + 1] - cy) * v[2 * i];
    double spin = c[4 * i + 2] * weight_moment(x[2 * i], lp[2 * i], h) -
                  c[4 * i + 1] * weight_moment(x[2 * i + 1], lp[2 * i + 1], h);
    l[0] += m[i] * (orb + spin);
    l[1] += m[i] * orb;
  }
  MPI_Allreduce(l, g, 2, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  free(x), free(v), free(m), free(c), free(lp);
  *orbital = g[1];
  return g[0];
}

/* The rotation of case_rotation with the affine transfer (APIC), which
 * meets the bound: max |stress| < 1e-8 E after a full turn.
 *
 * The same free block (4 x 4 cells, 2 x 2 particles per cell, uGIMP,
 * MUSL, linear elastic with the Jaumann rate, cfl 0.5) is given the rigid
 * field v = w x (x - c) and its gradient as the particles' affine matrix C
 * (GIMLET_FIELD_AFFINE), then turned through 2 pi with
 * GIMLET_TRANSFER_APIC. APIC maps a linear velocity field exactly both
 * ways, at the free edges too, so the grid's velocity gradient of the
 * rotation is skew to round-off and the Jaumann rate adds no spurious
 * stress. What stress remains is physical: a free spinning body is in
 * tension, of order the centrifugal stress rho w^2 a^2 = 1.35 (w a / c)^2 E
 * (the real stress, not an error; the block starts unstressed, so it
 * also oscillates about that state). Measured max |stress| / E at
 * w a / c = 1e-2, 1e-3, 1e-4, 5e-5: 8.4e-5, 9.4e-7, 1.03e-8, 2.7e-9, i.e.
 * 0.62, 0.70, 0.77, 0.79 rho w^2 a^2: all of it centrifugal (second
 * order in w); the first-order edge error of the FLIP/PIC transfer
 * (case_rotation: 8.3e-3 E at 1e-2) is gone. Subtracting a closed-form
 * centrifugal stress is not an option here (the square's dynamic response
 * has no closed form, and the bound is four orders below the physical
 * stress at the rates of case_rotation), so the bound is tested at a rate
 * where the physical stress is well below it: w a / c = 5e-5, physical
 * 0.66 * 2.5e-9 = 1.7e-9 E, about 510,000 steps in a few seconds (the
 * block has 64 particles). Asserted: max |stress| < 1e-8 E; printed: the
 * same over the centrifugal scale rho w^2 a^2, and the angular momentum.
 *
 * Angular momentum: APIC's particles carry part of it in C (sum m (C D) :
 * eps, D the second moments of each particle's weights; an eighth of the
 * block's here). P2G and G2P each conserve the sum to round-off at
 * fixed particle positions (the kernel's unit test); across a step the
 * particles move and their uGIMP moments D change with their place in the
 * cell, so the total printed changes by the fluctuation of sum m w (D_xx +
 * D_yy) and the time discretisation, not by round-off: measured 4.5e-4,
 * 6.3e-5, 6.5e-6, 3.3e-6 relative over the turn at the rates above (first
 * order in the step), the orbital part alone (x x m v, case_rotation's
 * figure, where FLIP loses 86 %) 1.9e-3 ... 9.8e-6. HARD_ROT_W (the
 * rate w) overrides the default for such measurements.
 *
 * rotation_apic_nh: the same with a Neo-Hookean block, whose stress
 * follows from F alone. Under APIC F is updated in the midpoint (Cayley)
 * form, orthogonal for a skew velocity gradient; the FLIP mode's
 * F <- (I + dt L) F would stretch F by 2 pi^2 / n over a turn of n steps
 * (4e-5 here) and stress the block at that level.
 *
 * rotation_apic_cpgimp: the Neo-Hookean turn with cpGIMP particles, whose
 * domains follow the lengths of their material fibres (|F e_x|, |F e_y|,
 * unchanged by a rotation). Measured: 2.6e-9 E (0.79 rho w^2 a^2), the
 * angular momentum to 3.3e-6 over the turn (2.5e-9 E and 1.4e-4 while
 * cpGIMP's APIC matrix was the gradient form sum v_i (x) grad S, which
 * does not conserve it; now B D^-1, as for uGIMP). With
 * domains lp0 F_ii, as before, a domain shrank to nothing at a quarter turn
 * and the block went unstable within the turn (strain increments above 1
 * in one step: 1.1 here, 355 with the linear-elastic law, 6 at
 * w a / c = 1e-2). */
static void case_rotation_apic(int neo_hookean, int shape) {
  const double E = 1.0, nu = 0.3, rho = 1.0, h = 1.0 / 16, a = 2 * h;
  const char *name = shape == GIMLET_SHAPE_CPGIMP ? "rotation_apic_cpgimp"
                     : neo_hookean                ? "rotation_apic_nh"
                                                  : "rotation_apic";
  GimletSim *s;
  MUST(gimlet_create(MPI_COMM_WORLD, 0, 0, 1, 1, h, &s));
  MUST(gimlet_set_transfer(s, GIMLET_TRANSFER_APIC));
  MUST(gimlet_set_shape(s, shape));
  env_overrides(s);
  int m;
  if (neo_hookean)
    MUST(gimlet_add_material_neo_hookean(s, E, nu, rho, &m));
  else
    MUST(gimlet_add_material_linear_elastic(s, E, nu, rho, &m));
  MUST(gimlet_fill_rectangle(s, 0.5 - a, 0.5 - a, 0.5 + a, 0.5 + a, 2, m, rho, 0, 0, NULL));
  const double c = sqrt(E * (1 - nu) / ((1 + nu) * (1 - 2 * nu)) / rho);
  const char *w_env = getenv("HARD_ROT_W");
  double w = w_env ? atof(w_env) : 5e-5 * c / a;
  int64_t n;
  double *x = field(s, GIMLET_FIELD_POSITION, &n);
  double *v = malloc(sizeof(double) * (size_t)(4 * n + 1));
  for (int64_t i = 0; i < n; i++) {
    v[2 * i] = -w * (x[2 * i + 1] - 0.5);
    v[2 * i + 1] = w * (x[2 * i] - 0.5);
  }
  MUST(gimlet_set_field(s, GIMLET_FIELD_VELOCITY, v, n));
  for (int64_t i = 0; i < n; i++) {
    v[4 * i] = 0, v[4 * i + 1] = -w, v[4 * i + 2] = w, v[4 * i + 3] = 0;
  }
  MUST(gimlet_set_field(s, GIMLET_FIELD_AFFINE, v, n));
  double o0, o1;
  double l0 = apic_angular_momentum(s, 0.5, 0.5, h, &o0);
  double t_end = 2 * M_PI / w, t;
  int64_t steps;
  MUST(gimlet_advance_to(s, t_end, 100000000, &t, &steps));
  double smax = max_stress(s);
  double l1 = apic_angular_momentum(s, 0.5, 0.5, h, &o1);
  if (rank_ == 0)
    printf("%s: w a / c = %.3g, %lld steps through 2 pi: max |stress| = %.3e E (bound 1e-8 E), "
           "= %.3f rho w^2 a^2 (the physical centrifugal scale); angular momentum change %.3e relative "
           "(with the APIC spin term), orbital part alone %.3e (spin share %.3f at the start)\n",
           name, w * a / c, (long long)steps, smax / E, smax / (rho * w * w * a * a), fabs(l1 - l0) / fabs(l0),
           fabs(o1 - o0) / fabs(o0), 1 - o0 / l0);
  char what[96];
  snprintf(what, sizeof what, "%s: stress after a full turn below 1e-8 E", name);
  all_true(isfinite(smax) && smax < 1e-8 * E, what);
  free(x);
  free(v);
  MUST(gimlet_destroy(&s));
}

/* Fills a free Neo-Hookean square (E, nu, rho) of half-width a about
 * (x0, y0), 2 x 2 particles per cell, and sets its velocity to the drift
 * (dx, dy) c plus amp c sin(pi/2 (x - x0)/a) along each axis (its first
 * mode); c is the P-wave speed, returned. With `pos`, the initial
 * positions are handed to the caller (free them). */
static double vibrating_block(GimletSim *s, double E, double nu, double rho, double x0, double y0,
                              double a, double dx, double dy, double amp, double **pos) {
  int m;
  MUST(gimlet_add_material_neo_hookean(s, E, nu, rho, &m));
  MUST(gimlet_fill_rectangle(s, x0 - a, y0 - a, x0 + a, y0 + a, 2, m, rho, 0, 0, NULL));
  const double c = sqrt(E * (1 - nu) / ((1 + nu) * (1 - 2 * nu)) / rho);
  int64_t n;
  double *x = field(s, GIMLET_FIELD_POSITION, &n);
  double *v = malloc(sizeof(double) * (size_t)(2 * n + 1));
  for (int64_t i = 0; i < n; i++) {
    double u = (x[2 * i] - x0) / a, w = (x[2 * i + 1] - y0) / a;
    v[2 * i] = dx * c + amp * c * sin(0.5 * M_PI * u);
    v[2 * i + 1] = dy * c + amp * c * sin(0.5 * M_PI * w);
  }
  MUST(gimlet_set_field(s, GIMLET_FIELD_VELOCITY, v, n));
  free(v);
  if (pos) *pos = x;
  else free(x);
  return c;
}

/* ------------------------------------------------------ free flight */

/* Nearly empty nodes: a free Neo-Hookean block (6 x 6 cells, 2 x 2
 * particles per cell, the default scheme) flies diagonally at
 * (0.02, 0.012) c for 1000 steps (about 9 cells) while it vibrates (an initial
 * velocity field of amplitude 0.01 c in its first mode), no gravity, no
 * walls. As the particles cross cells, the nodes at the block's edges
 * carry masses down to round-off (GIMP's quadratic weight tails: 1e-12 of
 * a particle's mass and below) and the internal forces on them are not
 * zero. With no external force the total momentum is a conservation law:
 * bound 1e-13 relative to its initial value (each step's transfers round
 * at 1e-16; nodes dropped with their forces gave 3e-11). */
static void case_free_flight(void) {
  const double E = 1.0, nu = 0.3, rho = 1.0, h = 1.0 / 32, a = 3 * h;
  GimletSim *s;
  MUST(gimlet_create(MPI_COMM_WORLD, 0, 0, 1, 1, h, &s));
  env_overrides(s);
  const double x0 = 0.25, y0 = 0.3;
  double *x;
  const double c = vibrating_block(s, E, nu, rho, x0, y0, a, 0.02, 0.012, 0.01, &x);
  int64_t n;
  double p0[2], p1[2], k0, k1;
  MUST(gimlet_diagnostics(s, &k0, NULL, &p0[0], &p0[1], NULL));
  double dt;
  MUST(gimlet_stable_dt(s, &dt));
  dt *= 0.9;
  double drift = 0;
  const int steps = 1000;
  for (int k = 0; k < steps; k++) {
    MUST(gimlet_step(s, dt, NULL, NULL));
    if (k % 50 == 49 || k == steps - 1) {
      MUST(gimlet_diagnostics(s, &k1, NULL, &p1[0], &p1[1], NULL));
      drift = fmax(drift, hypot(p1[0] - p0[0], p1[1] - p0[1]) / hypot(p0[0], p0[1]));
    }
  }
  double *x1 = field(s, GIMLET_FIELD_POSITION, &n), moved = 0;
  for (int64_t i = 0; i < n; i++) moved = fmax(moved, fabs(x1[2 * i] - x[2 * i]));
  moved = gmax(moved);
  if (rank_ == 0)
    printf("free_flight: %d steps, the block moved %.1f cells: largest momentum change %.3e relative (bound 1e-13)\n",
           steps, moved / h, drift);
  all_true(moved > 5 * h, "free_flight: the block crossed cells");
  all_true(drift <= 1e-13, "free_flight: momentum kept to 1e-13 relative");
  free(x);
  free(x1);
  MUST(gimlet_destroy(&s));
}

/* -------------------------------------------------------- runaway */

/* Everything of this rank's particles, as bytes (positions, velocities,
 * stresses, F), for a bitwise comparison. */
static double *snapshot(GimletSim *s, int64_t *len) {
  const int f[] = {GIMLET_FIELD_POSITION, GIMLET_FIELD_VELOCITY, GIMLET_FIELD_STRESS, GIMLET_FIELD_DEFGRAD};
  double *out = NULL;
  *len = 0;
  for (int k = 0; k < 4; k++) {
    int nc;
    int64_t n;
    MUST(gimlet_field_components(s, f[k], &nc));
    double *v = field(s, f[k], &n);
    out = realloc(out, sizeof(double) * (size_t)(*len + nc * n + 1));
    memcpy(out + *len, v, sizeof(double) * (size_t)(nc * n));
    *len += nc * n;
    free(v);
  }
  return out;
}

/* A run going unstable is caught at the step it starts: a free elastic
 * bar (16 x 4 cells, 2 x 2 particles per cell, the default scheme) pulled
 * at its right end by an absurd but finite traction of 100 E, in full from
 * t = 0, with the stable step. The loaded particles' first-step strain
 * increment is about 0.4 t/E cfl^2/0.25 = 40, far above the bound of 1
 * (gimlet's MAX_STRAIN_INCREMENT): the very first step must fail with
 * GIMLET_ERR_UNSTABLE naming "strain increment" and a particle id, and leave
 * the state bitwise as before (time, step count, every particle field).
 * Then the same bar under a traction of 1e-3 E (a legitimate load) takes
 * 200 steps without a complaint. On 2 ranks the bar spans both (patches
 * of 8 cells). */
static void case_runaway(void) {
  const double E = 1.0, nu = 0.3, rho = 1.0, h = 1.0 / 32;
  for (int pass = 0; pass < 2; pass++) {
    const double t = pass == 0 ? 100 * E : 1e-3 * E;
    GimletSim *s;
    MUST(gimlet_create(MPI_COMM_WORLD, 0, 0, 1, 1, h, &s));
    env_overrides(s);
    MUST(gimlet_set_patch_size(s, 0, 8, 8));
    int m;
    MUST(gimlet_add_material_linear_elastic(s, E, nu, rho, &m));
    MUST(gimlet_set_face_bc(s, GIMLET_FACE_LEFT, GIMLET_BC_FIXED));
    MUST(gimlet_fill_rectangle(s, 0, 0.375, 0.5, 0.5, 2, m, rho, 0, 0, NULL));
    int64_t loaded;
    MUST(gimlet_apply_traction(s, GIMLET_FACE_RIGHT, 0.5, 0.375, 0.5, t, 0, &loaded));
    all_true(loaded == 8, "runaway: the right face's 8 particles loaded");
    double dt;
    MUST(gimlet_stable_dt(s, &dt));
    if (pass == 0) {
      int64_t n0, n1;
      double *before = snapshot(s, &n0);
      int rc = gimlet_step(s, dt, NULL, NULL);
      const char *msg = last_error();
      double time;
      int64_t steps;
      MUST(gimlet_time(s, &time, &steps));
      double *after = snapshot(s, &n1);
      int same = n0 == n1 && memcmp(before, after, sizeof(double) * (size_t)n0) == 0;
      if (rank_ == 0) printf("runaway: traction 100 E, first step: status %d: %s\n", rc, msg);
      all_true(rc == GIMLET_ERR_UNSTABLE, "runaway: the first step under 100 E is GIMLET_ERR_UNSTABLE");
      /* every rank reports the failing rank's own message (the agreement
       * prefers it over the other ranks' "failed on another rank") */
      all_true(rc == GIMLET_ERR_UNSTABLE && strstr(msg, "strain increment") && strstr(msg, "particle id"),
               "runaway: the message names the strain increment and the particle on every rank");
      all_true(time == 0 && steps == 0 && same, "runaway: the failed step changed nothing");
      free(before);
      free(after);
    } else {
      dt *= 0.9; /* the bar's speed lowers the stable step a little */
      int rc = GIMLET_OK, k;
      for (k = 0; k < 200 && rc == GIMLET_OK; k++) rc = gimlet_step(s, dt, NULL, NULL);
      if (rank_ == 0) printf("runaway: traction 1e-3 E: %d steps, status %d%s%s\n", k, rc, rc ? ": " : "", rc ? last_error() : "");
      all_true(rc == GIMLET_OK, "runaway: a legitimate load runs 200 steps");
    }
    MUST(gimlet_destroy(&s));
  }
}

/* --------------------------------------------------------- impact */

/* Smallest det F over all particles. */
static double min_det(GimletSim *s) {
  int64_t n;
  double *f = field(s, GIMLET_FIELD_DEFGRAD, &n), m = INFINITY, g;
  for (int64_t i = 0; i < n; i++) m = fmin(m, f[4 * i] * f[4 * i + 3] - f[4 * i + 1] * f[4 * i + 2]);
  free(f);
  MPI_Allreduce(&m, &g, 1, MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
  return g;
}

/* A fast impact: a Neo-Hookean block (4 x 6 cells) at 0.2 c hits a block
 * of the same material at rest (8 x 8 cells), both free (no walls, no
 * gravity), 2 x 2 particles per cell, the default scheme, stable steps,
 * 400 steps (the impact, the compression wave crossing the target and the
 * rebound). Bounds: every step succeeds (no non-finite value, no inverted
 * particle, no strain increment above the bound), det F > 0.5 (the impact
 * strain is about v/c = 0.1 per block), total momentum kept to 1e-13
 * relative (no external force: a conservation law), and the total energy
 * (kinetic + strain) never above its initial value by more than 10 %.
 *
 * That last bound is loose on purpose and says something unwelcome: the
 * grid's single velocity field makes the contact inelastic, so energy
 * should only be lost. With the default (cpGIMP, MUSL, APIC) it is: the
 * energy never rises above its start and ends 64 % lower. With uGIMP and
 * FLIP it grows by 8.8 % (MUSL), 4.3 % with USF, 2.9 % with USL or with
 * MUSL and 5 % PIC (which then lose 65 % by the end). The bound catches a
 * run that gains energy without limit, not FLIP's excess. HARD_SCHEME and HARD_FLIP
 * override the defaults. On 2 ranks too (patches of 8 cells). */
static void case_impact(void) {
  const double E = 1.0, nu = 0.3, rho = 1.0, h = 1.0 / 32;
  GimletSim *s;
  MUST(gimlet_create(MPI_COMM_WORLD, 0, 0, 1, 1, h, &s));
  env_overrides(s);
  MUST(gimlet_set_patch_size(s, 0, 8, 8));
  int m;
  MUST(gimlet_add_material_neo_hookean(s, E, nu, rho, &m));
  const double c = sqrt(E * (1 - nu) / ((1 + nu) * (1 - 2 * nu)) / rho), v0 = 0.2 * c;
  MUST(gimlet_fill_rectangle(s, 2 * h, 13 * h, 6 * h, 19 * h, 2, m, rho, v0, 0, NULL));
  MUST(gimlet_fill_rectangle(s, 6.5 * h, 12 * h, 14.5 * h, 20 * h, 2, m, rho, 0, 0, NULL));
  double k0, s0, p0[2];
  MUST(gimlet_diagnostics(s, &k0, &s0, &p0[0], &p0[1], NULL));
  const double e0 = k0 + s0;
  double emax = e0, pdrift = 0, dmin = 1, dt, k1 = 0, s1 = 0;
  int rc = GIMLET_OK, k;
  for (k = 0; k < 400 && rc == GIMLET_OK; k++) {
    MUST(gimlet_stable_dt(s, &dt));
    rc = gimlet_step(s, dt, NULL, NULL);
    if (rc != GIMLET_OK) break;
    double p1[2];
    MUST(gimlet_diagnostics(s, &k1, &s1, &p1[0], &p1[1], NULL));
    emax = fmax(emax, k1 + s1);
    pdrift = fmax(pdrift, hypot(p1[0] - p0[0], p1[1] - p0[1]) / hypot(p0[0], p0[1]));
    if (k % 10 == 0) dmin = fmin(dmin, min_det(s));
  }
  dmin = fmin(dmin, min_det(s));
  if (rank_ == 0)
    printf("impact at 0.2 c: %d steps (status %d%s%s), smallest det F %.3f (bound 0.5), momentum change %.3e "
           "relative (bound 1e-13), largest energy %+.3e of the initial (bound +0.1), final %+.3e\n",
           k, rc, rc ? ": " : "", rc ? last_error() : "", dmin, pdrift, emax / e0 - 1, (k1 + s1) / e0 - 1);
  all_true(rc == GIMLET_OK && k == 400, "impact: 400 steps succeed");
  all_true(dmin > 0.5, "impact: det F > 0.5");
  all_true(pdrift <= 1e-13, "impact: momentum kept to 1e-13 relative");
  all_true(emax <= e0 * (1 + 0.1), "impact: energy never grows by more than 10 %");
  MUST(gimlet_destroy(&s));
}

/* ------------------------------------------------------------ long run */

/* A 100,000-step run: a free Neo-Hookean block of 8 x 8 cells (256
 * particles, 2 x 2 per cell) vibrating in its first mode (initial velocity
 * amplitude 0.01 c), the default scheme (cpGIMP, MUSL, APIC), a fixed step
 * of 0.9 of the initial stable step: t c / (4 a) = 2773 at the end, some
 * 2800 passes of a wave across the block. The total energy (kinetic +
 * strain, sampled every 1000 steps, printed every 10,000) is reported and
 * bounded above: never more than 5 % over its initial value (a gain is what
 * instability looks like). Its loss is the vibration's numerical damping,
 * bounded where it is measurable: the vibration's swing (the strain
 * energy's range) over steps 801-1000 (about 28 periods) keeps at least
 * half of the swing of the first 200 steps. The momentum (zero) stays below
 * 1e-12 m c.
 * Measured with the default: swing 0.59 ([0.002, 0.566] against [0.002,
 * 0.966]); the total never above its start, -55 % after 1000 steps,
 * -99.2 % at the end; momentum 6e-18 m c.
 * Why there is no bound on the total's loss: with FLIP (HARD_TRANSFER=0)
 * the total stays within [-4.7 %, +3.1 %], yet the vibration dies as fast
 * (swing 0.67 after 1000 steps; [0.536, 0.556] of the initial energy in the
 * last 200): FLIP keeps the energy it takes from the vibration as frozen
 * strain and as particle velocities the grid does not see (96.7 % of the
 * kinetic energy at the end lies in the transfer's null space, measured by
 * one XPIC(16) filter step). Transfers that remove that part (PIC, APIC,
 * XPIC) end at -99 %. A bound on the total's loss would reward that
 * null-space content, not the vibration; PIC, which does damp the
 * vibration far more (-99.998 % after 1000 steps), fails the swing bound.
 * HARD_LONG_STEPS shortens the run for experiments. */
static void case_long_run(void) {
  const double E = 1.0, nu = 0.3, rho = 1.0, h = 1.0 / 16, a = 4 * h;
  GimletSim *s;
  MUST(gimlet_create(MPI_COMM_WORLD, 0, 0, 1, 1, h, &s));
  env_overrides(s);
  const double c = vibrating_block(s, E, nu, rho, 0.5, 0.5, a, 0, 0, 0.01, NULL);
  double k0, s0, mass;
  MUST(gimlet_diagnostics(s, &k0, &s0, NULL, NULL, &mass));
  const double e0 = k0 + s0;
  double dt;
  MUST(gimlet_stable_dt(s, &dt));
  dt *= 0.9;
  const char *env = getenv("HARD_LONG_STEPS");
  const long steps = env ? atol(env) : 100000;
  double emin = e0, emax = e0, pmax = 0, e = e0;
  /* The vibration itself: the range of the strain energy over the first
   * and the last 200 steps (a vibrating block swings between kinetic and
   * strain energy a few times in 200 steps). Printed, not asserted. */
  double sw[3][2] = {{INFINITY, -INFINITY}, {INFINITY, -INFINITY}, {INFINITY, -INFINITY}};
  for (long k = 1; k <= steps; k++) {
    MUST(gimlet_step(s, dt, NULL, NULL));
    /* Windows: the first 200 steps, the last 200, steps 801-1000. */
    for (int win = 0; win < 3; win++) {
      const int in = win == 0 ? k <= 200 : win == 1 ? k > steps - 200 : k > 800 && k <= 1000;
      if (!in) continue;
      double se;
      MUST(gimlet_diagnostics(s, NULL, &se, NULL, NULL, NULL));
      sw[win][0] = fmin(sw[win][0], se / e0);
      sw[win][1] = fmax(sw[win][1], se / e0);
    }
    if (k % 1000 == 0) {
      double k1, s1, px, py;
      MUST(gimlet_diagnostics(s, &k1, &s1, &px, &py, NULL));
      e = k1 + s1;
      emin = fmin(emin, e);
      emax = fmax(emax, e);
      pmax = fmax(pmax, hypot(px, py) / (mass * c));
      if (rank_ == 0 && k % 10000 == 0)
        printf("long_run: step %6ld (t c/(4a) = %.4g): energy %+.4e of the initial\n", k,
               k * dt / (4 * a / c), e / e0 - 1);
    }
  }
  if (rank_ == 0)
    printf("long_run: %ld steps, energy drift %+.4e at the end, range [%+.4e, %+.4e] of the initial (bound: gain "
           "5e-2; the loss is the vibration's decay, bounded by its swing below), momentum %.3e m c (bound 1e-12)\n",
           steps, e / e0 - 1, emin / e0 - 1, emax / e0 - 1, pmax);
  const double kept = steps >= 1000 ? (sw[2][1] - sw[2][0]) / (sw[0][1] - sw[0][0]) : NAN;
  if (rank_ == 0)
    printf("long_run: strain energy over the first 200 steps in [%.3f, %.3f] of the initial energy, over steps "
           "801-1000 in [%.3f, %.3f] (the vibration's swing keeps %.2f of its start; bound 0.5), over the last 200 "
           "in [%.3f, %.3f]\n",
           sw[0][0], sw[0][1], sw[2][0], sw[2][1], kept, sw[1][0], sw[1][1]);
  all_true(emax <= 1.05 * e0, "long_run: energy never gains more than 5 %");
  all_true(pmax <= 1e-12, "long_run: momentum below 1e-12 m c");
  if (steps >= 1000) all_true(kept >= 0.5, "long_run: the vibration keeps half of its swing over 1000 steps");
  MUST(gimlet_destroy(&s));
}

/* ------------------------------------------------------- crossings */

/* Every particle's position, velocity and level, by id, on rank 0 of
 * `comm`. */
static Rec *collect(GimletSim *s, MPI_Comm comm, int64_t *count) {
  const int fields[3] = {GIMLET_FIELD_POSITION, GIMLET_FIELD_VELOCITY, GIMLET_FIELD_LEVEL};
  return gather(s, comm, fields, 3, count);
}

/* Runs the crossings scene on `comm`: 2 levels (coarse 1/`cells`, 1/16 in
 * the crossings case; the fine box
 * [0.375, 0.625] x [0.25, 0.75]), every level tiled by patches of 4 cells;
 * a free Neo-Hookean block (0.125 x 0.25, 2 x 2 particles per cell) flying
 * right at 0.05 c through the fine box and out of it while it vibrates
 * (0.01 c). Returns the records (root of `comm`), and the mass, momentum,
 * crossings and level-1 particle counts seen. */
typedef struct {
  double mass0, mass1, p0[2], pdrift, lvl1_max;
  int64_t n0, n1, crossings, steps;
} CrossStats;

static Rec *run_crossings(MPI_Comm comm, int cells, double vib, CrossStats *st, int64_t *count) {
  const double E = 1.0, nu = 0.3, rho = 1.0, h = 1.0 / cells;
  GimletSim *s;
  MUST(gimlet_create(comm, 0, 0, 1, 1, h, &s));
  env_overrides(s);
  double box[4] = {0.375, 0.25, 0.625, 0.75};
  MUST(gimlet_add_level(s, box, 1));
  for (int l = 0; l < 2; l++) MUST(gimlet_set_patch_size(s, l, 4, 4));
  int m;
  MUST(gimlet_add_material_neo_hookean(s, E, nu, rho, &m));
  const double c = sqrt(E * (1 - nu) / ((1 + nu) * (1 - 2 * nu)) / rho);
  MUST(gimlet_fill_rectangle(s, 0.0625, 0.3125, 0.3125, 0.6875, 2, m, rho, 0, 0, NULL));
  int64_t n;
  double *x = field(s, GIMLET_FIELD_POSITION, &n);
  double *v = malloc(sizeof(double) * (size_t)(2 * n + 1));
  for (int64_t i = 0; i < n; i++) {
    v[2 * i] = 0.05 * c + vib * c * sin(M_PI * (x[2 * i] - 0.1875) / 0.25);
    v[2 * i + 1] = vib * c * sin(M_PI * (x[2 * i + 1] - 0.5) / 0.375);
  }
  MUST(gimlet_set_field(s, GIMLET_FIELD_VELOCITY, v, n));
  free(x);
  free(v);
  MUST(gimlet_particle_count(s, NULL, &st->n0));
  MUST(gimlet_diagnostics(s, NULL, NULL, &st->p0[0], &st->p0[1], &st->mass0));
  /* Fixed steps: the block travels 0.55 (about 9 coarse cells) */
  double dt;
  MUST(gimlet_stable_dt(s, &dt));
  dt *= 0.9;
  st->steps = (int64_t)ceil(0.55 / (0.05 * c) / dt);
  st->pdrift = 0;
  st->lvl1_max = 0;
  for (int64_t k = 0; k < st->steps; k++) {
    MUST(gimlet_step(s, dt, NULL, NULL));
    if (k % 20 == 0) {
      double px, py;
      int64_t l1;
      MUST(gimlet_diagnostics(s, NULL, NULL, &px, &py, NULL));
      st->pdrift = fmax(st->pdrift, hypot(px - st->p0[0], py - st->p0[1]) / hypot(st->p0[0], st->p0[1]));
      MUST(gimlet_level_particle_count(s, 1, &l1));
      int64_t g1 = 0;
      MPI_Allreduce(&l1, &g1, 1, MPI_INT64_T, MPI_SUM, comm);
      st->lvl1_max = fmax(st->lvl1_max, (double)g1);
    }
  }
  MUST(gimlet_particle_count(s, NULL, &st->n1));
  MUST(gimlet_diagnostics(s, NULL, NULL, NULL, NULL, &st->mass1));
  MUST(gimlet_patch_crossings(s, &st->crossings));
  Rec *r = collect(s, comm, count);
  MUST(gimlet_destroy(&s));
  return r;
}

/* Particles crossing cells, patch and level boundaries thousands of times
 * (see run_crossings), twice: flying rigidly (vib = 0) and vibrating
 * (vib = 0.01 c). Bounds: no particle lost (the count is the initial one),
 * the total mass to 1e-14 (a sum in patch order; the particles' masses do
 * not change), at least 1000 patch crossings and particles on the fine
 * level during the run; the momentum of the rigid flight to 1e-13 relative
 * (no external force, and a uniform velocity field is carried exactly
 * by every transfer, so this checks the level and patch bookkeeping); and
 * on 2 ranks every particle's position and velocity in the vibrating run
 * equal to rank 0's 1-rank run of the same scene to 1e-12 of the largest
 * coordinate and speed.
 *
 * The vibrating run's momentum is printed and only bounded loosely (10 %):
 * the level coupling is not conservative. A coarse particle entering the
 * fine region and its fine-level copy evolve separately between syncs,
 * and the sync keeps one of the two (the paper's copy coupling, no
 * refluxing of the interface forces), so the momentum changes by 2.1 % of
 * the block's over the run (before ring copies kept their owners'
 * values, 2026-12-07: 1.3 %) (before the fine ghost ring moved with the
 * coarse level, 2026-12-07: 2 %, and 4.4 % with uGIMP and FLIP) (it did not with one level: free_flight). */
static void case_crossings(void) {
  for (int pass = 0; pass < 2; pass++) {
    const double vib = pass == 0 ? 0.0 : 0.01;
    CrossStats ref = {0}, st = {0};
    int64_t nref = 0, n = 0;
    Rec *r0 = NULL;
    if (pass == 1 && size_ > 1 && rank_ == 0) r0 = run_crossings(MPI_COMM_SELF, 16, vib, &ref, &nref);
    MPI_Barrier(MPI_COMM_WORLD);
    Rec *r = run_crossings(MPI_COMM_WORLD, 16, vib, &st, &n);
    const double pbound = pass == 0 ? 1e-13 : 0.1;
    if (rank_ == 0)
      printf("crossings (%s, %d rank(s)): %lld steps, %lld patch crossings, up to %.0f particles on the fine level, "
             "particles %lld -> %lld, mass change %.3e relative (bound 1e-14), momentum change %.3e relative "
             "(bound %g)\n",
             pass == 0 ? "rigid flight" : "vibrating", size_, (long long)st.steps, (long long)st.crossings,
             st.lvl1_max, (long long)st.n0, (long long)st.n1, fabs(st.mass1 - st.mass0) / st.mass0, st.pdrift,
             pbound);
    all_true(st.n1 == st.n0, "crossings: no particle lost");
    all_true(fabs(st.mass1 - st.mass0) <= 1e-14 * st.mass0, "crossings: mass kept to 1e-14");
    all_true(st.crossings >= 1000, "crossings: at least 1000 patch crossings");
    all_true(st.lvl1_max > 0, "crossings: particles went through the fine level");
    all_true(st.pdrift <= pbound, "crossings: momentum kept (1e-13 rigid, 0.1 vibrating)");
    if (pass == 1 && size_ > 1) {
      double diff[4] = {0}, scale[4] = {0}, dx = 0, dv = 0, xs = 1, vs = 1;
      int ok = 1;
      if (rank_ == 0) {
        ok = rec_diff(r0, nref, r, n, 4, diff, scale);
        dx = fmax(diff[0], diff[1]), dv = fmax(diff[2], diff[3]);
        xs = fmax(scale[0], scale[1]), vs = fmax(scale[2], scale[3]);
        printf("crossings: 2 ranks vs 1: same ids %s, position difference %.3e, velocity difference %.3e "
               "relative (bound 1e-12)\n",
               ok ? "yes" : "NO", dx / xs, dv / vs);
      }
      all_true(ok && dx <= 1e-12 * xs && dv <= 1e-12 * vs, "crossings: 2 ranks equal 1 rank to 1e-12");
    }
    free(r);
    free(r0);
  }
}

/* Why the vibrating block's momentum changes across the level boundary
 * (issue 27 item 5), measured on the crossings scene (see run_crossings,
 * 1 rank): the largest momentum change over the run, relative to the
 * block's momentum, at coarse cells of 1/8, 1/16, 1/32 and 1/64 (the fine
 * level halves each, particles and steps follow), and at 1/32 with the
 * vibration doubled. The copies carry particles, not forces: a coarse
 * particle in the fine ghost ring and its owner, and a fine particle and
 * its coarse copy, each push their own grid between synchronisations, and
 * nothing makes the force the fine level feels across the boundary equal
 * and opposite to the one the coarse level feels (the paper's coupling
 * has no refluxing). Rigid flight carries no stress and keeps its
 * momentum to 1e-14 (the crossings case), so the change is that
 * imbalance: it must grow linearly with the stress the block carries
 * (the vibration's amplitude; bound: doubling it from 0.005 c to 0.01 c
 * multiplies the change by 1.8 to 2.2) and fall with the cell size as a
 * truncation error of the coupling (bound: at least 4 times smaller at
 * 1/64 than at 1/8, an order of at least 2/3 over three halvings), both
 * at the vibration 0.005 c. Measured (2026-12-07, the coarse velocities
 * prescribed on the fine ghost ring): 3.45e-2, 9.85e-3, 5.82e-3 and
 * 1.22e-3 (order 1.61), and x1.870 for the doubled vibration (before
 * ring copies kept their owners' values, 2026-12-07: 2.41e-2, 6.67e-3,
 * 3.59e-3 and 1.06e-3, order 1.50, x1.966). Linearity
 * is a small-amplitude statement: from 0.01 c to 0.02 c (a vibration at
 * 40 % of the flight speed, 2 % strain) the ratio is x1.709, from 0.0025 c
 * to 0.005 c x1.942. Before the ring moved with the coarse level: 1.77e-2,
 * 9.51e-3, 3.40e-3 and 2.19e-3 (order 1.01) and x1.823 at these
 * amplitudes (order 0.96 and x2.067 from 0.01 c to 0.02 c). uGIMP with
 * FLIP (HARD_SHAPE=1 HARD_TRANSFER=0) failed both bounds before (at
 * 0.01 c: 3.3e-2, 4.4e-2, 2.0e-2, 8.5e-3 and x2.26), FLIP's noise adding
 * to the imbalance at the coarsest cells. What it costs the main job is
 * in the wedge study (README): 3 levels against their uniform finest
 * twin. */
static void case_crossings_order(void) {
  const int cells[4] = {8, 16, 32, 64};
  double change[4], doubled = 0;
  for (int k = 0; k < 4; k++) {
    CrossStats st = {0};
    int64_t n = 0;
    free(run_crossings(MPI_COMM_WORLD, cells[k], 0.005, &st, &n));
    change[k] = st.pdrift;
    if (cells[k] == 32) {
      CrossStats st2 = {0};
      free(run_crossings(MPI_COMM_WORLD, 32, 0.01, &st2, &n));
      doubled = st2.pdrift / st.pdrift;
    }
  }
  const double order = log2(change[0] / change[3]) / 3;
  if (rank_ == 0)
    printf("crossings_order: largest momentum change at coarse cells 1/8, 1/16, 1/32, 1/64: %.3e %.3e %.3e %.3e "
           "(1/8 over 1/64: %.2f, order %.2f; bound at least 4); vibration doubled at 1/32: x%.3f (bound 1.8 to "
           "2.2)\n",
           change[0], change[1], change[2], change[3], change[0] / change[3], order, doubled);
  all_true(change[0] >= 4 * change[3], "crossings_order: the change falls with the cell size (at least 4x over 1/8 to 1/64)");
  all_true(doubled >= 1.8 && doubled <= 2.2, "crossings_order: the change is linear in the vibration (x1.8 to x2.2)");
}

/* ------------------------------------------------------------ bar */

/* The library's plane-strain Neo-Hookean law (src/material: sigma = (mu/J)
 * (B - I) + (lambda ln J / J) I, B_zz = 1) in uniaxial tension along x,
 * F = diag(l1, l2, 1): sigma_yy = 0 gives l2 from l1 (mu (l2^2 - 1) +
 * lambda ln(l1 l2) = 0, by bisection: the left side grows with l2), then
 * sigma_xx = (mu (l1^2 - 1) + lambda ln J) / J. */
static double bar_lateral(double lam, double mu, double l1) {
  double a = 1e-3, b = 1.0;
  for (int k = 0; k < 200; k++) {
    double m = 0.5 * (a + b);
    if (mu * (m * m - 1) + lam * log(l1 * m) > 0) b = m;
    else a = m;
  }
  return 0.5 * (a + b);
}

static double bar_cauchy(double lam, double mu, double l1) {
  const double l2 = bar_lateral(lam, mu, l1), j = l1 * l2;
  return (mu * (l1 * l1 - 1) + lam * log(j)) / j;
}

typedef struct {
  double x0, y0, x, y;
} BarRec;

/* all_true with the case's name before the message. */
static void bar_check(int cond, const char *name, const char *what) {
  char msg[200];
  snprintf(msg, sizeof msg, "%s: %s", name, what);
  all_true(cond, msg);
}

/* Every particle's reference and current position, on every rank. */
static BarRec *bar_collect(GimletSim *s, int64_t *count) {
  int64_t n;
  double *x = field(s, GIMLET_FIELD_POSITION, &n), *r = field(s, GIMLET_FIELD_REFERENCE, &n);
  BarRec *mine = malloc(sizeof(BarRec) * (size_t)(n + 1));
  for (int64_t i = 0; i < n; i++) mine[i] = (BarRec){r[2 * i], r[2 * i + 1], x[2 * i], x[2 * i + 1]};
  int cnt = (int)(n * (int64_t)sizeof(BarRec)), *cnts = malloc(sizeof(int) * (size_t)size_);
  int *displ = malloc(sizeof(int) * (size_t)size_), tot = 0;
  MPI_Allgather(&cnt, 1, MPI_INT, cnts, 1, MPI_INT, MPI_COMM_WORLD);
  for (int k = 0; k < size_; k++) displ[k] = tot, tot += cnts[k];
  BarRec *all = malloc((size_t)tot + sizeof(BarRec));
  MPI_Allgatherv(mine, cnt, MPI_BYTE, all, cnts, displ, MPI_BYTE, MPI_COMM_WORLD);
  *count = tot / (int64_t)sizeof(BarRec);
  free(x), free(r), free(mine), free(cnts), free(displ);
  return all;
}

/* The mean x displacement of the end column (reference x0 >= xe) and, over
 * the end column, the largest distance from a particle to its neighbour in
 * the next column and in its own column (reference spacing d). */
static void bar_end(const BarRec *a, int64_t n, double xe, double d, double *u, double *gap) {
  double su = 0;
  int64_t ne = 0;
  *gap = 0;
  for (int64_t i = 0; i < n; i++) {
    if (a[i].x0 < xe) continue;
    su += a[i].x - a[i].x0;
    ne++;
    for (int64_t k = 0; k < n; k++) {
      const double dx0 = a[i].x0 - a[k].x0, dy0 = a[i].y0 - a[k].y0;
      const int next = fabs(dx0 - d) < 1e-3 * d && fabs(dy0) < 1e-3 * d;
      const int above = fabs(dx0) < 1e-3 * d && fabs(dy0 - d) < 1e-3 * d;
      if (next || above) *gap = fmax(*gap, hypot(a[i].x - a[k].x, a[i].y - a[k].y));
    }
  }
  *u = ne ? su / (double)ne : NAN;
}

/* Tension of a bar past 50 % engineering strain (issue 13 item 8). A
 * Neo-Hookean bar (E = 1, nu = 0.3, rho = 1), L x H = 1 x 0.25, 32 x 8
 * cells of h = 1/32, 2 x 2 particles per cell, cpGIMP, as the quarter of
 * a bar symmetric about x = 0 and y = 0 (rollers on the domain's left and
 * bottom faces; the domain, 2 x 0.5, leaves room to stretch), plane
 * strain, the library's default scheme (cpGIMP, MUSL, APIC; nothing set).
 * The free end carries a follower traction, GIMLET_FOLLOW_AREA: a Cauchy
 * traction s along x per current area of the end face, ramped linearly
 * over 40 transit times L/c (quasi-static), then held for 12 (about two
 * periods of the bar's first mode); stable steps.
 *
 * Measured: +0.07 % over the hold, end neighbours within 0.75 h; cpGIMP
 * with FLIP (HARD_TRANSFER=0) +0.12 %, the same neighbour distance.
 *
 * cpGIMP, not uGIMP. uGIMP with MUSL and pure FLIP (the paper's, and the
 * default before) does not hold even a few per cent here: at a closed-form stretch of
 * 1.05 (and 1.03 over the hold) the strain localises in the middle of the
 * bar and grows without bound (the end flies out of the domain), at any
 * patch size and with a smaller step. The cause is the position update:
 * uGIMP particles move with the updated grid velocity while F integrates
 * the re-mapped one, and the difference (the grid acceleration minus its
 * particle-smoothed image, times dt) accumulates in the positions without
 * any stress resisting it. Moving uGIMP particles with the re-mapped
 * velocity, as cpGIMP does, holds 30 % (+3.3 %) but gains 16 % energy in
 * long_run (bound 5 %), and no blend of the two holds 30 % with long_run
 * in bounds; 5 % PIC or APIC hold 10 %, APIC holds 30 %
 * (bar_ugimp, below) but not 40 %; at 50 % uGIMP domains leave gaps of a
 * quarter of their length and every uGIMP run separates. The follower traction
 * rather than the dead one: the closed form is for a Cauchy stress, and a
 * dead load of the same end value passes too (BAR_LOAD=dead); the turning
 * follower (BAR_LOAD=face) passes with PIC only (see
 * gimlet_apply_follower_traction).
 *
 * Closed form: the homogeneous uniaxial plane-strain state of the
 * library's law with sigma_xx = s, sigma_yy = 0 (bar_cauchy), s chosen for
 * a stretch of 1.52: the end column's displacement 0.52 x0. Bounds: every
 * step completes, no particle lost, all finite; the engineering strain
 * reached (end displacement over x0) at least 50 % at the end of the ramp
 * and over the hold; the end displacement averaged over the hold within
 * 3 % of the closed form; the loaded end intact: every end-column particle
 * within one cell of its neighbours (in the next column and in its own)
 * throughout the run (the homogeneous spacing is 0.76 h; a separating end
 * is cells away). Printed: strain reached, error, steps, wall time.
 *
 * Margin, measured: the end stays intact over a hold of 40 transit times
 * at 52 % (neighbour distance up to 0.87 h at h = 1/32, 0.90 h at 1/16,
 * growing) but not at 55 % with pure FLIP (it separates within that hold
 * at both sizes; 1 % PIC holds it at 1/16), and at 60 % it separates
 * around the end of the ramp: a particle-scale tensile instability (the
 * strain alternates from particle to particle near the loaded end) at a
 * Cauchy stress of about E / 2, which this case stays just below. On 2 ranks too (patches of
 * 8 x 8 cells). HARD_SCHEME, HARD_FLIP, HARD_SHAPE, BAR_LOAD (area, face,
 * dead), BAR_CELLS (cells per unit length), BAR_STRETCH and BAR_HOLD
 * (transit times) override the defaults for measurements.
 *
 * bar_ugimp: the same bar with uGIMP weights and APIC to 30 % (closed-form
 * stretch 1.30; the strain bound 29 %), the combination docs/method.md names
 * for moderate tension on uGIMP weights: it backs that advice.
 * Measured: +0.02 % over the hold, end neighbours within 0.85 h, 1 and 2
 * ranks.
 *
 * bar_ugimp_xpic: the same bar with uGIMP weights and pure XPIC(5)
 * (GIMLET_TRANSFER_XPIC, FLIP fraction 0) to 10 % (closed-form stretch
 * 1.10; the strain bound 9 %), backing docs/method.md's figures for XPIC on
 * uGIMP weights (FLIP tears below 5 %; at 20 % XPIC's loaded end
 * drifts 1.3 h apart). Measured: +0.73 % over the hold, end neighbours
 * within 0.69 h, the same figures on 1 and 2 ranks. */
static void case_bar(const char *name, int shape, int transfer, double stretch0, double min_strain) {
  const double E = 1.0, nu = 0.3, rho = 1.0;
  const double h = 1.0 / (getenv("BAR_CELLS") ? atof(getenv("BAR_CELLS")) : 32.0);
  const double L = 1.0, H = 0.25, stretch = getenv("BAR_STRETCH") ? atof(getenv("BAR_STRETCH")) : stretch0;
  const double lam = E * nu / ((1 + nu) * (1 - 2 * nu)), mu = E / (2 * (1 + nu));
  const double tc = L / sqrt((lam + 2 * mu) / rho), t_ramp = 40 * tc;
  const double t_hold = (getenv("BAR_HOLD") ? atof(getenv("BAR_HOLD")) : 12.0) * tc;
  const double s_pull = bar_cauchy(lam, mu, stretch);
  const char *load = getenv("BAR_LOAD") ? getenv("BAR_LOAD") : "area";
  const double t0w = MPI_Wtime();
  GimletSim *s;
  MUST(gimlet_create(MPI_COMM_WORLD, 0, 0, 2 * L, 2 * H, h, &s));
  MUST(gimlet_set_patch_size(s, 0, 8, 8));
  if (shape >= 0) MUST(gimlet_set_shape(s, shape));
  if (transfer >= 0) MUST(gimlet_set_transfer(s, transfer));
  if (transfer == GIMLET_TRANSFER_XPIC) MUST(gimlet_set_flip(s, 0));
  env_overrides(s);
  MUST(gimlet_set_face_bc(s, GIMLET_FACE_LEFT, GIMLET_BC_ROLLER));
  MUST(gimlet_set_face_bc(s, GIMLET_FACE_BOTTOM, GIMLET_BC_ROLLER));
  int m;
  MUST(gimlet_add_material_neo_hookean(s, E, nu, rho, &m));
  int64_t n0 = 0, loaded = 0, n, steps = 0, k = 0, hold_samples = 0;
  MUST(gimlet_fill_rectangle(s, 0, 0, L, H, 2, m, rho, 0, 0, &n0));
  if (!strcmp(load, "dead")) /* the nominal traction of the same end state */
    MUST(gimlet_apply_traction(s, GIMLET_FACE_RIGHT, L, 0, H, s_pull * bar_lateral(lam, mu, stretch), 0, &loaded));
  else
    MUST(gimlet_apply_follower_traction(s, GIMLET_FACE_RIGHT, L, 0, H, s_pull, 0,
                                        strcmp(load, "face") ? GIMLET_FOLLOW_AREA : GIMLET_FOLLOW_FACE, &loaded));
  MUST(gimlet_set_load_ramp(s, t_ramp));
  const double d = 0.5 * h, xe = L - d, x0e = L - 0.5 * d, u_cf = (stretch - 1) * x0e;
  int rc = GIMLET_OK;
  double t = 0, gap_max = 0, u_sum = 0, strain_ramp = 0, u = 0, gap = 0;
  while (t < t_ramp + t_hold) {
    rc = gimlet_step(s, 0, &t, &steps);
    if (rc != GIMLET_OK) break;
    if (++k % 10 == 0 || t >= t_ramp + t_hold) {
      BarRec *a = bar_collect(s, &n);
      bar_end(a, n, xe, d, &u, &gap);
      free(a);
      gap_max = fmax(gap_max, gap);
      if (t <= t_ramp) strain_ramp = u / x0e;
      else u_sum += u, hold_samples++;
      if (!isfinite(u) || gap > 4 * h) break; /* torn apart: stop here */
    }
  }
  const double wall = MPI_Wtime() - t0w;
  if (rc != GIMLET_OK && rank_ == 0) fprintf(stderr, "%s: step %lld failed: %s\n", name, (long long)steps + 1, last_error());
  int64_t nl = 0, ng = 0;
  MUST(gimlet_particle_count(s, &nl, &ng));
  const double u_hold = hold_samples ? u_sum / (double)hold_samples : NAN, err = (u_hold - u_cf) / u_cf;
  if (rank_ == 0)
    printf("%s: %s traction %.4f E (closed-form stretch %.3f), %lld particles (%lld loaded), %lld steps, %.1f s: "
           "strain at the end of the ramp %.1f %%, mean over the hold %.1f %% (closed form %.1f %%), error %+.2f %%, "
           "largest end-column neighbour distance %.2f h (homogeneous %.2f h)%s\n",
           name, load, s_pull / E, stretch, (long long)ng, (long long)loaded, (long long)steps, wall, 100 * strain_ramp,
           100 * u_hold / x0e, 100 * (stretch - 1), 100 * err, gap_max / h, 0.5 * stretch,
           rc == GIMLET_OK ? "" : " (a step failed)");
  bar_check(rc == GIMLET_OK && t >= t_ramp + t_hold, name, "every step completes");
  bar_check(ng == n0, name, "no particle lost");
  bar_check(isfinite(u_hold) && isfinite(gap_max), name, "all finite");
  char what[100];
  snprintf(what, sizeof what, "at least %.0f %% engineering strain reached and held", 100 * min_strain);
  bar_check(strain_ramp >= min_strain && u_hold / x0e >= min_strain, name, what);
  bar_check(fabs(err) <= 0.03, name, "end displacement within 3 % of the closed form over the hold");
  bar_check(gap_max <= h, name, "the loaded end stays intact (neighbours within one cell)");
  MUST(gimlet_destroy(&s));
}

int main(int argc, char **argv) {
  check_begin(&argc, &argv);
  const char *c = argc > 1 ? argv[1] : "";
  if (!strcmp(c, "rotation_flip"))
    case_rotation();
  else if (!strcmp(c, "rotation_apic"))
    case_rotation_apic(0, GIMLET_SHAPE_UGIMP);
  else if (!strcmp(c, "rotation_apic_nh"))
    case_rotation_apic(1, GIMLET_SHAPE_UGIMP);
  else if (!strcmp(c, "rotation_apic_cpgimp"))
    case_rotation_apic(1, GIMLET_SHAPE_CPGIMP);
  else if (!strcmp(c, "free_flight"))
    case_free_flight();
  else if (!strcmp(c, "runaway"))
    case_runaway();
  else if (!strcmp(c, "impact"))
    case_impact();
  else if (!strcmp(c, "crossings"))
    case_crossings();
  else if (!strcmp(c, "crossings_order"))
    case_crossings_order();
  else if (!strcmp(c, "long_run"))
    case_long_run();
  else if (!strcmp(c, "bar"))
    case_bar("bar", -1, -1, 1.52, 0.5); /* the library's defaults */
  else if (!strcmp(c, "bar_ugimp"))
    case_bar("bar_ugimp", GIMLET_SHAPE_UGIMP, GIMLET_TRANSFER_APIC, 1.30, 0.29);
  else if (!strcmp(c, "bar_ugimp_xpic"))
    case_bar("bar_ugimp_xpic", GIMLET_SHAPE_UGIMP, GIMLET_TRANSFER_XPIC, 1.10, 0.09);
  else {
    if (rank_ == 0) fprintf(stderr, "usage: test_hard rotation_flip|rotation_apic|rotation_apic_nh|rotation_apic_cpgimp|free_flight|runaway|impact|crossings|long_run|bar|bar_ugimp|bar_ugimp_xpic\n");
    MPI_Finalize();
    return 2;
  }
  return check_end(c);
}
