/* Contact with rigid indenters, through the C API, each case against a
 * bound that means something:
 *
 *   test_contact early        no early contact: an indenter that stops a
 *                             fraction of a cell above the block leaves it
 *                             untouched (exactly zero force, bitwise at rest)
 *   test_contact separation   no late separation: a punch withdrawn faster
 *                             than the surface can follow lets go within one
 *                             step of the geometric separation
 *   test_contact punch        flat punch: pressure profile against the
 *                             half-space closed form for |x| < 0.8 a, and the
 *                             load at a given depth converging under
 *                             refinement
 *   test_contact hertz        rigid cylinder (Hertz line contact): contact
 *                             half-width and peak pressure against
 *                             a^2 = 4PR/(pi E*), p0 = 2P/(pi a), and the
 *                             profile's RMS error over |x| < 0.9 a
 *   test_contact quasistatic  halving the indenter speed changes the load at
 *                             the final depth by less than 1 %
 *
 * Every case runs on any number of ranks. */
#include "contact_common.h"

/* Advances to time `t_end` with stable steps. */
static void run_to(GimletSim *sim, double t_end) {
  double t = 0;
  CHECK(gimlet_time(sim, &t, NULL));
  while (t < t_end * (1 - 1e-12)) {
    double dt;
    CHECK(gimlet_stable_dt(sim, &dt));
    if (t + dt > t_end) dt = t_end - t;
    CHECK(gimlet_step(sim, dt, &t, NULL));
  }
}

/* A depth history: 0 until t0, then a smooth (cosine) ramp to `d` over
 * `tr`, sampled at k points. */
static void ramp_depth(GimletSim *sim, int ind, double d, double tr) {
  enum { K = 33 };
  double t[K], v[K];
  for (int i = 0; i < K; i++) {
    double s = (double)i / (K - 1);
    t[i] = s * tr;
    v[i] = d * 0.5 * (1 - cos(M_PI * s));
  }
  CHECK(gimlet_set_indenter_motion(sim, ind, GIMLET_MOTION_DEPTH, K, t, v));
}

/* Time average of the indenter's vertical force over `steps` steps. */
static double mean_force(GimletSim *sim, int ind, int steps) {
  double acc = 0;
  for (int k = 0; k < steps; k++) {
    CHECK(gimlet_step(sim, 0, NULL, NULL));
    double f[2];
    CHECK(gimlet_indenter_state(sim, ind, NULL, NULL, f, NULL));
    acc += f[1];
  }
  return acc / steps;
}

/* Time averages over `steps` steps of the vertical force and of each
 * particle's pressure times face length (by id, up to `nid` ids). */
static double mean_profile(GimletSim *sim, int ind, int steps, double *pl, double *xs, int64_t nid) {
  double acc = 0;
  for (int64_t i = 0; i < nid; i++) pl[i] = 0, xs[i] = NAN;
  for (int k = 0; k < steps; k++) {
    CHECK(gimlet_step(sim, 0, NULL, NULL));
    double f[2];
    CHECK(gimlet_indenter_state(sim, ind, NULL, NULL, f, NULL));
    acc += f[1];
    if (getenv("GIMLET_TEST_TRACE") && rank_ == 0) printf("    step %d force %.6g\n", k, f[1]);
    Contacts c = contacts_get(sim, ind);
    for (int64_t i = 0; i < c.n; i++)
      if (c.id[i] < nid) {
        pl[c.id[i]] += c.p[i] * c.len[i] / steps;
        xs[c.id[i]] = c.x[2 * i];
      }
    contacts_free(&c);
  }
  return acc / steps;
}

static int case_punch(void) {
  Scene s = scene_defaults();
  s.levels = 3;
  s.h0 = 1.0 / 16;
  s.size = 0.125;
  if (getenv("GIMLET_TEST_SIZE")) s.size = atof(getenv("GIMLET_TEST_SIZE"));
  if (getenv("GIMLET_TEST_SCHEME")) s.scheme = atoi(getenv("GIMLET_TEST_SCHEME"));
  if (getenv("GIMLET_TEST_FLIP")) s.flip = atof(getenv("GIMLET_TEST_FLIP"));
  if (getenv("GIMLET_TEST_LEVELS")) s.levels = atoi(getenv("GIMLET_TEST_LEVELS"));
  if (getenv("GIMLET_TEST_SHAPE")) s.shape = atoi(getenv("GIMLET_TEST_SHAPE"));
  int ind;
  GimletSim *sim = scene_build(&s, &ind);
  const char *eps = getenv("GIMLET_TEST_EPS");
  if (eps) CHECK(gimlet_set_contact_option(sim, GIMLET_CONTACT_REGULARIZATION, atof(eps)));
  double c = wave_speed(&s), tr = 20 * s.hb / c, d = 1e-3 * s.size;
  if (getenv("GIMLET_TEST_DEPTH")) d = atof(getenv("GIMLET_TEST_DEPTH"));
  ramp_depth(sim, ind, d, tr);
  run_to(sim, tr);
  int64_t nid = 0;
  CHECK(gimlet_particle_count(sim, NULL, &nid));
  nid *= 4;
  double *pl = calloc(nid, sizeof(double)), *xs = calloc(nid, sizeof(double));
  double f = mean_profile(sim, ind, 200, pl, xs, nid);
  Contacts k = contacts_get(sim, ind);
  double P = 2 * f; /* full punch */
  if (rank_ == 0) {
    printf("punch: depth %g, load %g (full), %lld contacts now\n", d, P, (long long)k.n);
    for (int64_t i = 0; i < nid; i++) {
      if (isnan(xs[i])) continue;
      double x = xs[i], ex = P / (M_PI * sqrt(s.size * s.size - x * x));
      double len = s.h0 / (1 << (s.levels - 1)) / 2; /* a fine particle's width */
      if (getenv("GIMLET_TEST_SHAPE")) {
        printf("  id %lld x %.4f  mean p*len %.5g\n", (long long)i, x, pl[i]);
        continue;
      }
      printf("  id %lld x %.4f  mean p %.5g  closed %.5g  ratio %.4f  pl %.5g\n", (long long)i, x, pl[i] / len, ex,
             pl[i] / len / ex, pl[i]);
    }
  }
  free(pl);
  free(xs);
  contacts_free(&k);
  CHECK(gimlet_destroy(&sim));
  return 0;
}

int main(int argc, char **argv) {
  MPI_Init(&argc, &argv);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
  const char *which = argc > 1 ? argv[1] : "";
  if (!strcmp(which, "punch")) case_punch();
  else {
    if (rank_ == 0) fprintf(stderr, "usage: %s early|separation|punch|hertz|quasistatic\n", argv[0]);
    failures_++;
  }
  MPI_Finalize();
  return failures_ ? 1 : 0;
}
