/* A scratch test: a rigid wedge with Coulomb friction is pressed into an
 * aluminium block, then dragged sideways along the surface over several
 * contact widths, and lifted off, on as many ranks as it is started with.
 *
 * Plane strain (the x-y plane is the plane of the scratch: the groove's
 * section along the scratch direction). The material is the J2 aluminium
 * of wedge_indentation --material j2 (E = 70 GPa, nu = 0.33, rho = 2700
 * kg/m^3, von Mises with power hardening sigma_y = sigma_0 (1 +
 * eps_p/eps_0)^n, sigma_0 = 100 MPa, n = 0.1, eps_0 = sigma_0/E), or with
 * --material elastic linear elastic. The block, W x H (default 48 um x
 * 24 um), sits on rollers at its bottom, left and right faces, 2x2
 * particles per cell, with room above its top for the material the wedge
 * pushes up. Nested levels (cells of 1000, 500 and 250 nm by default)
 * reach the top surface and cover the whole track: the finest box spans
 * the travel plus --margin on each side and reaches --box-depth below the
 * surface; each coarser box adds --grow on the left, the right and below.
 * The wedge (tip half-angle 65 degrees, the paper's) starts with its apex
 * on the surface at x_s; it is pushed to --depth (speed ramped from 0 to
 * --speed over --ramp, held, ramped down to rest at the depth), held for
 * half a ramp, then moved +x by --travel (gimlet_set_indenter_lateral: the
 * lateral speed ramped up over --ramp, held at --lateral-speed, ramped
 * down to rest at the end of the travel) at its depth, held for half a
 * ramp and withdrawn at --speed until it has been clear of the surface
 * for 20 steps.
 *
 *   scratch [--material j2|elastic] [--friction MU] [--depth M] [--travel M]
 *           [--speed V] [--lateral-speed V] [--ramp S] [--h0 M] [--levels L]
 *           [--width M] [--height M] [--margin M] [--box-depth M] [--grow M]
 *           [--half-angle D] [--shape ugimp|cpgimp] [--transfer flip|apic]
 *           [--dt-factor F] [--flip F] [--friction-tol T] [--friction-max-iter N]
 *           [--out DIR] [--name NAME] [--every N] [--quiet]
 *
 *   --friction MU Coulomb friction coefficient of the wedge (default 0.2;
 *                 inf: full adhesion)
 *   --depth M     scratch depth below the undeformed surface (default 4e-7)
 *   --travel M    sideways travel of the tip (default 6e-6: three widths
 *                 of the static contact, 2a, or about five of the contact
 *                 while sliding, which is on the front flank only)
 *   --speed V     pressing and withdrawal speed (default 20 m/s)
 *   --lateral-speed V  sliding speed (default 40 m/s: 0.6 % of the
 *                 longitudinal wave speed; J2 is rate independent). At 20
 *                 m/s over 8 um (about 7000 steps) the run fails near the
 *                 end of the travel: with J2 on these levels, plastic strain
 *                 and particle speeds grow at the refined boxes' edges and
 *                 corners, far from the wedge, and a wedge merely held at
 *                 its depth fails the same way at about step 7000; the
 *                 default run (about 3200 steps) stays clear of it
 *   --ramp S      speed ramps (default 2e-8 s)
 *   --h0 M        coarse cell (default 1e-6); --levels L (default 3)
 *   --shape, --transfer  particle weights and velocity transfer (default
 *                 the library's, cpGIMP and APIC, which hold large shear;
 *                 --flip F the FLIP fraction under --transfer flip, default
 *                 0.95)
 *   --friction-tol T, --friction-max-iter N  the frictional solve's
 *                 friction-bound iteration (GIMLET_CONTACT_FRICTION_TOL and
 *                 _MAX_ITER; default the library's, 1e-8 and 200)
 *   --dt-factor F the step as a fraction of the stable one (default 0.8;
 *                 each step takes the smaller of that fraction of the
 *                 step stable at the start and the step stable now)
 *
 * Writes DIR/NAME.csv (NAME: scratch by default), one row per coarse step:
 * time_s, x_tip_m (the tip's lateral displacement from its start),
 * depth_m, fx_n_per_m, fy_n_per_m (the force on the wedge per metre of
 * thickness, gimlet_indenter_state: fy > 0 is the normal load, fx < 0
 * resists the +x motion), contacts, sticking (contact particles that stick),
 * dissipation_j_per_m (friction dissipation since the start, whole body),
 * fx_contacts_n_per_m, fy_contacts_n_per_m (the force on the wedge summed
 * from the contact list after the finest level's last substep: -(p n +
 * tau t) length per particle, a check of the library's force);
 * DIR/NAME_groove.csv, the surface once the wedge has left: the upper
 * envelope of the particles in bins of the finest particles' width (x_m:
 * the bin's centre, height_m: the top edge of the highest particle there
 * above the original surface, x0_m, y0_m: that particle's reference
 * centre: in plane strain the wedge drags the surface layer along into a
 * prow, so the top particle row no longer is the surface); DIR/NAME.json
 * (the settings and the summary in one line); DIR/NAME.xdmf with
 * DIR/NAME_*.h5 (the particle fields at the start of sliding, after each
 * quarter of the travel and at the end);
 * and prints a summary: the forces and the friction ratio -fx/fy in gross
 * sliding (the travel from a quarter of it to the start of the lateral
 * deceleration), the share of the tangential work the friction
 * dissipates, the groove's depth and the prow's height, the wall time.
 * scripts/plot_scratch.py draws DIR/NAME.csv and DIR/NAME_groove.csv. The
 * run takes about 30 s on 2 cores. */
#include <math.h>
#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "gimlet.h"

static int rank_ = 0;

#define CHECK(call)                                                      \
  do {                                                                   \
    if ((call) != GIMLET_OK) {                                           \
      char m_[1024];                                                     \
      gimlet_last_error(m_, sizeof m_, NULL);                            \
      fprintf(stderr, "rank %d: %s failed: %s\n", rank_, #call, m_);     \
      MPI_Abort(MPI_COMM_WORLD, 1);                                      \
    }                                                                    \
  } while (0)

/* The lateral schedule: n points (t, x), linear in between, constant
 * outside, as the library interpolates it. */
#define NLAT 64
static int nlat = 0;
static double lat_t[NLAT], lat_x[NLAT];

static double lateral_at(double t) {
  if (nlat == 0 || t <= lat_t[0]) return nlat ? lat_x[0] : 0.0;
  for (int k = 1; k < nlat; k++)
    if (t <= lat_t[k]) return lat_x[k - 1] + (t - lat_t[k - 1]) / (lat_t[k] - lat_t[k - 1]) * (lat_x[k] - lat_x[k - 1]);
  return lat_x[nlat - 1];
}

/* Round v to a multiple of h (the boxes align with the coarse cells). */
static double snap(double v, double h) { return h * round(v / h); }

static int cmp_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

/* The surface after the scratch: the upper envelope of the particles. The
 * x range [0, W] is cut into bins of width dx (the finest particles'
 * width); each bin gets the top edge (y + half-length) of the highest
 * particle whose x extent overlaps it, and that particle's reference
 * centre (where the surface material came from). Particles whose top edge
 * lies below y_min are skipped (they cannot be on the surface). On rank 0
 * rows (x, top, x0, y0) of the bins some particle overlaps, by x; returns
 * their count there (0 elsewhere). */
static int64_t surface_envelope(GimletSim *sim, double W, double dx, double y_min, double **rows) {
  int64_t n = 0;
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_POSITION, NULL, 0, &n));
  double *p = malloc(sizeof(double) * (2 * n + 2)), *r = malloc(sizeof(double) * (2 * n + 2)),
         *lp = malloc(sizeof(double) * (2 * n + 2));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_POSITION, p, n, &n));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_REFERENCE, r, n, &n));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_HALF_LENGTH, lp, n, &n));
  const int64_t nb = (int64_t)ceil(W / dx);
  /* Per bin: (top, x0, y0) of this rank's highest particle; the ranks'
   * bins are merged by the top (MPI_MAXLOC on (top, rank)), then the owner
   * of each bin's winner sends its reference position. */
  struct { double v; int r; } *mine = malloc(sizeof *mine * nb), *best = malloc(sizeof *best * nb);
  double *ref = malloc(sizeof(double) * 2 * nb), *ref_all = malloc(sizeof(double) * 2 * nb);
  for (int64_t b = 0; b < nb; b++) mine[b].v = -INFINITY, mine[b].r = rank_, ref[2 * b] = ref[2 * b + 1] = 0;
  for (int64_t i = 0; i < n; i++) {
    double top = p[2 * i + 1] + lp[2 * i + 1];
    if (top < y_min) continue;
    int64_t b0 = (int64_t)floor((p[2 * i] - lp[2 * i]) / dx + 1e-9);
    int64_t b1 = (int64_t)ceil((p[2 * i] + lp[2 * i]) / dx - 1e-9);
    for (int64_t b = b0 < 0 ? 0 : b0; b < b1 && b < nb; b++)
      if (top > mine[b].v) mine[b].v = top, ref[2 * b] = r[2 * i], ref[2 * b + 1] = r[2 * i + 1];
  }
  MPI_Allreduce(mine, best, (int)nb, MPI_DOUBLE_INT, MPI_MAXLOC, MPI_COMM_WORLD);
  for (int64_t b = 0; b < nb; b++)
    if (best[b].r != rank_) ref[2 * b] = ref[2 * b + 1] = 0;
  MPI_Reduce(ref, ref_all, (int)(2 * nb), MPI_DOUBLE, MPI_SUM, 0, MPI_COMM_WORLD);
  double *out = malloc(sizeof(double) * 4 * (nb + 1));
  int64_t k = 0;
  if (rank_ == 0)
    for (int64_t b = 0; b < nb; b++)
      if (best[b].v > -INFINITY) {
        out[4 * k] = (b + 0.5) * dx, out[4 * k + 1] = best[b].v;
        out[4 * k + 2] = ref_all[2 * b], out[4 * k + 3] = ref_all[2 * b + 1];
        k++;
      }
  free(p); free(r); free(lp); free(mine); free(best); free(ref); free(ref_all);
  *rows = out;
  return k;
}

/* The force on the wedge summed from its contact list (every rank has the
 * whole list): the body gets p n + tau t per unit face length (n the
 * contact normal into the body, t = (-n_y, n_x)); the wedge the opposite.
 * Also the number of contact particles that carry a pressure and how many
 * of them stick. */
static void contact_force(GimletSim *sim, int ind, double f[2], int64_t *loaded, int64_t *sticking) {
  int64_t m = 0, mf = 0;
  CHECK(gimlet_get_contacts(sim, ind, 0, &m, NULL, NULL, NULL, NULL, NULL, NULL, NULL));
  double *nn = malloc(sizeof(double) * (2 * m + 2)), *pr = malloc(sizeof(double) * (m + 1)),
         *len = malloc(sizeof(double) * (m + 1)), *tr = malloc(sizeof(double) * (m + 1));
  int *st = malloc(sizeof(int) * (m + 1));
  CHECK(gimlet_get_contacts(sim, ind, m, &m, NULL, nn, pr, len, NULL, NULL, NULL));
  CHECK(gimlet_get_contact_friction(sim, ind, m, &mf, tr, NULL, st));
  if (mf != m) {
    fprintf(stderr, "rank %d: gimlet_get_contact_friction lists %lld particles, gimlet_get_contacts %lld\n", rank_,
            (long long)mf, (long long)m);
    MPI_Abort(MPI_COMM_WORLD, 1);
  }
  f[0] = f[1] = 0;
  *loaded = *sticking = 0;
  for (int64_t k = 0; k < m; k++) {
    double nx = nn[2 * k], ny = nn[2 * k + 1], tx = -ny, ty = nx;
    f[0] -= (pr[k] * nx + tr[k] * tx) * len[k];
    f[1] -= (pr[k] * ny + tr[k] * ty) * len[k];
    if (pr[k] > 0) {
      (*loaded)++;
      if (st[k]) (*sticking)++;
    }
  }
  free(nn); free(pr); free(len); free(tr); free(st);
}

int main(int argc, char **argv) {
  MPI_Init(&argc, &argv);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  int size;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  const double um = 1e-6;
  int j2 = 1, levels = 3, every = 500, quiet = 0;
  int shape = GIMLET_SHAPE_CPGIMP, transfer = GIMLET_TRANSFER_APIC;
  double mu = 0.2, depth = 0.4 * um, travel = 6 * um, speed = 20, vlat = 40, t_r = 20e-9, h0 = 1 * um;
  double W = 48 * um, Hb = 24 * um, margin = 6 * um, box_depth = 8 * um, grow = 4 * um, half_angle = 65;
  double dt_factor = 0.8, flip = 0.95, friction_tol = 0, friction_max_iter = 0; /* 0: the library's */
  const char *out = "results", *name = "scratch";
  for (int i = 1; i < argc; i++) {
    const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : "";
    int bad = 0;
    if (!strcmp(a, "--material")) {
      if (!strcmp(v, "j2")) j2 = 1;
      else if (!strcmp(v, "elastic")) j2 = 0;
      else bad = 1;
      i++;
    } else if (!strcmp(a, "--friction")) {
      char *end = NULL;
      mu = strtod(v, &end);
      bad = end == v || *end != '\0' || isnan(mu) || mu < 0;
      i++;
    } else if (!strcmp(a, "--depth")) depth = atof(v), i++;
    else if (!strcmp(a, "--travel")) travel = atof(v), i++;
    else if (!strcmp(a, "--speed")) speed = atof(v), i++;
    else if (!strcmp(a, "--lateral-speed")) vlat = atof(v), i++;
    else if (!strcmp(a, "--ramp")) t_r = atof(v), i++;
    else if (!strcmp(a, "--h0")) h0 = atof(v), i++;
    else if (!strcmp(a, "--levels")) levels = atoi(v), i++;
    else if (!strcmp(a, "--width")) W = atof(v), i++;
    else if (!strcmp(a, "--height")) Hb = atof(v), i++;
    else if (!strcmp(a, "--margin")) margin = atof(v), i++;
    else if (!strcmp(a, "--box-depth")) box_depth = atof(v), i++;
    else if (!strcmp(a, "--grow")) grow = atof(v), i++;
    else if (!strcmp(a, "--half-angle")) half_angle = atof(v), i++;
    else if (!strcmp(a, "--dt-factor")) dt_factor = atof(v), i++;
    else if (!strcmp(a, "--flip")) flip = atof(v), i++;
    else if (!strcmp(a, "--friction-tol")) friction_tol = atof(v), i++;
    else if (!strcmp(a, "--friction-max-iter")) friction_max_iter = atof(v), i++;
    else if (!strcmp(a, "--shape")) {
      shape = !strcmp(v, "ugimp") ? GIMLET_SHAPE_UGIMP : !strcmp(v, "cpgimp") ? GIMLET_SHAPE_CPGIMP : -1;
      bad = shape < 0;
      i++;
    } else if (!strcmp(a, "--transfer")) {
      transfer = !strcmp(v, "flip") ? GIMLET_TRANSFER_FLIP : !strcmp(v, "apic") ? GIMLET_TRANSFER_APIC : -1;
      bad = transfer < 0;
      i++;
    } else if (!strcmp(a, "--out")) out = v, i++;
    else if (!strcmp(a, "--name")) name = v, i++;
    else if (!strcmp(a, "--every")) every = atoi(v), i++;
    else if (!strcmp(a, "--quiet")) quiet = 1;
    else bad = 2;
    if (bad) {
      if (rank_ == 0) {
        if (bad == 2) fprintf(stderr, "unknown argument %s (see the comment at the top of scratch.c)\n", a);
        else fprintf(stderr, "%s %s: bad value (see the comment at the top of scratch.c)\n", a, v);
      }
      MPI_Finalize();
      return 2;
    }
  }
  if (!(depth > 0 && travel > 0 && speed > 0 && vlat > 0 && t_r > 0 && levels >= 1 && levels <= 8 &&
        dt_factor > 0 && dt_factor <= 1 && every > 0)) {
    if (rank_ == 0) fprintf(stderr, "scratch: depth, travel, speeds, ramp, dt-factor, every must be > 0, levels 1-8\n");
    MPI_Finalize();
    return 2;
  }
  /* The ramps must fit in the push and in the travel. */
  if (t_r > 0.5 * depth / speed) t_r = 0.5 * depth / speed;
  if (t_r > 0.5 * travel / vlat) t_r = 0.5 * travel / vlat;

  /* Layout, in coarse cells: the room above the surface takes the prow
   * (in plane strain the material the wedge displaces cannot flow
   * sideways: it goes up, ahead of and beside the wedge). */
  const double top = snap(4 * um > 2 * h0 ? 4 * um : 2 * h0, h0);
  W = snap(W, h0), Hb = snap(Hb, h0);
  const double x_s = snap(0.5 * (W - travel) > margin + (levels - 1) * grow + 4 * h0
                              ? 0.5 * (W - travel) : margin + (levels - 1) * grow + 4 * h0, h0);
  if (x_s + travel + margin + (levels - 1) * grow + 4 * h0 > W + 1e-12 || box_depth + (levels - 1) * grow >= Hb) {
    if (rank_ == 0)
      fprintf(stderr, "scratch: the block (%g x %g m) is too small for the track and the levels\n", W, Hb);
    MPI_Finalize();
    return 2;
  }
  GimletSim *sim = NULL;
  CHECK(gimlet_create(MPI_COMM_WORLD, 0, 0, W, Hb + top, h0, &sim));
  for (int l = 1; l < levels; l++) {
    double g = (levels - 1 - l) * grow; /* the finest box grown by this */
    double box[4] = {snap(x_s - margin - g, h0), snap(Hb - box_depth - g, h0), snap(x_s + travel + margin + g, h0),
                     Hb + top};
    CHECK(gimlet_add_level(sim, box, 1));
  }
  /* Patches: 4 x 2 per refined level (the track is long and shallow), 2 x 2
   * on the coarse one, counting a refined level's 4-cell ghost ring. */
  for (int l = 0; l < levels; l++) {
    double hl, b[4];
    int64_t count = 0;
    CHECK(gimlet_level_info(sim, l, &hl, NULL, NULL));
    CHECK(gimlet_level_boxes(sim, l, b, 1, &count));
    int wx = (int)lround((b[2] - b[0]) / hl) + (l ? 8 : 0), wy = (int)lround((b[3] - b[1]) / hl) + (l ? 4 : 0);
    int px = l ? 4 : 2, py = 2;
    CHECK(gimlet_set_patch_size(sim, l, (wx + px - 1) / px, (wy + py - 1) / py));
  }
  const double E = 70e9, nu = 0.33, rho = 2700, sigma_0 = 100e6;
  int al;
  if (j2) CHECK(gimlet_add_material_j2_power(sim, E, nu, rho, sigma_0, 0.1, sigma_0 / E, &al));
  else CHECK(gimlet_add_material_linear_elastic(sim, E, nu, rho, &al));
  CHECK(gimlet_set_face_bc(sim, GIMLET_FACE_LEFT, GIMLET_BC_ROLLER));
  CHECK(gimlet_set_face_bc(sim, GIMLET_FACE_RIGHT, GIMLET_BC_ROLLER));
  CHECK(gimlet_set_face_bc(sim, GIMLET_FACE_BOTTOM, GIMLET_BC_ROLLER));
  CHECK(gimlet_set_shape(sim, shape));
  CHECK(gimlet_set_transfer(sim, transfer));
  CHECK(gimlet_set_flip(sim, flip));
  CHECK(gimlet_fill_rectangle(sim, 0, 0, W, Hb, 2, al, rho, 0, 0, NULL));
  int wedge;
  CHECK(gimlet_add_indenter_wedge(sim, half_angle, 10 * um, x_s, Hb, &wedge));
  CHECK(gimlet_set_indenter_friction(sim, wedge, mu));
  if (friction_tol > 0) CHECK(gimlet_set_contact_option(sim, GIMLET_CONTACT_FRICTION_TOL, friction_tol));
  if (friction_max_iter > 0) CHECK(gimlet_set_contact_option(sim, GIMLET_CONTACT_FRICTION_MAX_ITER, friction_max_iter));

  /* Vertical: push to the depth, hold until the travel is done, withdraw. */
  const double t1 = t_r, t2 = depth / speed, t3 = t2 + t_r; /* depth(t3) = depth */
  const double ts = t3 + 0.5 * t_r;                       /* the sliding starts */
  const double tc = (travel - vlat * t_r) / vlat;           /* at full lateral speed */
  const double te = ts + t_r + tc + t_r;                    /* the sliding ends */
  const double tw = te + 0.5 * t_r;                         /* the withdrawal starts */
  double vt[7] = {0, t1, t2, t3, tw, tw + t_r, tw + t_r + 1}, vv[7] = {0, speed, speed, 0, 0, -speed, -speed};
  CHECK(gimlet_set_indenter_motion(sim, wedge, GIMLET_MOTION_VELOCITY, 7, vt, vv));
  /* Lateral: x(t) with the speed ramped linearly (x quadratic, sampled at
   * 16 points per ramp), held, ramped down. */
  const int nr = 16;
  for (int k = 0; k <= nr; k++) {
    double s = t_r * k / nr;
    lat_t[nlat] = ts + s, lat_x[nlat++] = 0.5 * vlat * s * s / t_r;
  }
  for (int k = 0; k <= nr; k++) {
    double s = t_r * k / nr;
    lat_t[nlat] = ts + t_r + tc + s, lat_x[nlat++] = 0.5 * vlat * t_r + vlat * tc + vlat * s - 0.5 * vlat * s * s / t_r;
  }
  CHECK(gimlet_set_indenter_lateral(sim, wedge, nlat, lat_t, lat_x));
  const double t_max = tw + t_r + 2 * depth / speed; /* well clear, unless the body follows the wedge */

  char path[1024];
  CHECK(gimlet_output_open(sim, out, name));
  FILE *csv = NULL;
  if (rank_ == 0) {
    snprintf(path, sizeof path, "%s/%s.csv", out, name);
    csv = fopen(path, "w");
    if (!csv) {
      fprintf(stderr, "cannot write %s\n", path);
      MPI_Abort(MPI_COMM_WORLD, 1);
    }
    fprintf(csv, "time_s,x_tip_m,depth_m,fx_n_per_m,fy_n_per_m,contacts,sticking,dissipation_j_per_m,"
                 "fx_contacts_n_per_m,fy_contacts_n_per_m\n");
  }
  int64_t n = 0, level_particles[8] = {0};
  CHECK(gimlet_particle_count(sim, NULL, &n));
  for (int l = 0; l < levels; l++) {
    int64_t mine = 0;
    CHECK(gimlet_level_particle_count(sim, l, &mine));
    MPI_Allreduce(&mine, &level_particles[l], 1, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);
  }
  double dt0;
  CHECK(gimlet_stable_dt(sim, &dt0));
  const double dt_fix = dt_factor * dt0;
  if (rank_ == 0) {
    printf("scratch: %s aluminium, %d rank(s), %d level(s) (finest cell %.4g nm), %lld particles; 65 deg wedge at "
           "x = %.1f um, mu = %g: pushed to %.0f nm at %g m/s, moved %.2f um at %g m/s, withdrawn; about %.0f steps\n",
           j2 ? "J2" : "elastic", size, levels, h0 / (1 << (levels - 1)) * 1e9, (long long)n, x_s / um, mu,
           depth * 1e9, speed, travel / um, vlat, t_max / dt_fix);
    fflush(stdout);
  }

  /* Gross sliding: from a quarter of the travel to the start of the
   * deceleration. */
  const double win_lo = 0.25 * travel, win_hi = travel - 0.5 * vlat * t_r;
  double s_fx = 0, s_fy = 0, s_ratio = 0, s_ratio2 = 0, d_lo = NAN, d_hi = NAN, x_lo = NAN, x_hi = NAN;
  int64_t s_n = 0, s_loaded = 0, s_stick = 0, s_cap = 4096;
  double *s_ratios = malloc(sizeof(double) * s_cap); /* -fx/fy of each step of the window, for the median */
  double wall = MPI_Wtime(), t = 0, part_steps = 0, fdiff_max = 0, f_peak = 0;
  int64_t step = 0;
  int separated = 0, frame = 0;
  const double frames[5] = {0, 0.25, 0.5, 0.75, 1.0}; /* outputs at these fractions of the travel */
  while (1) {
    double dts;
    CHECK(gimlet_stable_dt(sim, &dts));
    double dt = dt_fix < dts ? dt_fix : dts;
    int64_t steps;
    int rc = gimlet_step(sim, dt, &t, &steps);
    if (rc != GIMLET_OK) {
      char m[1024];
      gimlet_last_error(m, sizeof m, NULL);
      if (rank_ == 0)
        fprintf(stderr, "step %lld at t = %g s (x_tip %g m): %s\n", (long long)step + 1, t, lateral_at(t), m);
      MPI_Abort(MPI_COMM_WORLD, 1);
    }
    step++;
    for (int l = 0; l < levels; l++) part_steps += (double)level_particles[l] * (1 << l);
    double d, f[2], fc[2], diss_all = 0;
    int64_t nc, loaded, sticking;
    CHECK(gimlet_indenter_state(sim, wedge, &d, NULL, f, &nc));
    CHECK(gimlet_friction_stats(sim, wedge, &diss_all, NULL)); /* the whole body's, on every rank */
    contact_force(sim, wedge, fc, &loaded, &sticking);
    const double x = lateral_at(t);
    if (t > ts && t < te) {
      double fm = hypot(f[0], f[1]);
      if (fm > f_peak) f_peak = fm;
      if (fabs(fc[0] - f[0]) > fdiff_max) fdiff_max = fabs(fc[0] - f[0]);
    }
    if (x >= win_lo && x <= win_hi && t < te) {
      if (isnan(d_lo)) d_lo = diss_all, x_lo = x;
      d_hi = diss_all, x_hi = x;
      s_fx += f[0], s_fy += f[1], s_n++;
      if (s_n > s_cap) s_cap *= 2, s_ratios = realloc(s_ratios, sizeof(double) * s_cap);
      s_ratios[s_n - 1] = f[1] > 0 ? -f[0] / f[1] : NAN;
      if (f[1] > 0) s_ratio += -f[0] / f[1], s_ratio2 += (f[0] / f[1]) * (f[0] / f[1]);
      s_loaded += loaded, s_stick += sticking;
    }
    if (rank_ == 0)
      fprintf(csv, "%.9e,%.9e,%.9e,%.9e,%.9e,%lld,%lld,%.9e,%.9e,%.9e\n", t, x, d, f[0], f[1], (long long)nc,
              (long long)sticking, diss_all, fc[0], fc[1]);
    while (frame < 5 && t >= ts && x >= frames[frame] * travel - 1e-3 * travel) {
      CHECK(gimlet_write_output(sim));
      frame++;
    }
    if (!quiet && step % every == 0 && rank_ == 0) {
      double el = MPI_Wtime() - wall;
      printf("  step %6lld  t %8.2f ns  x_tip %6.3f um  depth %7.2f nm  Fx %9.3f  Fy %9.3f N/m  contacts %3lld "
             "(%3lld sticking)  %5.2f M particle-steps/s\n",
             (long long)step, t * 1e9, x / um, d * 1e9, f[0], f[1], (long long)nc, (long long)sticking,
             part_steps / el / 1e6);
      fflush(stdout);
    }
    if (t > tw && nc == 0 && f[1] == 0) separated++;
    if (separated >= 20 || t >= t_max) break;
  }
  wall = MPI_Wtime() - wall;
  if (rank_ == 0) fclose(csv);
  CHECK(gimlet_write_output(sim));
  int64_t fc_all[3] = {0, 0, 0};
  CHECK(gimlet_friction_stats(sim, wedge, NULL, fc_all));
  double *rows = NULL;
  const double dx = 0.5 * h0 / (1 << (levels - 1)); /* the finest particles' width */
  int64_t k = surface_envelope(sim, W, dx, Hb - 2 * depth - 2 * h0, &rows);
  if (rank_ == 0) {
    snprintf(path, sizeof path, "%s/%s_groove.csv", out, name);
    FILE *g = fopen(path, "w");
    if (!g) {
      fprintf(stderr, "cannot write %s\n", path);
      MPI_Abort(MPI_COMM_WORLD, 1);
    }
    fprintf(g, "x_m,height_m,x0_m,y0_m\n");
    /* The groove: the surface over the middle half of the track (lowest
     * and mean); the prow: the highest point (ahead of the track's end). */
    double groove = INFINITY, prow = -INFINITY, x_prow = 0, mean_track = 0;
    int n_track = 0;
    for (int64_t i = 0; i < k; i++) {
      double x = rows[4 * i], hgt = rows[4 * i + 1] - Hb;
      fprintf(g, "%.9e,%.9e,%.9e,%.9e\n", x, hgt, rows[4 * i + 2], rows[4 * i + 3]);
      if (x > x_s + 0.25 * travel && x < x_s + 0.75 * travel) {
        if (hgt < groove) groove = hgt;
        mean_track += hgt, n_track++;
      }
      if (hgt > prow) prow = hgt, x_prow = x;
    }
    fclose(g);
    mean_track = n_track ? mean_track / n_track : NAN;
    if (!n_track) groove = NAN; /* a travel shorter than a bin */
    double fx = s_n ? s_fx / s_n : NAN, fy = s_n ? s_fy / s_n : NAN, r = s_n ? s_ratio / s_n : NAN;
    double r_sd = s_n ? sqrt(fmax(0, s_ratio2 / s_n - r * r)) : NAN;
    /* The median: the typical step (the mean is pulled down by the
     * single-step load spikes as particles pass the apex). */
    int64_t nr_ok = 0;
    for (int64_t i = 0; i < s_n; i++)
      if (!isnan(s_ratios[i])) s_ratios[nr_ok++] = s_ratios[i];
    qsort(s_ratios, nr_ok, sizeof(double), cmp_double);
    double r_med = !nr_ok        ? NAN
                   : nr_ok % 2 ? s_ratios[nr_ok / 2]
                               : 0.5 * (s_ratios[nr_ok / 2 - 1] + s_ratios[nr_ok / 2]);
    const double tb = tan((90 - half_angle) * M_PI / 180); /* the flank's slope */
    printf("done: %lld steps in %.1f s (%.3e particle-steps/s on %d rank(s))\n", (long long)step, wall,
           part_steps / wall, size);
    printf("  gross sliding (x_tip %.2f to %.2f um, %lld steps): mean Fx %.2f N/m, Fy %.2f N/m; friction ratio -Fx/Fy: "
           "median %.4f, of the means %.4f, mean %.4f (sd %.4f), at mu = %g; a front flank (%g deg from the surface) "
           "in Coulomb slip alone gives (tan + mu)/(1 - mu tan) = %.4f\n",
           x_lo / um, x_hi / um, (long long)s_n, fx, fy, r_med, -fx / fy, r, r_sd, mu, 90 - half_angle,
           isinf(mu) ? NAN : (tb + mu) / (1 - mu * tb));
    printf("  contact particles carrying pressure in gross sliding: %.2f on average, %.1f %% of them sticking\n",
           s_n ? (double)s_loaded / s_n : 0.0, s_loaded ? 100.0 * s_stick / s_loaded : 0.0);
    printf("  friction dissipation over that travel %.6g J/m, the tangential work -Fx dx %.6g J/m: %.1f %% "
           "(the rest goes to plastic and elastic work, ploughing)\n",
           d_hi - d_lo, -fx * (x_hi - x_lo), 100 * (d_hi - d_lo) / (-fx * (x_hi - x_lo)));
    printf("  frictional solves: %lld, %.1f friction-bound iterations per solve, at most %lld\n", (long long)fc_all[0],
           fc_all[0] ? (double)fc_all[1] / fc_all[0] : 0.0, (long long)fc_all[2]);
    printf("  force from the contact list against gimlet_indenter_state while sliding: largest |dFx| %.3g N/m "
           "(%.2f %% of the largest force)\n",
           fdiff_max, 100 * fdiff_max / f_peak);
    printf("  groove (the particles' upper envelope after lift-off, bins of %.1f nm): over the track's middle half "
           "%.1f nm below the original surface on average, %.1f nm at the lowest; prow %+.1f nm at x = %.2f um "
           "(the track ends at %.2f um)\n",
           dx * 1e9, -mean_track * 1e9, -groove * 1e9, prow * 1e9, x_prow / um, (x_s + travel) / um);
    printf("  wrote %s/%s.csv, %s/%s_groove.csv, %s/%s.json, %s/%s.xdmf\n", out, name, out, name, out, name, out,
           name);
    /* JSON has no infinity: full adhesion is the string "inf". */
    char mus[32];
    if (isinf(mu)) snprintf(mus, sizeof mus, "\"inf\"");
    else snprintf(mus, sizeof mus, "%.6g", mu);
    /* The run in one line (stdout and DIR/NAME.json, which
     * scripts/plot_scratch.py reads). */
    char js[2048], gm[32], gl[32];
    /* JSON has no NaN either: a missing groove is null. */
    if (isnan(mean_track)) snprintf(gm, sizeof gm, "null"), snprintf(gl, sizeof gl, "null");
    else snprintf(gm, sizeof gm, "%.6e", -mean_track), snprintf(gl, sizeof gl, "%.6e", -groove);
    snprintf(js, sizeof js,
             "{\"case\":\"scratch\",\"ranks\":%d,\"material\":\"%s\",\"mu\":%s,\"depth_m\":%.6e,"
             "\"x_start_m\":%.6e,\"travel_m\":%.6e,\"lateral_speed_m_per_s\":%.6g,\"window_m\":[%.6e,%.6e],"
             "\"wall_s\":%.2f,\"steps\":%lld,\"fx_n_per_m\":%.6e,\"fy_n_per_m\":%.6e,\"ratio\":%.6e,"
             "\"ratio_median\":%.6e,\"ratio_mean\":%.6e,\"ratio_sd\":%.6e,\"stick_share\":%.4f,"
             "\"groove_mean_m\":%s,\"groove_min_m\":%s,\"prow_m\":%.6e,"
             "\"prow_x_m\":%.6e}",
             size, j2 ? "j2" : "elastic", mus, depth, x_s, travel, vlat, x_lo, x_hi, wall, (long long)step, fx, fy,
             -fx / fy, r_med, r, r_sd, s_loaded ? (double)s_stick / s_loaded : 0.0, gm, gl, prow, x_prow);
    printf("%s\n", js);
    snprintf(path, sizeof path, "%s/%s.json", out, name);
    FILE *jf = fopen(path, "w");
    if (jf) fprintf(jf, "%s\n", js), fclose(jf);
    fflush(stdout);
  }
  free(rows);
  free(s_ratios);
  CHECK(gimlet_destroy(&sim));
  MPI_Finalize();
  return 0;
}
