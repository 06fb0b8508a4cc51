/* Berkovich-equivalent nanoindentation, axisymmetric: a rigid cone of
 * half-angle 70.3 degrees (the Berkovich and Vickers pyramids' projected
 * area-depth function, A = pi tan^2(70.3) h^2 = 24.5 h^2) pushed into
 * aluminium and withdrawn, on nested levels, on as many ranks as it is
 * started with; Oliver-Pharr's hardness and modulus against the inputs.
 *
 * gimlet_set_geometry(GIMLET_AXISYMMETRIC): x is the radius r (the left
 * face, r = 0, is the axis), y the axis z; the wedge on the axis is a cone
 * and gimlet_indenter_state reports the whole body's load (N, 2 pi
 * included). The body is a cylinder of radius and height R = --body a_g,
 * a_g = h tan(psi) the cone's intersection with the undeformed surface at
 * the final depth h (a few tens of contact radii: in axisymmetry the
 * elastic field decays as 1/r^2), on rollers at its bottom, its side free;
 * 40 coarse cells across R, 2 x 2 particles per cell. The levels come from
 * gimlet_propose_levels (--across T finest particles across a_g, the
 * finest box reaching --box-factor a_g from the axis and from the surface,
 * each coarser box twice as far; the proposal's plastic estimate a_g is
 * the cone's too, and the elastic contact is (2/pi) a_g), or with
 * --levels L the same boxes for a given number of levels.
 *
 * Materials (E = 70 GPa, nu = 0.33, rho = 2700 kg/m^3, the paper's
 * aluminium; the rigid tip makes the reduced modulus E/(1 - nu^2)):
 *   j2       von Mises with power hardening sigma_y = sigma_0 (1 +
 *            eps_p/eps_0)^0.1, sigma_0 = 100 MPa, eps_0 = sigma_0/E (as
 *            wedge_indentation --material j2; the default);
 *   epp      elastic-perfectly-plastic, sigma_y = E / (--e-over-sy, 200);
 *            compared with Johnson's expanding cavity model of a cone,
 *            p_m / Y = (2/3) [1 + ln(E tan(beta) / (3 Y))], beta = 90 deg -
 *            psi (Contact Mechanics, 1985);
 *   elastic  linear elastic; the loading curvature C = P/h^2 is compared
 *            with Sneddon's (2/pi) E* tan(psi): finite elements find a few
 *            per cent above it for a blunt cone (Hay, Bolshakov and Pharr
 *            1999, gamma = 1.07 at nu = 0.3), and the finite body adds a
 *            little stiffness.
 *
 * For both plastic materials and the 70.3 deg cone the loading curvature C
 * is compared with Dao et al.'s finite-element fit (Acta Materialia 49,
 * 3899, 2001, the dimensionless function Pi_1): C / sigma_r = -1.131 x^3 +
 * 13.635 x^2 - 30.594 x + 29.267, x = ln(E* / sigma_r), with E* = E/(1 -
 * nu^2) for the rigid tip and the representative stress sigma_r the flow
 * stress at plastic strain 0.033 (sigma_y when perfectly plastic; their
 * hardening law is the j2 material's form); their fit is within about 3 %
 * of their computations.
 *
 * History (gimlet_set_indenter_motion, speeds): ramp from 0 to --speed over
 * t_r, hold, ramp down to rest at the depth, hold (--hold, > 0, default t_r),
 * ramp to --unload-speed over t_r and withdraw until the load has been zero
 * for 20 steps. t_r defaults to one period of the body's quarter-wave mode,
 * 4R/c_L (13 ns): the load rings at it after a sudden start. Equal steps
 * (0.8 of the stable step at the start; less only if the stable step falls
 * below that).
 *
 *   cone_indentation [--material j2|epp|elastic] [--e-over-sy K] [--depth M]
 *                    [--across T | --levels L] [--box-factor F] [--body F]
 *                    [--speed V] [--unload-speed V] [--ramp S] [--hold S]
 *                    [--half-angle D] [--out DIR] [--name NAME] [--every N] [--quiet]
 *                    [--friction MU] [--friction-tol T] [--friction-max-iter N]
 *                    [--expect-dao TOL]
 *
 * Defaults: j2, 300 nm, T = 24 (27 finest particles across a_g: 4 levels
 * of 503, 251, 126 and 63 nm cells), F = 6 (the plastic zone, eps_p >
 * 1e-4, reaches 2.7 a in the J2 run), body 24 a_g (20 um), 10 m/s, and for the
 * plastic materials withdrawal at 1/20 of it. The metal recovers only about
 * 10 nm of the 300 on unloading, at 0.5 m/s in about 20 ns, 1.5 periods of
 * the body. The unloading stiffness S of 3-level runs at 2.5, 1, 0.5 and
 * 0.25 m/s: 1.56, 1.47, 1.42 and 1.48 x 10^5 N/m (a few per cent of noise
 * below 1 m/s, the particles leaving the contact one ring at a time). The
 * elastic body recovers it all: full speed.
 *
 * Prints the quasi-static check (kinetic energy against the work done),
 * the true contact radius, the surface's pile-up, Oliver-Pharr's analysis
 * (gimlet_indentation_analysis_axisym: hardness, reduced modulus against
 * E/(1 - nu^2), with the true contact area beside), the loading curvature
 * C and, per material, Sneddon, Johnson or Tabor. The particles enter the
 * contact one ring at a time: the loading curve is a staircase with steps
 * of a few per cent (each step an overshoot that relaxes over the next few
 * ns), so P_max moves by about that much with the depth and the speed.
 *
 * Writes DIR/NAME.csv (time_s, depth_m, load_n: the whole body's, contacts,
 * kinetic_j, strain_j, work_j = int P dh), DIR/NAME_surface.csv (the top
 * particle row by reference radius r0_m: r_load_m, uz_load_m at the start
 * of unloading, r_res_m, uz_res_m after the cone has left; uz is the
 * particle centre's rise above its place on the original surface),
 * DIR/NAME_field.csv (particles within 4 a_g of the tip at the start of
 * unloading: r, z, half-lengths, sigma_rr, sigma_zz, sigma_rz, sigma_tt,
 * eps_p), DIR/NAME.xdmf with DIR/NAME_*.h5 (all particle fields at half
 * depth, at the start of unloading and at the end; the stress's fourth
 * component is sigma_tt), DIR/NAME.json (the summary);
 * scripts/plot_cone.py DIR NAME draws them.
 *
 * --expect-dao TOL (a plastic material and the 70.3 deg cone): exit with
 * status 1 unless the loading curvature C (the least-squares fit over the
 * second half of the loading) is within TOL (relative) of Dao et al.'s
 * Pi_1 times sigma_r (ctest cone_epp_dao_np2).
 *
 * --friction MU: Coulomb friction coefficient of the cone
 * (gimlet_set_indenter_friction): MU >= 0, or inf for full adhesion (stick
 * wherever a particle carries a pressure). Without the option the cone is
 * frictionless and nothing of the run or its output changes; with it
 * (--friction 0 included, which the library keeps bitwise frictionless)
 * the run also prints the friction dissipation (gimlet_friction_stats: in
 * axisymmetry the whole body's, J) at the end of the constant-speed push,
 * at the start of unloading and at the end, the frictional solves (count,
 * mean and most friction-bound iterations) and the tangential side of the
 * contact at the end of the push (the cone still moving at --speed) and at
 * the start of unloading (after the hold, the cone at rest): the particles
 * that stick and the tangential force on the body along t = (-n_z, n_r),
 * which on the flank points up it, away from the axis, over the normal
 * force (negative where friction holds the material back towards the
 * tip). The JSON line gets friction_mu, friction_dissipation_j (the
 * end's), friction_dissipation_at_push_j, friction_dissipation_at_unload_j,
 * friction_solves, friction_iterations (summed), friction_iterations_max,
 * push_depth_m, contacts_at_push, sticking_at_push,
 * tangential_over_normal_at_push, contacts_at_unload, sticking_at_unload,
 * tangential_over_normal; DIR/NAME_contact_push.csv and
 * DIR/NAME_contact.csv hold the contact lists of the two moments (r_m,
 * z_m, n_r, n_z, pressure_pa, length_m2: the r-weighted face length per
 * radian, traction_pa, slip_m: the last step's, stick).
 * --friction-tol T, --friction-max-iter N: the frictional solve's
 * friction-bound iteration (GIMLET_CONTACT_FRICTION_TOL and
 * GIMLET_CONTACT_FRICTION_MAX_ITER; default: the library's, 1e-8 and 200). */
#include <math.h>
#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "gimlet.h"

static int rank_ = 0, size_ = 1;

#define CHECK(call)                                                      \
  do {                                                                   \
    if ((call) != GIMLET_OK) {                                           \
      char m_[1024];                                                     \
      gimlet_last_error(m_, sizeof m_, NULL);                            \
      fprintf(stderr, "rank %d: %s failed: %s\n", rank_, #call, m_);     \
      MPI_Abort(MPI_COMM_WORLD, 1);                                      \
    }                                                                    \
  } while (0)

/* This rank's particles: current and reference positions, half-lengths,
 * stress (rr, zz, rz, tt) and plastic strain. */
typedef struct {
  int64_t n;
  double *p, *r, *lp, *s, *ep;
} Parts;

static Parts fetch(GimletSim *sim) {
  Parts q;
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_POSITION, NULL, 0, &q.n));
  int64_t n = q.n;
  q.p = malloc(sizeof(double) * (2 * n + 2)), q.r = malloc(sizeof(double) * (2 * n + 2));
  q.lp = malloc(sizeof(double) * (2 * n + 2)), q.s = malloc(sizeof(double) * (4 * n + 4));
  q.ep = malloc(sizeof(double) * (n + 1));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_POSITION, q.p, n, &n));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_REFERENCE, q.r, n, &n));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_HALF_LENGTH, q.lp, n, &n));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_STRESS, q.s, n, &n));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_PLASTIC_STRAIN, q.ep, n, &n));
  return q;
}

static void release(Parts *q) { free(q->p), free(q->r), free(q->lp), free(q->s), free(q->ep); }

/* Gathers every rank's m rows of w values on rank 0; returns the row count
 * there (0 elsewhere) and the rows in *all (to be freed). */
static int64_t gather(const double *mine, int64_t m, int w, double **all) {
  int cnt = (int)(m * w), *counts = malloc(sizeof(int) * size_), *displs = malloc(sizeof(int) * size_), total = 0;
  MPI_Gather(&cnt, 1, MPI_INT, counts, 1, MPI_INT, 0, MPI_COMM_WORLD);
  if (rank_ == 0)
    for (int q = 0; q < size_; q++) displs[q] = total, total += counts[q];
  *all = malloc(sizeof(double) * (total + w));
  MPI_Gatherv(mine, cnt, MPI_DOUBLE, *all, counts, displs, MPI_DOUBLE, 0, MPI_COMM_WORLD);
  free(counts), free(displs);
  return rank_ == 0 ? total / w : 0;
}

static int by_first(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

/* The top particle row (reference centre within one particle height of the
 * original surface z_top) on rank 0, sorted by reference radius, as rows
 * (r0, r, uz) with uz = z - z0: the surface profile. */
static int64_t surface_rows(GimletSim *sim, double z_top, double **rows) {
  Parts q = fetch(sim);
  double *mine = malloc(sizeof(double) * (3 * q.n + 3));
  int64_t m = 0;
  for (int64_t i = 0; i < q.n; i++) {
    if (q.r[2 * i + 1] < z_top - 2 * q.lp[2 * i + 1]) continue;
    mine[3 * m] = q.r[2 * i], mine[3 * m + 1] = q.p[2 * i], mine[3 * m + 2] = q.p[2 * i + 1] - q.r[2 * i + 1];
    m++;
  }
  int64_t k = gather(mine, m, 3, rows);
  qsort(*rows, k, 3 * sizeof(double), by_first);
  free(mine), release(&q);
  return k;
}

/* The particles with r < win and z > z_top - win on rank 0, as rows (r, z,
 * lr, lz, s_rr, s_zz, s_rz, s_tt, eps_p). */
static int64_t field_rows(GimletSim *sim, double z_top, double win, double **rows) {
  Parts q = fetch(sim);
  double *mine = malloc(sizeof(double) * (9 * q.n + 9));
  int64_t m = 0;
  for (int64_t i = 0; i < q.n; i++) {
    if (q.p[2 * i] > win || q.p[2 * i + 1] < z_top - win) continue;
    double *o = mine + 9 * m++;
    o[0] = q.p[2 * i], o[1] = q.p[2 * i + 1], o[2] = q.lp[2 * i], o[3] = q.lp[2 * i + 1];
    for (int c = 0; c < 4; c++) o[4 + c] = q.s[4 * i + c];
    o[8] = q.ep[i];
  }
  int64_t k = gather(mine, m, 9, rows);
  free(mine), release(&q);
  return k;
}

/* The true contact radius now, from the contact list (every rank has all of
 * it), two ways. Per radian, a loaded face covers the indenter area l (the
 * library's `length`), whose projection on the surface is l |n_z|: for a
 * face spanning [r - w, r + w] that is (r+w)^2/2 - (r-w)^2/2 = 2 r w.
 *   edge: r + w = r + l |n_z| / (2r) of the outermost particle carrying
 *         pressure (wedge_indentation's half-width x + (l/2)|n_y| in r);
 *   area: sqrt(2 sum l |n_z|): the loaded faces' projected area pi a^2.
 * The particle at the edge carries almost no pressure and leaves and
 * rejoins the contact from step to step: the caller takes the largest edge
 * and the mean area over the hold. The edge is the one passed to the
 * analysis; the area comes out a few per cent larger, since the uGIMP
 * domains keep their size and overlap where the tip compresses them. */
static void contact_radius(GimletSim *sim, int ind, double *edge, double *area) {
  int64_t m = 0;
  CHECK(gimlet_get_contacts(sim, ind, 0, &m, NULL, NULL, NULL, NULL, NULL, NULL, NULL));
  double *xy = malloc(sizeof(double) * (2 * m + 2)), *nn = malloc(sizeof(double) * (2 * m + 2)),
         *len = malloc(sizeof(double) * (m + 1)), *pr = malloc(sizeof(double) * (m + 1));
  CHECK(gimlet_get_contacts(sim, ind, m, &m, xy, nn, pr, len, NULL, NULL, NULL));
  double e = 0, s = 0;
  for (int64_t k = 0; k < m; k++) {
    if (!(pr[k] > 0)) continue;
    double proj = len[k] * fabs(nn[2 * k + 1]), r = xy[2 * k];
    if (r > 0 && r + proj / (2 * r) > e) e = r + proj / (2 * r);
    s += proj;
  }
  *edge = e, *area = sqrt(2 * s);
  free(xy), free(nn), free(len), free(pr);
}

/* With friction: the contact list now with its tangential side (rank 0
 * writes it to DIR/NAME<suffix>.csv when out is not NULL), the particles
 * that carry pressure, those of them that stick, and the whole body's
 * tangential force along t = (-n_z, n_r) and normal force (N): per radian a
 * particle's force is its traction times its r-weighted length. */
static void contact_friction(GimletSim *sim, int ind, const char *out, const char *name, const char *suffix,
                             int64_t *loaded, int64_t *stick, double *f_tan, double *f_norm) {
  int64_t m = 0, mf = 0;
  CHECK(gimlet_get_contacts(sim, ind, 0, &m, NULL, NULL, NULL, NULL, NULL, NULL, NULL));
  double *xy = malloc(sizeof(double) * (2 * m + 2)), *nn = malloc(sizeof(double) * (2 * m + 2)),
         *len = malloc(sizeof(double) * (m + 1)), *pr = malloc(sizeof(double) * (m + 1)),
         *tr = malloc(sizeof(double) * (m + 1)), *sl = malloc(sizeof(double) * (m + 1));
  int *st = malloc(sizeof(int) * (m + 1));
  CHECK(gimlet_get_contacts(sim, ind, m, &m, xy, nn, pr, len, NULL, NULL, NULL));
  CHECK(gimlet_get_contact_friction(sim, ind, m, &mf, tr, sl, st));
  if (mf != m) {
    if (rank_ == 0)
      fprintf(stderr, "gimlet_get_contact_friction: %lld particles, gimlet_get_contacts %lld\n", (long long)mf,
              (long long)m);
    MPI_Abort(MPI_COMM_WORLD, 1);
  }
  FILE *f = NULL;
  if (out) {
    char path[1024];
    snprintf(path, sizeof path, "%s/%s%s.csv", out, name, suffix);
    f = fopen(path, "w");
    if (!f) {
      fprintf(stderr, "cannot write %s\n", path);
      MPI_Abort(MPI_COMM_WORLD, 1);
    }
    fprintf(f, "r_m,z_m,n_r,n_z,pressure_pa,length_m2,traction_pa,slip_m,stick\n");
  }
  *loaded = *stick = 0, *f_tan = *f_norm = 0;
  for (int64_t k = 0; k < m; k++) {
    if (f)
      fprintf(f, "%.9e,%.9e,%.6e,%.6e,%.9e,%.9e,%.9e,%.9e,%d\n", xy[2 * k], xy[2 * k + 1], nn[2 * k], nn[2 * k + 1],
              pr[k], len[k], tr[k], sl[k], st[k]);
    if (!(pr[k] > 0)) continue;
    (*loaded)++, *stick += st[k] != 0;
    *f_tan += 2 * M_PI * tr[k] * len[k], *f_norm += 2 * M_PI * pr[k] * len[k];
  }
  if (f) fclose(f);
  free(xy), free(nn), free(len), free(pr), free(tr), free(sl), free(st);
}

/* Dao et al.'s (2001) Pi_1 for the 70.3 deg cone: the loading curvature C
 * over the representative stress, as a function of E* over it. */
static double dao_pi1(double e_over_sr) {
  const double x = log(e_over_sr);
  return ((-1.131 * x + 13.635) * x - 30.594) * x + 29.267;
}

/* A number for the JSON line (JSON has no NaN: null). */
static const char *jnum(char *buf, double v) {
  if (isfinite(v)) snprintf(buf, 32, "%.6e", v);
  else snprintf(buf, 32, "null");
  return buf;
}

static FILE *open_out(const char *out, const char *name, const char *suffix) {
  char path[1024];
  snprintf(path, sizeof path, "%s/%s%s", out, name, suffix);
  FILE *f = fopen(path, "w");
  if (!f) {
    fprintf(stderr, "cannot write %s\n", path);
    MPI_Abort(MPI_COMM_WORLD, 1);
  }
  return f;
}

int main(int argc, char **argv) {
  MPI_Init(&argc, &argv);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
  enum { J2, EPP, ELASTIC } mat = J2;
  static const char *mat_name[] = {"j2", "epp", "elastic"};
  double depth = 300e-9, across = 24, box_factor = 6, body = 24, speed = 10, vu = 0, t_r = 0, hold = -1, psi_deg = 70.3;
  double e_over_sy = 200, expect_dao = -1;
  int levels = 0, every = 500, quiet = 0;
  double friction = 0, friction_tol = 0, friction_max_iter = 0; /* --friction: applied only when given */
  int friction_set = 0;
  const char *out = "results", *name = "cone";
  for (int i = 1; i < argc; i++) {
    const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : "";
    int bad = 0;
    if (!strcmp(a, "--material")) {
      if (!strcmp(v, "j2")) mat = J2;
      else if (!strcmp(v, "epp")) mat = EPP;
      else if (!strcmp(v, "elastic")) mat = ELASTIC;
      else bad = 1;
      i++;
    } else if (!strcmp(a, "--e-over-sy")) e_over_sy = atof(v), i++;
    else if (!strcmp(a, "--depth")) depth = atof(v), i++;
    else if (!strcmp(a, "--expect-dao")) bad = !((expect_dao = atof(v)) > 0), i++;
    else if (!strcmp(a, "--across")) across = atof(v), i++;
    else if (!strcmp(a, "--levels")) levels = atoi(v), i++;
    else if (!strcmp(a, "--box-factor")) box_factor = atof(v), i++;
    else if (!strcmp(a, "--body")) body = atof(v), i++;
    else if (!strcmp(a, "--speed")) speed = atof(v), i++;
    else if (!strcmp(a, "--unload-speed")) vu = atof(v), i++;
    else if (!strcmp(a, "--ramp")) t_r = atof(v), i++;
    else if (!strcmp(a, "--hold")) hold = atof(v), i++;
    else if (!strcmp(a, "--half-angle")) psi_deg = atof(v), i++;
    else if (!strcmp(a, "--out")) out = v, i++;
    else if (!strcmp(a, "--name")) name = v, i++;
    else if (!strcmp(a, "--every")) every = atoi(v), i++;
    else if (!strcmp(a, "--quiet")) quiet = 1;
    else if (!strcmp(a, "--friction")) {
      char *end = NULL;
      friction = strtod(v, &end); /* strtod reads "inf" too */
      if (end == v || *end != '\0' || isnan(friction) || friction < 0) bad = 1;
      friction_set = 1;
      i++;
    } else if (!strcmp(a, "--friction-tol")) friction_tol = atof(v), i++;
    else if (!strcmp(a, "--friction-max-iter")) friction_max_iter = atof(v), i++;
    else bad = 2;
    if (bad) {
      if (rank_ == 0) {
        if (bad == 2) fprintf(stderr, "unknown argument %s (see the comment at the top of cone_indentation.c)\n", a);
        else fprintf(stderr, "%s %s: bad value (see the comment at the top of cone_indentation.c)\n", a, v);
      }
      MPI_Finalize();
      return 2;
    }
  }
  if (!(depth > 0 && across > 0 && box_factor >= 1 && body >= 4 * box_factor && speed > 0 && vu >= 0 && t_r >= 0 &&
        (hold == -1 || hold > 0) && psi_deg > 0 && psi_deg < 90 && e_over_sy > 1 && levels >= 0 && levels <= 8 &&
        every > 0 && (expect_dao < 0 || (mat != ELASTIC && fabs(psi_deg - 70.3) < 1e-9)))) {
    if (rank_ == 0) fprintf(stderr, "cone_indentation: an option is out of range (see the comment at the top)\n");
    MPI_Finalize();
    return 2;
  }
  const double E = 70e9, nu = 0.33, rho = 2700, sigma_0 = 100e6, es = E / (1 - nu * nu);
  const double sy = mat == EPP ? E / e_over_sy : sigma_0;
  const double psi = psi_deg * M_PI / 180, beta = M_PI / 2 - psi;
  if (vu == 0) vu = mat == ELASTIC ? speed : 0.05 * speed;

  /* The body: R = body a_g, 40 coarse cells across, two coarse cells of
   * room above the surface (pile-up) and beyond the free side. */
  const double a_g = depth * tan(psi), h0 = body * a_g / 40, R = 40 * h0, H = R;
  const double domain[5] = {0, 0, R + 2 * h0, H + 2 * h0, h0};
  double boxes[4 * 7], prop[GIMLET_PROPOSAL_RESULTS];
  if (levels == 0) {
    CHECK(gimlet_propose_levels(domain, 0, H, GIMLET_INDENTER_CONE, psi_deg, depth, GIMLET_RESPONSE_PLASTIC, 2,
                                across, box_factor, 8, &levels, boxes, prop));
  } else {
    /* Level l reaches box_factor a_g 2^(L-1-l) from the axis and below the
     * surface (at least 32 finest cells), rounded out to its parent's cells. */
    for (int l = 1; l < levels; l++) {
      double hp = h0 / (1 << (l - 1)), reach = box_factor * a_g * (1 << (levels - 1 - l));
      double min_reach = 32 * h0 / (1 << (levels - 1)) * (1 << (levels - 1 - l));
      reach = hp * ceil((reach > min_reach ? reach : min_reach) / hp);
      double b[4] = {0, H - reach, reach, H + 2 * h0};
      if (b[1] < 0) b[1] = 0;
      if (b[2] > R + 2 * h0) b[2] = R + 2 * h0;
      memcpy(boxes + 4 * (l - 1), b, sizeof b);
    }
  }
  const double hf = h0 / (1 << (levels - 1)); /* the finest cell; particles hf/2 */
  GimletSim *sim = NULL;
  CHECK(gimlet_create(MPI_COMM_WORLD, 0, 0, domain[2], domain[3], h0, &sim));
  for (int l = 1; l < levels; l++) CHECK(gimlet_add_level(sim, boxes + 4 * (l - 1), 1));
  /* The axis: set before any insertion; the free left face at r = 0 then
   * takes v_r = 0. */
  CHECK(gimlet_set_geometry(sim, GIMLET_AXISYMMETRIC));
  /* 2 x 2 patches per level (a refined level's patch tiles its box plus
   * the 4-cell ghost ring on the sides away from the domain's edges). */
  for (int l = 0; l < levels; l++) {
    double hl, b[4];
    int64_t count = 0;
    CHECK(gimlet_level_info(sim, l, &hl, NULL, NULL));
    CHECK(gimlet_level_boxes(sim, l, b, 1, &count));
    int wx = (int)lround((b[2] - b[0]) / hl) + (l ? 4 : 0), wy = (int)lround((b[3] - b[1]) / hl) + (l ? 4 : 0);
    CHECK(gimlet_set_patch_size(sim, l, (wx + 1) / 2, (wy + 1) / 2));
  }
  int al;
  if (mat == J2) CHECK(gimlet_add_material_j2_power(sim, E, nu, rho, sigma_0, 0.1, sigma_0 / E, &al));
  else if (mat == EPP) CHECK(gimlet_add_material_j2_linear(sim, E, nu, rho, sy, 0.0, &al));
  else CHECK(gimlet_add_material_linear_elastic(sim, E, nu, rho, &al));
  CHECK(gimlet_set_face_bc(sim, GIMLET_FACE_BOTTOM, GIMLET_BC_ROLLER));
  /* test_axisym's indentation set-up and the paper's scheme: uGIMP, MUSL,
   * FLIP with 5 % PIC (pure FLIP leaves a particle-scale mode under the
   * tip that makes the load chatter). */
  CHECK(gimlet_set_shape(sim, GIMLET_SHAPE_UGIMP));
  CHECK(gimlet_set_scheme(sim, GIMLET_SCHEME_MUSL));
  CHECK(gimlet_set_transfer(sim, GIMLET_TRANSFER_FLIP));
  CHECK(gimlet_set_flip(sim, 0.95));
  CHECK(gimlet_fill_rectangle(sim, 0, 0, R, H, 2, al, rho, 0, 0, NULL));
  int cone;
  CHECK(gimlet_add_indenter_wedge(sim, psi_deg, 4 * depth + 2 * h0, 0.0, H, &cone));
  /* Coulomb friction along the cone's flank (the r-z face; on the axis the
   * tangential traction is radial and v_r = 0 holds it). */
  if (friction_set) CHECK(gimlet_set_indenter_friction(sim, cone, friction));
  if (friction_tol > 0) CHECK(gimlet_set_contact_option(sim, GIMLET_CONTACT_FRICTION_TOL, friction_tol));
  if (friction_max_iter > 0) CHECK(gimlet_set_contact_option(sim, GIMLET_CONTACT_FRICTION_MAX_ITER, friction_max_iter));

  /* The history. c_L: the longitudinal wave speed. */
  const double c_l = sqrt(E * (1 - nu) / ((1 + nu) * (1 - 2 * nu)) / rho);
  if (t_r == 0) t_r = 4 * H / c_l;
  if (t_r > 0.5 * depth / speed) t_r = 0.5 * depth / speed; /* the ramps fit in the push */
  if (hold < 0) hold = t_r;
  const double t2 = depth / speed, t3 = t2 + t_r, tu = t3 + hold; /* depth(t3) = depth; unloading from tu */
  double times[7] = {0, t_r, t2, t3, tu, tu + t_r, tu + t_r + 1}, speeds[7] = {0, speed, speed, 0, 0, -vu, -vu};
  CHECK(gimlet_set_indenter_motion(sim, cone, GIMLET_MOTION_VELOCITY, 7, times, speeds));
  const double t_max = tu + t_r + 1.2 * depth / vu; /* an elastic body recovers it all */

  CHECK(gimlet_output_open(sim, out, name));
  FILE *csv = rank_ == 0 ? open_out(out, name, ".csv") : NULL;
  if (csv) fprintf(csv, "time_s,depth_m,load_n,contacts,kinetic_j,strain_j,work_j\n");
  int64_t n = 0, lp[8] = {0};
  CHECK(gimlet_particle_count(sim, NULL, &n));
  for (int l = 0; l < levels; l++) {
    int64_t mine = 0;
    CHECK(gimlet_level_particle_count(sim, l, &mine));
    MPI_Allreduce(&mine, &lp[l], 1, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);
  }
  double dt0;
  CHECK(gimlet_stable_dt(sim, &dt0));
  const double dt_fix = 0.8 * dt0;
  if (rank_ == 0) {
    printf("cone nanoindentation (axisymmetric): %s aluminium, %d rank(s), %d level(s), finest cell %.4g nm "
           "(%.1f particles across a_g = h tan(psi) = %.1f nm), %lld particles; body %.2f um x %.2f um; %.1f deg cone "
           "to %.0f nm at %g m/s (ramps %.1f ns), held %.1f ns, withdrawn at %g m/s; %.0f steps of %.3g ps to the "
           "start of unloading\n",
           mat_name[mat], size_, levels, hf * 1e9, a_g / (0.5 * hf), a_g * 1e9, (long long)n, R * 1e6, H * 1e6,
           psi_deg, depth * 1e9, speed, t_r * 1e9, hold * 1e9, vu, tu / dt_fix, dt_fix * 1e12);
    if (friction_set) printf("  Coulomb friction at the cone: mu = %g\n", friction);
    fflush(stdout);
  }

  /* The run. Every step's (depth, load) goes to the analysis. */
  int64_t ns = 0, cap = 4096, step = 0;
  double *s_d = malloc(sizeof(double) * cap), *s_p = malloc(sizeof(double) * cap);
  double wall = MPI_Wtime(), t = 0, part_steps = 0, work = 0, d_prev = 0, p_prev = 0;
  double a_edge = 0, a_area = 0, ke_ratio = 0, ke_at_max = NAN, se_at_max = NAN, w_at_max = NAN;
  int n_hold = 0, wrote_half = 0, separated = 0;
  int64_t n_loading = 0; /* the series' points before the hold */
  double *surf_load = NULL, *field = NULL;
  int64_t k_load = 0, k_field = 0;
  /* With friction, at the start of unloading: the dissipation so far, the
   * loaded contact particles, those that stick, and the tangential and
   * normal forces on the body (whole body, N). */
  double fdiss_unload = NAN, f_tan = NAN, f_norm = NAN;
  int64_t n_loaded = 0, n_stick = 0;
  /* The same at the end of the constant-speed push (the first step at
   * t >= t2, the cone still moving down at --speed). */
  double fdiss_push = NAN, ft_push = NAN, fn_push = NAN, d_push = NAN;
  int64_t nl_push = 0, ns_push = 0;
  while (1) {
    double dts, d, f[2], ke, se;
    CHECK(gimlet_stable_dt(sim, &dts));
    int rc = gimlet_step(sim, dt_fix < dts ? dt_fix : dts, &t, NULL);
    if (rc != GIMLET_OK) {
      char m[1024];
      gimlet_last_error(m, sizeof m, NULL);
      if (rank_ == 0) fprintf(stderr, "step %lld (t = %.6g s): %s\n", (long long)step + 1, t, m);
      MPI_Abort(MPI_COMM_WORLD, 1);
    }
    step++;
    for (int l = 0; l < levels; l++) part_steps += (double)lp[l] * (1 << l);
    int64_t nc;
    CHECK(gimlet_indenter_state(sim, cone, &d, NULL, f, &nc));
    CHECK(gimlet_diagnostics(sim, &ke, &se, NULL, NULL, NULL));
    work += 0.5 * (f[1] + p_prev) * (d - d_prev), d_prev = d, p_prev = f[1];
    if (ns == cap) cap *= 2, s_d = realloc(s_d, sizeof(double) * cap), s_p = realloc(s_p, sizeof(double) * cap);
    s_d[ns] = d, s_p[ns++] = f[1];
    if (t < t3) n_loading = ns;
    if (csv)
      fprintf(csv, "%.9e,%.9e,%.9e,%lld,%.9e,%.9e,%.9e\n", t, d, f[1], (long long)nc, ke, se, work);
    /* Quasi-static? The kinetic energy against the work done, over the
     * second half of the loading. */
    if (t < t3 && d > 0.5 * depth && ke / work > ke_ratio) ke_ratio = ke / work;
    if (!wrote_half && d >= 0.5 * depth) {
      CHECK(gimlet_write_output(sim));
      wrote_half = 1;
    }
    if (friction_set && t >= t2 && isnan(d_push)) {
      d_push = d;
      CHECK(gimlet_friction_stats(sim, cone, &fdiss_push, NULL));
      contact_friction(sim, cone, rank_ == 0 ? out : NULL, name, "_contact_push", &nl_push, &ns_push, &ft_push,
                       &fn_push);
    }
    /* The hold at the final depth: the contact radius. */
    if (t >= t3 && t < tu) {
      double e, ar;
      contact_radius(sim, cone, &e, &ar);
      if (e > a_edge) a_edge = e;
      a_area += ar, n_hold++;
    }
    /* The start of unloading (the hold's last step): the surface, the
     * stresses, the energies. */
    if (t >= tu && !surf_load) {
      k_load = surface_rows(sim, H, &surf_load);
      k_field = field_rows(sim, H, 4 * a_g, &field);
      CHECK(gimlet_write_output(sim));
      ke_at_max = ke, se_at_max = se, w_at_max = work;
      if (friction_set) {
        CHECK(gimlet_friction_stats(sim, cone, &fdiss_unload, NULL));
        contact_friction(sim, cone, rank_ == 0 ? out : NULL, name, "_contact", &n_loaded, &n_stick, &f_tan, &f_norm);
      }
    }
    if (!quiet && step % every == 0 && rank_ == 0) {
      double el = MPI_Wtime() - wall;
      printf("  step %6lld  t %7.2f ns  depth %7.2f nm  load %9.4f mN  contacts %4lld  %5.2f M particle-steps/s\n",
             (long long)step, t * 1e9, d * 1e9, f[1] * 1e3, (long long)nc, part_steps / el / 1e6);
      fflush(stdout);
    }
    if (t > tu && nc == 0 && f[1] == 0) separated++;
    if (separated >= 20 || t >= t_max) break;
  }
  wall = MPI_Wtime() - wall;
  if (csv) fclose(csv);
  /* Friction: the dissipation (the whole body's, J) and the frictional
   * solves, the same on every rank. */
  double fdiss = 0;
  int64_t fcount[3] = {0, 0, 0};
  if (friction_set) CHECK(gimlet_friction_stats(sim, cone, &fdiss, fcount));
  CHECK(gimlet_write_output(sim));
  a_area /= n_hold > 0 ? n_hold : 1;
  /* The loading curve over its second half, h >= depth/2: least squares of
   * P = C h^2 (geometric similarity: a cone's load grows as h^2 for any
   * rate-independent material) and of ln P = ln K + x ln h. The particles
   * enter the contact one ring at a time, so the curve is a staircase of
   * steps of about 2/N of the load (N particles across a): the fit averages
   * over them, P_max/h_max^2 does not. */
  double c_fit, x_fit;
  {
    double sph2 = 0, sh4 = 0, sx = 0, sy2 = 0, sxx = 0, sxy = 0;
    int64_t k = 0;
    for (int64_t i = 0; i < n_loading; i++)
      if (s_d[i] >= 0.5 * depth && s_p[i] > 0) {
        double lx = log(s_d[i]), ly = log(s_p[i]);
        sph2 += s_p[i] * s_d[i] * s_d[i], sh4 += pow(s_d[i], 4);
        sx += lx, sy2 += ly, sxx += lx * lx, sxy += lx * ly, k++;
      }
    c_fit = k > 1 ? sph2 / sh4 : NAN;
    x_fit = k > 1 ? (k * sxy - sx * sy2) / (k * sxx - sx * sx) : NAN;
  }
  double *surf_res = NULL;
  int64_t k_res = surface_rows(sim, H, &surf_res);

  /* Oliver-Pharr (gimlet_indentation_analysis_axisym): epsilon the cone's
   * 2(pi - 2)/pi, beta 1 (a body of revolution), the fit over 40-98 % of
   * P_max, the true contact radius beside. Pure: every rank has the series. */
  double res[GIMLET_OP_RESULTS];
  int dao_failed = 0;
  int rc = gimlet_indentation_analysis_axisym(ns, s_d, s_p, GIMLET_TIP_CONE, psi_deg, NAN, 1.0, 0.4, 0.98, 0.0,
                                              a_edge, res);
  char err[1024] = "";
  if (rc != GIMLET_OK) {
    gimlet_last_error(err, sizeof err, NULL);
    for (int k = 0; k < GIMLET_OP_RESULTS; k++) res[k] = NAN;
  }
  if (rank_ == 0) {
    /* The surface files and the pile-up. */
    FILE *sf = open_out(out, name, "_surface.csv");
    fprintf(sf, "r0_m,r_load_m,uz_load_m,r_res_m,uz_res_m\n");
    double pile_res = -INFINITY, r_pile = 0, pile_load = -INFINITY, imp = 0;
    for (int64_t i = 0; i < k_res; i++) {
      const double *lo = i < k_load ? surf_load + 3 * i : NULL, *re = surf_res + 3 * i;
      fprintf(sf, "%.9e,%.9e,%.9e,%.9e,%.9e\n", re[0], lo ? lo[1] : NAN, lo ? lo[2] : NAN, re[1], re[2]);
      if (re[2] > pile_res) pile_res = re[2], r_pile = re[1];
      if (lo && lo[2] > pile_load) pile_load = lo[2];
      if (re[2] < imp) imp = re[2];
    }
    fclose(sf);
    FILE *ff = open_out(out, name, "_field.csv");
    fprintf(ff, "r_m,z_m,lr_m,lz_m,s_rr_pa,s_zz_pa,s_rz_pa,s_tt_pa,eps_p\n");
    for (int64_t i = 0; i < k_field; i++) {
      const double *o = field + 9 * i;
      fprintf(ff, "%.7e,%.7e,%.5e,%.5e,%.6e,%.6e,%.6e,%.6e,%.6e\n", o[0], o[1], o[2], o[3], o[4], o[5], o[6], o[7],
              o[8]);
    }
    fclose(ff);

    const double pm = res[GIMLET_OP_UNLOAD_LOAD], hm = res[GIMLET_OP_UNLOAD_DEPTH], C = pm / (hm * hm);
    printf("done: %lld steps in %.1f s (%.3e particle-steps/s on %d rank(s))\n", (long long)step, wall,
           part_steps / wall, size_);
    printf("  quasi-static: kinetic energy at most %.2f %% of the work done over the second half of the loading, "
           "%.3f %% at the start of unloading (work %.4g nJ, strain energy %.4g nJ, dissipated %.4g nJ)\n",
           100 * ke_ratio, 100 * ke_at_max / w_at_max, w_at_max * 1e9, se_at_max * 1e9,
           (w_at_max - se_at_max - ke_at_max) * 1e9);
    printf("  true contact radius over the hold: %.1f nm (outer edge of the outermost loaded face, %.1f finest "
           "particles; the loaded faces' projected area gives %.1f nm); a_g = h tan(psi) = %.1f nm\n",
           a_edge * 1e9, a_edge / (0.5 * hf), a_area * 1e9, a_g * 1e9);
    printf("  surface (top particle row): at the start of unloading highest %+.2f nm; after unloading the impression "
           "is %.2f nm deep at the axis, pile-up %+.2f nm at r = %.0f nm\n",
           pile_load * 1e9, -imp * 1e9, pile_res * 1e9, r_pile * 1e9);
    if (rc != GIMLET_OK) {
      printf("  Oliver-Pharr analysis failed: %s\n", err);
    } else {
      const double er = res[GIMLET_OP_REDUCED_MODULUS], ert = res[GIMLET_OP_TRUE_REDUCED_MODULUS];
      printf("  Oliver-Pharr (fit P = B (h - h_f)^m over 40-98 %% of P_max: %d points, m = %.3f, RMS %.2g %%):\n",
             (int)res[GIMLET_OP_FIT_POINTS], res[GIMLET_OP_FIT_M], 100 * res[GIMLET_OP_FIT_RMS]);
      printf("    P_max %.5g mN at h_max %.2f nm (largest load %.5g mN), P_max/h_max^2 = %.4g GPa\n", pm * 1e3,
             hm * 1e9, res[GIMLET_OP_MAX_LOAD] * 1e3, C / 1e9);
      printf("    stiffness S %.5g N/m, contact depth h_c %.2f nm (h_c/h_max %.3f), residual depth %.2f nm\n",
             res[GIMLET_OP_STIFFNESS], res[GIMLET_OP_CONTACT_DEPTH] * 1e9, res[GIMLET_OP_CONTACT_DEPTH] / hm,
             res[GIMLET_OP_RESIDUAL_DEPTH] * 1e9);
      printf("    hardness H = %.4g GPa (A(h_c) = %.4g um^2); reduced modulus E_r = %.4g GPa against the input "
             "E/(1 - nu^2) = %.4g GPa: %+.2f %%\n",
             res[GIMLET_OP_HARDNESS] / 1e9, res[GIMLET_OP_AREA] * 1e12, er / 1e9, es / 1e9, 100 * (er / es - 1));
      printf("    true area pi a^2 = %.4g um^2 (a = %.1f nm): %.3f of Oliver-Pharr's; H_true = %.4g GPa, "
             "E_r,true = %.4g GPa (%+.2f %%); true contact depth %.2f nm\n",
             res[GIMLET_OP_TRUE_AREA] * 1e12, a_edge * 1e9, res[GIMLET_OP_AREA_RATIO],
             res[GIMLET_OP_TRUE_HARDNESS] / 1e9, ert / 1e9,
             100 * (ert / es - 1), res[GIMLET_OP_TRUE_CONTACT_DEPTH] * 1e9);
    }
    if (friction_set) {
      printf("  friction (mu = %g): dissipated %.6g nJ (whole body) by the end of the push, %.6g nJ by the start "
             "of unloading (%.2f %% of the work done), %.6g nJ in all; %lld frictional solves, %.2f friction-bound "
             "iterations per solve, at most %lld\n",
             friction, fdiss_push * 1e9, fdiss_unload * 1e9, 100 * fdiss_unload / w_at_max, fdiss * 1e9,
             (long long)fcount[0], fcount[0] ? (double)fcount[1] / fcount[0] : 0.0, (long long)fcount[2]);
      printf("  contact at the end of the push (depth %.1f nm, moving): %lld particles carry pressure, %lld of them "
             "stick; tangential force along the flank's upward tangent over the normal force %+.4f (tangential %.5g "
             "mN, normal %.5g mN)\n",
             d_push * 1e9, (long long)nl_push, (long long)ns_push, fn_push > 0 ? ft_push / fn_push : NAN,
             ft_push * 1e3, fn_push * 1e3);
      printf("  contact at the start of unloading (after the hold): %lld particles carry pressure, %lld of them "
             "stick; tangential force over normal force %+.4f (tangential %.5g mN, normal %.5g mN)\n",
             (long long)n_loaded, (long long)n_stick, f_norm > 0 ? f_tan / f_norm : NAN, f_tan * 1e3, f_norm * 1e3);
    }
    printf("  loading curve over h >= %.0f nm: C = P/h^2 = %.4g GPa (least squares), exponent %.3f\n",
           0.5 * depth * 1e9, c_fit / 1e9, x_fit);
    if (mat == ELASTIC) {
      const double cs = 2 / M_PI * es * tan(psi), as = 2 / M_PI * depth * tan(psi);
      printf("  elastic: C / Sneddon's (2/pi) E* tan(psi) = %.4f (fit), %.4f (P_max/h_max^2); Hay, Bolshakov and "
             "Pharr expect about 1.07 (the surface's radial displacement), the finite body a little more; contact "
             "radius / Sneddon's (2/pi) h tan(psi) = %.4f\n",
             c_fit / cs, C / cs, a_edge / as);
    } else {
      printf("  sigma_y %.4g MPa: C/sigma_y = %.2f (fit), H/sigma_y = %.3f (Oliver-Pharr), %.3f (true area)\n",
             sy / 1e6, c_fit / sy, res[GIMLET_OP_HARDNESS] / sy, res[GIMLET_OP_TRUE_HARDNESS] / sy);
      if (mat == EPP) {
        const double pj = 2.0 / 3.0 * (1 + log(E * tan(beta) / (3 * sy)));
        printf("  Johnson's expanding cavity p_m/Y = (2/3)[1 + ln(E tan(beta)/(3Y))] = %.3f (beta = %.1f deg): "
               "H_true/sigma_y %+.1f %%, H_OP/sigma_y %+.1f %% from it\n",
               pj, 90 - psi_deg, 100 * (res[GIMLET_OP_TRUE_HARDNESS] / sy / pj - 1),
               100 * (res[GIMLET_OP_HARDNESS] / sy / pj - 1));
      } else {
        /* Tabor: H about 3 times the flow stress at the representative
         * strain 0.08 of a Vickers (70.3 deg-equivalent) indentation. */
        const double sr = sigma_0 * pow(1 + 0.08 * E / sigma_0, 0.1);
        printf("  Tabor's H ~ 3 sigma_y(eps_p = 0.08) = %.4g GPa: H_true %+.1f %%, H_OP %+.1f %% from it\n",
               3 * sr / 1e9, 100 * (res[GIMLET_OP_TRUE_HARDNESS] / (3 * sr) - 1),
               100 * (res[GIMLET_OP_HARDNESS] / (3 * sr) - 1));
      }
      if (fabs(psi_deg - 70.3) < 1e-9) {
        /* Dao et al.'s representative stress: the flow stress at plastic
         * strain 0.033 (sigma_y for the perfectly plastic solid). */
        const double sr = mat == EPP ? sy : sigma_0 * pow(1 + 0.033 * E / sigma_0, 0.1), pi1 = dao_pi1(es / sr);
        printf("  Dao et al. (2001) Pi_1 for the 70.3 deg cone: sigma_r = sigma(eps_p = 0.033) = %.4g MPa, "
               "ln(E*/sigma_r) = %.3f, C/sigma_r = %.2f; C (fit) %+.2f %% from it\n",
               sr / 1e6, log(es / sr), pi1, 100 * (c_fit / sr / pi1 - 1));
        if (expect_dao > 0 && !(fabs(c_fit / sr / pi1 - 1) <= expect_dao)) {
          printf("  FAILED: C/sigma_r = %.3f is not within %.1f %% of Dao et al.'s Pi_1 = %.3f\n", c_fit / sr,
                 100 * expect_dao, pi1);
          dao_failed = 1;
        }
      }
    }
    /* The summary in one line (stdout and DIR/NAME.json; plot_cone.py reads it). */
    char b[24][32], js[4096];
    snprintf(js, sizeof js,
             "{\"case\":\"cone\",\"ranks\":%d,\"material\":\"%s\",\"e_pa\":%.6e,\"nu\":%.3f,\"sigma_y_pa\":%s,"
             "\"half_angle_deg\":%.3f,\"surface_z_m\":%.6e,\"depth_m\":%.6e,\"levels\":%d,\"finest_cell_m\":%.6e,"
             "\"particles\":%lld,"
             "\"steps\":%lld,\"wall_s\":%.2f,\"p_max_n\":%s,\"h_max_m\":%s,\"c_pa\":%s,\"c_fit_pa\":%s,"
             "\"load_exponent\":%s,\"fit_m\":%s,"
             "\"stiffness_n_per_m\":%s,\"contact_depth_m\":%s,\"hardness_pa\":%s,\"reduced_modulus_pa\":%s,"
             "\"input_reduced_modulus_pa\":%.6e,\"residual_depth_m\":%s,\"area_m2\":%s,\"true_contact_radius_m\":%s,"
             "\"area_contact_radius_m\":%s,\"true_area_m2\":%s,\"true_hardness_pa\":%s,"
             "\"true_reduced_modulus_pa\":%s,\"area_ratio\":%s,\"pileup_m\":%s,\"pileup_at_load_m\":%s,"
             "\"impression_depth_m\":%s,\"kinetic_over_work\":%s}",
             size_, mat_name[mat], E, nu, jnum(b[20], mat == ELASTIC ? NAN : sy), psi_deg, H, depth, levels, hf,
             (long long)n,
             (long long)step, wall, jnum(b[0], pm), jnum(b[1], hm), jnum(b[2], C),
             jnum(b[21], c_fit), jnum(b[22], x_fit),
             jnum(b[3], res[GIMLET_OP_FIT_M]), jnum(b[4], res[GIMLET_OP_STIFFNESS]),
             jnum(b[5], res[GIMLET_OP_CONTACT_DEPTH]), jnum(b[6], res[GIMLET_OP_HARDNESS]),
             jnum(b[7], res[GIMLET_OP_REDUCED_MODULUS]), es,
             jnum(b[8], res[GIMLET_OP_RESIDUAL_DEPTH]), jnum(b[9], res[GIMLET_OP_AREA]),
             jnum(b[10], a_edge), jnum(b[11], a_area), jnum(b[12], res[GIMLET_OP_TRUE_AREA]),
             jnum(b[13], res[GIMLET_OP_TRUE_HARDNESS]),
             jnum(b[14], res[GIMLET_OP_TRUE_REDUCED_MODULUS]),
             jnum(b[15], res[GIMLET_OP_AREA_RATIO]), jnum(b[16], pile_res), jnum(b[17], pile_load),
             jnum(b[18], -imp), jnum(b[19], ke_ratio));
    if (friction_set) {
      /* Before the closing brace. JSON has no infinity: adhesion is "inf". */
      size_t L = strlen(js) - 1;
      char mu_s[32];
      if (isinf(friction)) snprintf(mu_s, sizeof mu_s, "\"inf\"");
      else snprintf(mu_s, sizeof mu_s, "%.6g", friction);
      snprintf(js + L, sizeof js - L,
               ",\"friction_mu\":%s,\"friction_dissipation_j\":%s,\"friction_dissipation_at_push_j\":%s,"
               "\"friction_dissipation_at_unload_j\":%s,"
               "\"friction_solves\":%lld,\"friction_iterations\":%lld,\"friction_iterations_max\":%lld,"
               "\"push_depth_m\":%s,\"contacts_at_push\":%lld,\"sticking_at_push\":%lld,"
               "\"tangential_over_normal_at_push\":%s,"
               "\"contacts_at_unload\":%lld,\"sticking_at_unload\":%lld,\"tangential_over_normal\":%s}",
               mu_s, jnum(b[0], fdiss), jnum(b[3], fdiss_push), jnum(b[1], fdiss_unload), (long long)fcount[0],
               (long long)fcount[1], (long long)fcount[2], jnum(b[4], d_push), (long long)nl_push,
               (long long)ns_push, jnum(b[5], fn_push > 0 ? ft_push / fn_push : NAN), (long long)n_loaded,
               (long long)n_stick, jnum(b[2], f_norm > 0 ? f_tan / f_norm : NAN));
    }
    printf("%s\n", js);
    FILE *jf = open_out(out, name, ".json");
    fprintf(jf, "%s\n", js);
    fclose(jf);
    if (friction_set)
      printf("  wrote %s/%s.csv, %s_surface.csv, %s_field.csv, %s_contact_push.csv, %s_contact.csv, %s.json, %s.xdmf "
             "(+ h5)\n", out, name, name, name, name, name, name, name);
    else
      printf("  wrote %s/%s.csv, %s_surface.csv, %s_field.csv, %s.json, %s.xdmf (+ h5)\n", out, name, name, name, name,
             name);
    fflush(stdout);
  }
  free(s_d), free(s_p), free(surf_load), free(surf_res), free(field);
  CHECK(gimlet_destroy(&sim));
  MPI_Finalize();
  return rc == GIMLET_OK && !dao_failed ? 0 : 1;
}
