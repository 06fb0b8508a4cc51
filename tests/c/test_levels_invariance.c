/* Nested levels on several ranks and patch layouts (issue "Nested levels
 * with subcycling"): rank and patch invariance, exact mass conservation.
 *
 * Rank 0 first runs the scene alone (on MPI_COMM_SELF, one patch per box
 * of every level) as the reference; then every rank runs it together on
 * MPI_COMM_WORLD with every level tiled by patches of PATCH x PATCH cells.
 * Checks, after STEPS coarse steps:
 *   - positions and stresses by global id match the reference to 1e-12
 *     relative (position differences over the largest coordinate, stress
 *     differences over the largest stress component);
 *   - each particle is owned by exactly one level: the global ids over all
 *     levels are unique, and the (id, mass) list equals the one after
 *     insertion, so the total mass is conserved exactly (the diagnostic
 *     mass, a floating-point sum in patch order, within 1e-14);
 *   - at least one particle changed level (the coupling moved owners).
 * Reported: momentum and energy at the start and the end (the scenes have
 * walls and loads, so neither is conserved; the numbers show the drift).
 *
 * Scenes: "plate" (2 levels, box [0.25, 0.75]^2 of a unit square of 32
 * cells, vibrating with an amplitude of one coarse cell so that particles
 * cross patch and level boundaries) and "pressure" (the paper's
 * indentation of silicon with 3 levels under the loaded strip, see
 * test_levels_pressure.c).
 *
 *   test_levels_invariance SCENE PATCH STEPS [WEIGHTS]
 *
 * WEIGHTS is "ugimp_flip" (the default here: uGIMP weights with the
 * FLIP transfer, the paper's, which the examples and the main job use) or
 * "cpgimp_apic" (the library's default, cpGIMP weights with the APIC
 * transfer; both are set explicitly on both runs. cpGIMP with APIC is the
 * combination whose affine matrices once depended on the patch layout
 * through the nodes beyond the roller plane that only the tails of the
 * cpGIMP domains reach).
 */
#include "scenes.h"

/* The values gathered: position, stress, mass, level. */
static const int fields[4] = {GIMLET_FIELD_POSITION, GIMLET_FIELD_STRESS, GIMLET_FIELD_MASS, GIMLET_FIELD_LEVEL};
enum { V_MASS = 6, V_LEVEL = 7 };

/* Builds the scene on `comm`; `patch` > 0 tiles every level with patches
 * of that many cells. Returns the coarse step. */
static double setup(GimletSim **s, MPI_Comm comm, const char *scene, int patch, Weights w) {
  if (strcmp(scene, "plate") != 0) return pressure_scene(s, comm, 1e-6, 3, patch, patch, w);
  const double E = 1e4, nu = 0.3, rho = 1, h = 1.0 / 32;
  MUST(gimlet_create(comm, 0, 0, 1, 1, h, s));
  weights_set(*s, w);
  double b[4] = {0.25, 0.25, 0.75, 0.75};
  MUST(gimlet_add_level(*s, b, 1));
  if (patch > 0)
    for (int l = 0; l < 2; l++) MUST(gimlet_set_patch_size(*s, l, patch, patch));
  int m;
  MUST(gimlet_add_material_neo_hookean(*s, E, nu, rho, &m));
  for (int f = 0; f < 4; f++) MUST(gimlet_set_face_bc(*s, f, GIMLET_BC_ROLLER));
  MUST(gimlet_fill_rectangle(*s, 0, 0, 1, 1, 2, m, rho, 0, 0, NULL));
  double lam = E * nu / ((1 + nu) * (1 - 2 * nu)), mu = E / (2 * (1 + nu));
  double om = M_PI * sqrt((lam + 2 * mu) / rho), v0 = om * h;
  int64_t n;
  double *x = field(*s, GIMLET_FIELD_POSITION, &n);
  for (int64_t i = 0; i < 2 * n; i++) x[i] = v0 * sin(M_PI * x[i]);
  MUST(gimlet_set_field(*s, GIMLET_FIELD_VELOCITY, x, n));
  free(x);
  double dt;
  MUST(gimlet_stable_dt(*s, &dt));
  return 0.8 * dt;
}

/* A run on `comm`: the records after insertion and after `steps` coarse
 * steps (root only), the diagnostics before and after, and the number of
 * particles whose level changed. */
typedef struct {
  Rec *initial, *final;
  int64_t n0, n;
  double d0[5], d1[5];
  int64_t moved;
} Run;

/* The stable step the library takes from a step itself (each level's last
 * pass and the synchronisations that end the step) against a separate pass
 * over the particles of the same state, which setting the velocities to
 * their own values makes the next call run: bit for bit, after one more
 * step of each scheme. */
static void stable_step_check(GimletSim *s, MPI_Comm comm, double dt, const char *scene) {
  const int schemes[3] = {GIMLET_SCHEME_MUSL, GIMLET_SCHEME_USL, GIMLET_SCHEME_USF};
  const char *names[3] = {"MUSL", "USL", "USF"};
  int rank;
  MPI_Comm_rank(comm, &rank);
  for (int k = 0; k < 3; k++) {
    MUST(gimlet_set_scheme(s, schemes[k]));
    MUST(gimlet_step(s, dt, NULL, NULL));
    double from_step = 0, from_pass = 0;
    MUST(gimlet_stable_dt(s, &from_step));
    int64_t n = 0;
    double *v = field(s, GIMLET_FIELD_VELOCITY, &n);
    MUST(gimlet_set_field(s, GIMLET_FIELD_VELOCITY, v, n));
    free(v);
    MUST(gimlet_stable_dt(s, &from_pass));
    if (rank == 0)
      printf("  %s, a %s step: stable step from the step %.17g s, from a pass over the particles %.17g s\n", scene,
             names[k], from_step, from_pass);
    EXPECT(from_step == from_pass, "%s, %s: the stable step from the step (%.17g) is not the pass's (%.17g)", scene,
           names[k], from_step, from_pass);
  }
}

static Run run(MPI_Comm comm, const char *scene, int patch, int steps, Weights w) {
  Run r = {0};
  GimletSim *s = NULL;
  double dt = setup(&s, comm, scene, patch, w);
  r.initial = gather(s, comm, fields, 4, &r.n0);
  MUST(gimlet_diagnostics(s, &r.d0[0], &r.d0[1], &r.d0[2], &r.d0[3], &r.d0[4]));
  for (int k = 0; k < steps; k++) MUST(gimlet_step(s, dt, NULL, NULL));
  MUST(gimlet_diagnostics(s, &r.d1[0], &r.d1[1], &r.d1[2], &r.d1[3], &r.d1[4]));
  r.final = gather(s, comm, fields, 4, &r.n);
  stable_step_check(s, comm, dt, scene);
  for (int64_t i = 0; r.final && i < r.n && i < r.n0; i++)
    r.moved += r.final[i].id == r.initial[i].id && r.final[i].v[V_LEVEL] != r.initial[i].v[V_LEVEL];
  MUST(gimlet_destroy(&s));
  return r;
}

/* Exact conservation on the root: same ids (unique), same masses. */
static void conserved(const char *what, const Run *r) {
  int ok = r->n0 == r->n;
  for (int64_t i = 0; ok && i < r->n; i++) {
    if (i > 0 && r->final[i].id == r->final[i - 1].id) ok = 0;
    if (r->initial[i].id != r->final[i].id || r->initial[i].v[V_MASS] != r->final[i].v[V_MASS]) ok = 0;
  }
  double dm = fabs(r->d1[4] - r->d0[4]) / r->d0[4];
  printf("  %s: %lld particles, ids unique and (id, mass) list unchanged: %s; diagnostic mass change %.1e\n", what,
         (long long)r->n, ok ? "yes" : "NO", dm);
  printf("  %s: momentum (%.6e, %.6e) -> (%.6e, %.6e); energy %.6e -> %.6e (kinetic %.3e, strain %.3e)\n", what,
         r->d0[2], r->d0[3], r->d1[2], r->d1[3], r->d0[0] + r->d0[1], r->d1[0] + r->d1[1], r->d1[0], r->d1[1]);
  EXPECT(ok, "%s: the (id, mass) list changed or an id is not unique", what);
  EXPECT(dm <= 1e-14, "%s: the diagnostic mass changed by %.1e", what, dm);
}

int main(int argc, char **argv) {
  check_begin(&argc, &argv);
  int w = argc == 5 ? weights_parse(argv[4]) : UGIMP_FLIP;
  if (argc < 4 || argc > 5 || w < 0) {
    if (rank_ == 0) fprintf(stderr, "usage: %s plate|pressure PATCH STEPS [ugimp_flip|cpgimp_apic]\n", argv[0]);
    MPI_Finalize();
    return 2;
  }
  const char *scene = argv[1];
  int patch = atoi(argv[2]), steps = atoi(argv[3]);
  Run ref = {0};
  if (rank_ == 0) ref = run(MPI_COMM_SELF, scene, 0, steps, (Weights)w);
  Run now = run(MPI_COMM_WORLD, scene, patch, steps, (Weights)w);
  if (rank_ == 0) {
    printf("%s (%s), %d steps: reference 1 rank 1 patch per box; run %d ranks, patches of %d cells; %lld particles "
           "changed level (reference %lld)\n",
           scene, weights_name(w), steps, size_, patch, (long long)now.moved, (long long)ref.moved);
    conserved("reference", &ref);
    conserved("run", &now);
    double dpos = 1, dstress = 1;
    int same = pos_stress_diff(ref.final, ref.n, now.final, now.n, &dpos, &dstress);
    printf("  max |dx| / position scale = %.3e, max |dstress| / stress scale = %.3e (bound 1e-12)\n", dpos, dstress);
    EXPECT(same && dpos <= 1e-12 && dstress <= 1e-12, "the run differs from the reference");
    if (!strcmp(scene, "plate")) EXPECT(now.moved > 0, "no particle changed level");
  }
  free(ref.initial), free(ref.final), free(now.initial), free(now.final);
  return check_end("test_levels_invariance");
}
