/* Accuracy of nested levels with subcycling (issue "Nested levels with
 * subcycling"), on any number of ranks.
 *
 * 1. Localized pulse, 2 and 3 levels. A smooth radial velocity pulse
 *    (v = A (x - c) cos^2(pi r / 2w) / w for r < w, w = 0.1) starts in the
 *    middle of the finest box of a unit square (linear elastic, rollers on
 *    every face) and runs until t = 0.5 / c_p: it crosses the finest box,
 *    then the coarser boxes. The error is the RMS velocity difference over
 *    the particles of the finest box from a reference run on a uniform grid
 *    three times finer than the finest level, sampled 10 times, maximum
 *    over the samples, over A. The dynamics start and stay in the finest
 *    region until the wave leaves it, and what comes back is the wave the
 *    coarser levels carry out plus whatever the level boundaries reflect:
 *    the fine-region error of a correct coupling is then that of the
 *    finest cell size (it is here that "within 2x of the uniform-finest
 *    error" is a fair requirement; in a global mode like the vibrating
 *    plate the fine region is slaved to the coarse region's phase, see 2).
 *    Bounds: error <= 2 x the uniform-finest error and <= 0.6 x (2 levels)
 *    or 0.5 x (3 levels) the uniform-coarse error.
 * 2. Vibrating plate, 2 levels (the fundamental mode v = v0 sin(pi X),
 *    box [0.25, 0.75]^2): the displacement error over the fine box against
 *    the analytic mode over one period, at cfl 0.5 and 0.125. A global
 *    mode's phase is set by the whole plate, so the fine region cannot beat
 *    the coarse error by much; what it must not do is exceed it or grow
 *    with the number of synchronisations (before the coupling fix: 2.1x,
 *    3.4x and 4.5x the uniform-coarse error at cfl 0.5, 0.25, 0.125).
 *    Bounds: <= 1.0 x (cfl 0.5) and <= 1.25 x (cfl 0.125) the uniform-coarse
 *    error; the energy averaged over the second period within 0.5 % of that
 *    over the first (before the fix: -1.3 %).
 *
 *   test_levels_accuracy            (all cases)
 *   test_levels_accuracy pulse|plate
 */
#include "check.h"

static void expect(int ok, const char *what, double got, double bound) {
  if (rank_ == 0) printf("  %-58s %.3e <= %.3e  %s\n", what, got, bound, ok ? "ok" : "FAILED");
  EXPECT(ok, "%s", what);
}

static const double E = 1e4, NU = 0.3, RHO = 1.0;

static double wave_speed(void) {
  return sqrt(E * (1 - NU) / ((1 + NU) * (1 - 2 * NU)) / RHO);
}

enum { PULSE, PLATE };

/* Unit square, `nc` coarse cells, `nl` levels nested around the centre
 * ([0.25, 0.75]^2, then [0.375, 0.625]^2), 2x2 particles per cell. */
static GimletSim *make(int kind, int nc, int nl, double cfl, double w) {
  GimletSim *s = NULL;
  MUST(gimlet_create(MPI_COMM_WORLD, 0, 0, 1, 1, 1.0 / nc, &s));
  /* The paper's weights and transfer (uGIMP, FLIP), which this scene's
   * figures were measured with; the library's defaults are cpGIMP, APIC. */
  MUST(gimlet_set_shape(s, GIMLET_SHAPE_UGIMP));
  MUST(gimlet_set_transfer(s, GIMLET_TRANSFER_FLIP));
  double lo = 0.25, hi = 0.75;
  for (int l = 1; l < nl; l++, lo += 0.125, hi -= 0.125) {
    double b[4] = {lo, lo, hi, hi};
    MUST(gimlet_add_level(s, b, 1));
  }
  int m;
  MUST(gimlet_add_material_linear_elastic(s, E, NU, RHO, &m));
  for (int f = 0; f < 4; f++) MUST(gimlet_set_face_bc(s, f, GIMLET_BC_ROLLER));
  MUST(gimlet_set_cfl(s, cfl));
  MUST(gimlet_fill_rectangle(s, 0, 0, 1, 1, 2, m, RHO, 0, 0, NULL));
  int64_t n;
  MUST(gimlet_get_field(s, GIMLET_FIELD_POSITION, NULL, 0, &n));
  double *x = malloc(16 * n + 16), *v = calloc(2 * n + 2, 8);
  MUST(gimlet_get_field(s, GIMLET_FIELD_POSITION, x, n, &n));
  double a = 1e-3 * wave_speed();
  for (int64_t i = 0; i < n; i++) {
    double dx = x[2 * i] - 0.5, dy = x[2 * i + 1] - 0.5, r = sqrt(dx * dx + dy * dy);
    if (kind == PLATE) {
      v[2 * i] = a * sin(M_PI * x[2 * i]);
      v[2 * i + 1] = a * sin(M_PI * x[2 * i + 1]);
    } else if (r < w) {
      double g = pow(cos(M_PI * r / (2 * w)), 2) / w;
      v[2 * i] = a * dx * g;
      v[2 * i + 1] = a * dy * g;
    }
  }
  MUST(gimlet_set_field(s, GIMLET_FIELD_VELOCITY, v, n));
  free(x);
  free(v);
  return s;
}

/* This rank's particles: reference position and velocity, 4 per particle. */
static double *state(GimletSim *s, int64_t *n) {
  MUST(gimlet_get_field(s, GIMLET_FIELD_REFERENCE, NULL, 0, n));
  double *x0 = malloc(16 * *n + 16), *v = malloc(16 * *n + 16), *out = malloc(32 * *n + 32);
  MUST(gimlet_get_field(s, GIMLET_FIELD_REFERENCE, x0, *n, n));
  MUST(gimlet_get_field(s, GIMLET_FIELD_VELOCITY, v, *n, n));
  for (int64_t i = 0; i < *n; i++) {
    out[4 * i] = x0[2 * i];
    out[4 * i + 1] = x0[2 * i + 1];
    out[4 * i + 2] = v[2 * i];
    out[4 * i + 3] = v[2 * i + 1];
  }
  free(x0);
  free(v);
  return out;
}

/* The reference run's velocity on its particle lattice (spacing sp, centres
 * (m + 1/2) sp, m < mm), gathered on every rank. */
typedef struct { int mm; double sp; double *v; } Lattice;

static void lattice(GimletSim *ref, int nref, Lattice *L) {
  int64_t n;
  double *st = state(ref, &n);
  int size;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  int cnt = (int)(4 * n), *cnts = malloc(sizeof(int) * size), *displ = malloc(sizeof(int) * size);
  MPI_Allgather(&cnt, 1, MPI_INT, cnts, 1, MPI_INT, MPI_COMM_WORLD);
  int tot = 0;
  for (int r = 0; r < size; r++) displ[r] = tot, tot += cnts[r];
  double *all = malloc(8 * (size_t)tot + 8);
  MPI_Allgatherv(st, cnt, MPI_DOUBLE, all, cnts, displ, MPI_DOUBLE, MPI_COMM_WORLD);
  L->mm = 2 * nref;
  L->sp = 1.0 / L->mm;
  if (!L->v) L->v = calloc(2 * (size_t)L->mm * L->mm, 8);
  for (int k = 0; k < tot / 4; k++) {
    int i = (int)lround(all[4 * k] / L->sp - 0.5), j = (int)lround(all[4 * k + 1] / L->sp - 0.5);
    L->v[2 * ((size_t)j * L->mm + i)] = all[4 * k + 2];
    L->v[2 * ((size_t)j * L->mm + i) + 1] = all[4 * k + 3];
  }
  free(all);
  free(cnts);
  free(displ);
  free(st);
}

static void interp(const Lattice *L, double x, double y, double out[2]) {
  double fx = x / L->sp - 0.5, fy = y / L->sp - 0.5;
  fx = fx < 0 ? 0 : fx > L->mm - 1.000001 ? L->mm - 1.000001 : fx;
  fy = fy < 0 ? 0 : fy > L->mm - 1.000001 ? L->mm - 1.000001 : fy;
  int i = (int)fx, j = (int)fy;
  double ax = fx - i, ay = fy - j;
  for (int c = 0; c < 2; c++) {
    const double *v = L->v + c;
    size_t k = (size_t)j * L->mm + i;
    out[c] = (1 - ax) * (1 - ay) * v[2 * k] + ax * (1 - ay) * v[2 * (k + 1)] +
             (1 - ax) * ay * v[2 * (k + L->mm)] + ax * ay * v[2 * (k + L->mm + 1)];
  }
}

/* RMS over the box [lo, hi]^2 of the velocity difference from the lattice. */
static double pulse_error(GimletSim *s, const Lattice *L, double lo, double hi) {
  int64_t n;
  double *st = state(s, &n), acc[2] = {0, 0};
  for (int64_t i = 0; i < n; i++) {
    double x = st[4 * i], y = st[4 * i + 1], r[2];
    if (x < lo || x > hi || y < lo || y > hi) continue;
    interp(L, x, y, r);
    acc[0] += pow(st[4 * i + 2] - r[0], 2) + pow(st[4 * i + 3] - r[1], 2);
    acc[1] += 1;
  }
  MPI_Allreduce(MPI_IN_PLACE, acc, 2, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  free(st);
  return sqrt(acc[0] / acc[1]);
}

static double min_dt(GimletSim *s, int sub) {
  double dt;
  MUST(gimlet_stable_dt(s, &dt));
  return dt * sub;
}

static void advance(GimletSim *s, double dt, int sub) {
  double t;
  int64_t st;
  for (int k = 0; k < sub; k++) MUST(gimlet_step(s, dt / sub, &t, &st));
}

static void pulse_case(int nc, int nl, double coarse_factor) {
  const double w = 0.1, c = wave_speed(), a = 1e-3 * c, tend = 0.5 / c;
  int sub = 1 << (nl - 1), nf = nc * sub, nref = 3 * nf;
  double lo = 0.25 + 0.125 * (nl - 2), hi = 1 - lo;
  GimletSim *run[3] = {make(PULSE, nc, nl, 0.5, w), make(PULSE, nf, 1, 0.5, w), make(PULSE, nc, 1, 0.5, w)};
  GimletSim *ref = make(PULSE, nref, 1, 0.5, w);
  int subs[3] = {1, sub, 1};
  double dt = min_dt(run[0], 1);
  for (int r = 1; r < 3; r++) dt = fmin(dt, min_dt(run[r], subs[r]));
  dt = fmin(dt, min_dt(ref, 3 * sub)) * 0.99;
  int nsteps = (int)ceil(tend / dt), nsamp = 10;
  dt = tend / nsteps;
  double emax[3] = {0, 0, 0}, wall[3] = {0, 0, 0};
  Lattice L = {0, 0, NULL};
  for (int k = 1; k <= nsteps; k++) {
    for (int r = 0; r < 3; r++) {
      double t0 = MPI_Wtime();
      advance(run[r], dt, subs[r]);
      wall[r] += MPI_Wtime() - t0;
    }
    advance(ref, dt, 3 * sub);
    if (k % (nsteps / nsamp) == 0 || k == nsteps) {
      lattice(ref, nref, &L);
      for (int r = 0; r < 3; r++) emax[r] = fmax(emax[r], pulse_error(run[r], &L, lo, hi) / a);
    }
  }
  if (rank_ == 0)
    printf("pulse, %d levels (%d..%d cells), %d coarse steps: max RMS velocity error / A over the "
           "finest box [%.3f, %.3f]^2: levels %.3e, uniform finest %.3e, uniform coarse %.3e "
           "(wall %.2f / %.2f / %.2f s)\n",
           nl, nc, nf, nsteps, lo, hi, emax[0], emax[1], emax[2], wall[0], wall[1], wall[2]);
  char what[128];
  snprintf(what, sizeof what, "pulse %d levels: error / uniform-finest error", nl);
  expect(emax[0] <= 2 * emax[1], what, emax[0] / emax[1], 2.0);
  snprintf(what, sizeof what, "pulse %d levels: error / uniform-coarse error", nl);
  expect(emax[0] <= coarse_factor * emax[2], what, emax[0] / emax[2], coarse_factor);
  for (int r = 0; r < 3; r++) MUST(gimlet_destroy(&run[r]));
  MUST(gimlet_destroy(&ref));
  free(L.v);
}

/* Displacement RMS error over [lo, hi]^2 against the plate's mode. */
static double plate_error(GimletSim *s, double t, double lo, double hi) {
  double c = wave_speed(), v0 = 1e-3 * c, om = M_PI * c, amp = v0 / om, acc[2] = {0, 0};
  int64_t n;
  MUST(gimlet_get_field(s, GIMLET_FIELD_POSITION, NULL, 0, &n));
  double *x = malloc(16 * n + 16), *x0 = malloc(16 * n + 16);
  MUST(gimlet_get_field(s, GIMLET_FIELD_POSITION, x, n, &n));
  MUST(gimlet_get_field(s, GIMLET_FIELD_REFERENCE, x0, n, &n));
  for (int64_t i = 0; i < n; i++) {
    double X = x0[2 * i], Y = x0[2 * i + 1];
    if (X < lo || X > hi || Y < lo || Y > hi) continue;
    double ux = amp * sin(M_PI * X) * sin(om * t), uy = amp * sin(M_PI * Y) * sin(om * t);
    acc[0] += pow(x[2 * i] - X - ux, 2) + pow(x[2 * i + 1] - Y - uy, 2);
    acc[1] += 1;
  }
  MPI_Allreduce(MPI_IN_PLACE, acc, 2, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  free(x);
  free(x0);
  return sqrt(acc[0] / acc[1]) / amp;
}

/* Runs the plate for `periods` periods at `cfl` with fixed steps; returns
 * the largest error over 8 samples per period of the first period and the
 * period-mean energies. */
static void plate_run(int nc, int nl, double cfl, int periods, double *err, double *emean) {
  GimletSim *s = make(PLATE, nc, nl, cfl, 0);
  double c = wave_speed(), T = 2.0 / c, dt = min_dt(s, 1);
  int per = 8 * (int)ceil(T / dt / 8);
  dt = T / per;
  *err = 0;
  for (int p = 0; p < periods; p++) {
    double sum = 0;
    for (int k = 1; k <= per; k++) {
      advance(s, dt, 1);
      double ke, se;
      MUST(gimlet_diagnostics(s, &ke, &se, NULL, NULL, NULL));
      sum += ke + se;
      if (p == 0 && k % (per / 8) == 0) *err = fmax(*err, plate_error(s, k * dt, 0.25, 0.75));
    }
    emean[p] = sum / per;
  }
  MUST(gimlet_destroy(&s));
}

static void plate_case(void) {
  double cfls[2] = {0.5, 0.125}, bounds[2] = {1.0, 1.25};
  for (int k = 0; k < 2; k++) {
    double el, ec, e2[2], e1[2];
    plate_run(32, 2, cfls[k], k == 0 ? 2 : 1, &el, e2);
    plate_run(32, 1, cfls[k], 1, &ec, e1);
    if (rank_ == 0)
      printf("plate, 2 levels (32..64 cells), cfl %.3f: max RMS displacement error / amplitude "
             "over [0.25, 0.75]^2 in one period: levels %.3e, uniform coarse %.3e\n",
             cfls[k], el, ec);
    char what[128];
    snprintf(what, sizeof what, "plate cfl %.3f: error / uniform-coarse error", cfls[k]);
    expect(el <= bounds[k] * ec, what, el / ec, bounds[k]);
    if (k == 0) {
      double drift = e2[1] / e2[0] - 1;
      if (rank_ == 0) printf("plate, 2 levels, cfl 0.5: period-mean energy, 2nd / 1st period - 1 = %+.3e\n", drift);
      expect(fabs(drift) <= 5e-3, "plate cfl 0.5: |energy drift| per period", fabs(drift), 5e-3);
    }
  }
}

int main(int argc, char **argv) {
  check_begin(&argc, &argv);
  const char *which = argc > 1 ? argv[1] : "all";
  if (!strcmp(which, "all") || !strcmp(which, "pulse")) {
    pulse_case(32, 2, 0.6);
    pulse_case(16, 3, 0.5);
  }
  if (!strcmp(which, "all") || !strcmp(which, "plate")) plate_case();
  return check_end("test_levels_accuracy");
}
