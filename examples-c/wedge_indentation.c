/* The paper's wedge nanoindentation (Ma et al. 2005, section 4, third
 * example), on as many ranks as it is started with: the main job.
 *
 * Aluminium (E = 70 GPa, nu = 0.33, rho = 2700 kg/m^3, plane strain;
 * linear elastic as in the paper, or with --material j2 elastic-plastic:
 * von Mises with power hardening sigma_y = sigma_0 (1 + eps_p/eps_0)^n,
 * sigma_0 = 100 MPa, n = 0.1, eps_0 = sigma_0/E), a 60 um x 40 um block modelled by its half, x in [0, 30 um]
 * with the symmetry plane at x = 0 (roller) and the bottom fixed in y
 * (roller), 2x2 particles per cell. Nested levels refine the region under
 * the indenter (cells of 500, 250 and 125 nm by default, each level a
 * quarter of the next coarser in area, reaching the top), 4 patches per
 * level. A rigid wedge of tip half-angle 65 degrees, its apex on the top
 * surface on the symmetry axis, is pushed to 450 nm and withdrawn: the
 * speed ramps from 0 to v over t_r, is held, ramps down to 0 at the final
 * depth, is held at 0 for t_r, then the same backwards until the wedge is
 * clear of the surface.
 *
 *   wedge_indentation [--material elastic|j2] [--half-angle D] [--levels L] [--h0 M]
 *                     [--uniform M] [--speed V] [--depth M] [--ramp S]
 *                     [--unload 0|1] [--unload-speed V] [--r0 M] [--box M] [--across T [--box-factor F]]
 *                     [--patches PXxPY] [--out DIR] [--friction MU]
 *                     [--every N] [--quiet] [--expect-modulus TOL]
 *
 *   --material K  elastic (default, the paper's) or j2 (aluminium above)
 *   --half-angle D  the wedge's tip half-angle in degrees (default 65)
 *   --levels L    number of levels (default 3: 500/250/125 nm)
 *   --h0 M        coarse cell size in metres (default 5e-7)
 *   --uniform M   one level of cell size M instead (e.g. 1.25e-7)
 *   --speed V     indenter speed in m/s (default 10)
 *   --depth M     final depth in metres (default 4.5e-7)
 *   --ramp S      speed ramp duration in seconds (default 3.2e-8: about
 *                 one period of the block's fundamental mode, which the
 *                 load rings at after a sudden start; a 10 ns ramp leaves
 *                 a +-5 % ringing on the load-depth curve, and the load at
 *                 450 nm then changes by 4.6 % when the speed is halved;
 *                 with 32 ns, by 0.4 %)
 *   --unload 0    stop at the final depth (no unloading); by default the
 *                 wedge is withdrawn until it has left the surface
 *   --unload-speed V  withdrawal speed in m/s (default: the loading
 *                 speed; an elastic-plastic impression recovers only a few
 *                 per cent of the depth, and a slower withdrawal samples
 *                 that short unloading branch quasi-statically)
 *   --r0 M        distance from the axis of the surface point the depth is
 *                 measured from in the unloading analysis (default 4e-6)
 *   --box M       width and depth of level 1's box, [0, M] x [top - M, top]
 *                 (default 1e-5); each finer level's box halves it
 *   --across T    let the library propose the levels and boxes
 *                 (gimlet_propose_levels) for at least T finest particles
 *                 across the expected contact half-width at the final
 *                 depth; replaces --levels and --box (--h0 stays the
 *                 coarse cell). The work-precision table (README) says
 *                 what T gives: 3.7 particles, 0.2 % on the load
 *   --box-factor F  with --across: the finest box reaches F expected
 *                 half-widths from the axis (default 20)
 *   --expect-modulus TOL  exit with status 1 unless the reduced modulus
 *                 from the unloading analysis with Oliver-Pharr's contact
 *                 depth (gimlet_indentation_analysis_wedge) is within TOL
 *                 (relative) of E/(1 - nu^2) (a check for the elastic
 *                 material; the analysis with the particles' half-width is
 *                 printed too)
 *   --flip F      FLIP fraction (default 0.95)
 *   --shape S     particle weights: ugimp (default, the paper's), cpgimp
 *                 or mpm
 *   --transfer T  velocity transfer: flip (default, blended by --flip)
 *                 or apic
 *   --dt-factor F the fixed step as a fraction of the stable step at the
 *                 start (default 0.8; the compression under the tip
 *                 shortens the stable step of the finest cells, and with
 *                 6 levels 0.8 of the initial step is too long by 0.6 %)
 *   --contact-gap G  where a contact particle's gap is measured
 *                 (GIMLET_CONTACT_GAP: 1 the mean over its contact faces,
 *                 the default; 0 its domain's point nearest the indenter)
 *   --petsc       every contact solve with PETSc (default: small systems
 *                 by a direct solve on every rank)
 *   --friction MU Coulomb friction coefficient of the wedge
 *                 (gimlet_set_indenter_friction): MU >= 0, or inf for
 *                 full adhesion (stick wherever a particle carries a
 *                 pressure). Without the option the wedge is frictionless
 *                 and nothing of the run or its output changes; with it
 *                 (--friction 0 included, which the library keeps bitwise
 *                 frictionless) the run also prints the friction
 *                 dissipation and the frictional solves, the JSON line
 *                 gets friction_mu and friction_dissipation_j_per_m, and
 *                 DIR/nanoindentation_tip.csv gets the columns
 *                 traction_pa (tangential traction on the body along
 *                 t = (-n_y, n_x)), slip_m and stick
 *   --friction-tol T, --friction-max-iter N  the frictional solve's
 *                 friction-bound iteration: GIMLET_CONTACT_FRICTION_TOL
 *                 and GIMLET_CONTACT_FRICTION_MAX_ITER (default: the
 *                 library's, 1e-8 and 200)
 *
 * Writes DIR/nanoindentation.csv (time, depth_m: the tip's distance below
 * the undeformed top surface, load_n_per_m: the load on the full (mirrored)
 * body per metre of thickness, ..., sink_m: the downward displacement of
 * the top surface at x = r0, sink_2um ... sink_8um: the same at 2, 3, 4, 6
 * and 8 um, to check that the modulus does not depend on r0),
 * DIR/nanoindentation_tip.csv (the contact
 * pressures at the deepest point), DIR/nanoindentation.xdmf with
 * DIR/nanoindentation_*.h5 (particle fields) and prints progress lines and
 * a summary: the load at the final depth, the stress sigma_yy of the
 * particle under the tip, the wall time and where the contact phase's time
 * went. With unloading it also writes DIR/nanoindentation_surface.csv, the
 * residual impression (x0_m, x_m, y_m, uy_m: reference and current
 * position and vertical displacement of the top particle row once the
 * wedge has left; scripts/plot_nanoindentation.py draws it), and prints
 * the analysis of the unloading branch (gimlet_indentation_analysis, see
 * docs/method.md): hardness, unloading stiffness, reduced modulus (against
 * E/(1 - nu^2)), residual depth. The load-depth series it analyses has a
 * point every 5 steps; the steps are all equal (a short last step would
 * report the contact impulse over a tiny time as a large force). */
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

/* sigma_yy of the owned particle nearest to (x, y), over all ranks. */
static double stress_near(GimletSim *sim, double x, double y, double *where) {
  int64_t n = 0;
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_POSITION, NULL, 0, &n));
  double *p = malloc(sizeof(double) * (2 * n + 2)), *s = malloc(sizeof(double) * (4 * n + 4));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_POSITION, p, n, &n));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_STRESS, s, n, &n));
  struct { double d; int r; } best = {INFINITY, rank_}, all;
  double mine[3] = {0, 0, 0};
  for (int64_t i = 0; i < n; i++) {
    double d = hypot(p[2 * i] - x, p[2 * i + 1] - y);
    if (d < best.d) {
      best.d = d;
      mine[0] = s[4 * i + 1];
      mine[1] = p[2 * i];
      mine[2] = p[2 * i + 1];
    }
  }
  MPI_Allreduce(&best, &all, 1, MPI_DOUBLE_INT, MPI_MINLOC, MPI_COMM_WORLD);
  MPI_Bcast(mine, 3, MPI_DOUBLE, all.r, MPI_COMM_WORLD);
  free(p);
  free(s);
  if (where) { where[0] = mine[1]; where[1] = mine[2]; }
  return mine[0];
}

/* The global id of the owned top-row particle nearest to (x, y_top) on
 * the finest level there (identical on every rank). */
static uint64_t top_particle_near(GimletSim *sim, double x, double y_top) {
  int64_t n = 0;
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_POSITION, NULL, 0, &n));
  double *p = malloc(sizeof(double) * (2 * n + 2)), *lp = malloc(sizeof(double) * (2 * n + 2)),
         *lev = malloc(sizeof(double) * (n + 1));
  uint64_t *id = malloc(sizeof(uint64_t) * (n + 1));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_POSITION, p, n, &n));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_HALF_LENGTH, lp, n, &n));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_LEVEL, lev, n, &n));
  CHECK(gimlet_get_ids(sim, id, n, &n));
  /* Owned particles tile the body: the nearest in x is on the finest level
   * there; a finer level wins a tie. */
  struct { double d; int r; } best = {INFINITY, rank_}, all;
  uint64_t mine = 0;
  for (int64_t i = 0; i < n; i++) {
    if (p[2 * i + 1] < y_top - 2 * lp[2 * i + 1]) continue; /* not the top row */
    double d = fabs(p[2 * i] - x) - 1e-6 * lp[2 * i] * lev[i];
    if (d < best.d) best.d = d, mine = id[i];
  }
  MPI_Allreduce(&best, &all, 1, MPI_DOUBLE_INT, MPI_MINLOC, MPI_COMM_WORLD);
  MPI_Bcast(&mine, 1, MPI_UINT64_T, all.r, MPI_COMM_WORLD);
  free(p); free(lp); free(lev); free(id);
  return mine;
}

/* The y of the particles with the given ids (NAN where none has it). */
static void particles_y(GimletSim *sim, int k, const uint64_t *want, double *y) {
  int64_t n = 0;
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_POSITION, NULL, 0, &n));
  double *p = malloc(sizeof(double) * (2 * n + 2));
  uint64_t *id = malloc(sizeof(uint64_t) * (n + 1));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_POSITION, p, n, &n));
  CHECK(gimlet_get_ids(sim, id, n, &n));
  double mine[16];
  for (int j = 0; j < k; j++) mine[j] = -INFINITY;
  for (int64_t i = 0; i < n; i++)
    for (int j = 0; j < k; j++)
      if (id[i] == want[j]) mine[j] = p[2 * i + 1];
  MPI_Allreduce(mine, y, k, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  for (int j = 0; j < k; j++)
    if (y[j] == -INFINITY) y[j] = NAN;
  free(p); free(id);
}

/* The top particle row (owned particles whose reference centre lies within
 * one particle height of the top surface y_top) on rank 0, sorted by x, as
 * rows (x0, x, y, uy); returns the count on rank 0 (0 elsewhere). */
static int64_t surface_profile(GimletSim *sim, double y_top, double **rows) {
  int64_t n = 0;
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_POSITION, NULL, 0, &n));
  double *p = malloc(sizeof(double) * (2 * n + 2)), *r = malloc(sizeof(double) * (2 * n + 2)),
         *lp = malloc(sizeof(double) * (2 * n + 2)), *mine = malloc(sizeof(double) * (4 * n + 4));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_POSITION, p, n, &n));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_REFERENCE, r, n, &n));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_HALF_LENGTH, lp, n, &n));
  int m = 0;
  for (int64_t i = 0; i < n; i++) {
    if (r[2 * i + 1] < y_top - 2 * lp[2 * i + 1]) continue;
    mine[4 * m] = r[2 * i];
    mine[4 * m + 1] = p[2 * i];
    mine[4 * m + 2] = p[2 * i + 1];
    mine[4 * m + 3] = p[2 * i + 1] - r[2 * i + 1];
    m++;
  }
  int size;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  int *counts = malloc(sizeof(int) * size), *displs = malloc(sizeof(int) * size), cnt = 4 * m;
  MPI_Gather(&cnt, 1, MPI_INT, counts, 1, MPI_INT, 0, MPI_COMM_WORLD);
  int total = 0;
  if (rank_ == 0)
    for (int q = 0; q < size; q++) displs[q] = total, total += counts[q];
  double *all = malloc(sizeof(double) * (total + 4));
  MPI_Gatherv(mine, cnt, MPI_DOUBLE, all, counts, displs, MPI_DOUBLE, 0, MPI_COMM_WORLD);
  int64_t k = rank_ == 0 ? total / 4 : 0;
  /* Insertion sort by x0 (a few hundred rows). */
  for (int64_t i = 1; i < k; i++)
    for (int64_t j = i; j > 0 && all[4 * (j - 1)] > all[4 * j]; j--)
      for (int c = 0; c < 4; c++) {
        double t = all[4 * j + c];
        all[4 * j + c] = all[4 * (j - 1) + c];
        all[4 * (j - 1) + c] = t;
      }
  free(p); free(r); free(lp); free(mine); free(counts); free(displs);
  *rows = all;
  return k;
}

/* The contact half-width now: the outer end of the outermost face in
 * contact, x + (length/2) |n_y| (the faces of the particles in contact
 * tile the indenter's surface; a face of length `length` on a flank with
 * unit normal n spans length |n_y| in x; x is the particle's centre). On
 * the elastic wedge it falls within 0.1 % of the closed form
 * a = P/(E* tan(beta)). The caller takes the largest over the hold at the
 * deepest point: the particle at the edge carries almost no pressure and
 * leaves and rejoins the contact from step to step. */
static double contact_half_width(GimletSim *sim, int ind) {
  int64_t m = 0;
  CHECK(gimlet_get_contacts(sim, ind, 0, &m, NULL, NULL, NULL, NULL, NULL, NULL, NULL));
  double *xy = malloc(sizeof(double) * (2 * m + 2)), *nn = malloc(sizeof(double) * (2 * m + 2)),
         *len = malloc(sizeof(double) * (m + 1)), *pr = malloc(sizeof(double) * (m + 1));
  CHECK(gimlet_get_contacts(sim, ind, m, &m, xy, nn, pr, len, NULL, NULL, NULL));
  double a = 0;
  for (int64_t k = 0; k < m; k++) {
    if (!(pr[k] > 0)) continue;
    double e = fabs(xy[2 * k]) + 0.5 * len[k] * fabs(nn[2 * k + 1]);
    if (e > a) a = e;
  }
  free(xy); free(nn); free(len); free(pr);
  return a;
}

int main(int argc, char **argv) {
  MPI_Init(&argc, &argv);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  int size;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  const double um = 1e-6;
  int levels = 3, px = 2, py = 2, every = 200, quiet = 0, unload = 1;
  double h0 = 0.5 * um, uniform = 0, speed = 10.0, depth_max = 0.45 * um, t_r = 32e-9, flip = 0.95;
  int petsc = 0, j2 = 0, shape = GIMLET_SHAPE_UGIMP, transfer = GIMLET_TRANSFER_FLIP;
  int contact_gap = -1;
  double dt_factor = 0.8;
  double r0 = 4 * um, expect_modulus = -1, half_angle = 65.0, unload_speed = 0, box_w = 10 * um;
  double across = 0, box_factor = 20;
  double friction = 0; /* --friction MU; applied only when given */
  int friction_set = 0;
  double friction_tol = 0, friction_max_iter = 0; /* 0: the library's default */
  const char *out = "results";
  for (int i = 1; i < argc; i++) {
    const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : "";
    if (!strcmp(a, "--levels")) levels = atoi(v), i++;
    else if (!strcmp(a, "--material")) {
      if (!strcmp(v, "j2")) j2 = 1;
      else if (!strcmp(v, "elastic")) j2 = 0;
      else {
        if (rank_ == 0) fprintf(stderr, "--material %s: must be elastic or j2\n", v);
        MPI_Finalize();
        return 2;
      }
      i++;
    }
    else if (!strcmp(a, "--r0")) r0 = atof(v), i++;
    else if (!strcmp(a, "--box")) box_w = atof(v), i++;
    else if (!strcmp(a, "--across")) across = atof(v), i++;
    else if (!strcmp(a, "--box-factor")) box_factor = atof(v), i++;
    else if (!strcmp(a, "--contact-gap")) contact_gap = atoi(v), i++;
    else if (!strcmp(a, "--dt-factor")) dt_factor = atof(v), i++;
    else if (!strcmp(a, "--half-angle")) half_angle = atof(v), i++;
    else if (!strcmp(a, "--unload-speed")) unload_speed = atof(v), i++;
    else if (!strcmp(a, "--expect-modulus")) expect_modulus = atof(v), i++;
    else if (!strcmp(a, "--h0")) h0 = atof(v), i++;
    else if (!strcmp(a, "--uniform")) uniform = atof(v), i++;
    else if (!strcmp(a, "--speed")) speed = atof(v), i++;
    else if (!strcmp(a, "--depth")) depth_max = atof(v), i++;
    else if (!strcmp(a, "--ramp")) t_r = atof(v), i++;
    else if (!strcmp(a, "--unload")) unload = atoi(v), i++;
    else if (!strcmp(a, "--flip")) flip = atof(v), i++;
    else if (!strcmp(a, "--shape")) {
      shape = !strcmp(v, "ugimp") ? GIMLET_SHAPE_UGIMP : !strcmp(v, "cpgimp") ? GIMLET_SHAPE_CPGIMP
              : !strcmp(v, "mpm") ? GIMLET_SHAPE_MPM : -1;
      if (shape < 0) {
        if (rank_ == 0) fprintf(stderr, "--shape %s: must be ugimp, cpgimp or mpm\n", v);
        MPI_Finalize();
        return 2;
      }
      i++;
    } else if (!strcmp(a, "--transfer")) {
      transfer = !strcmp(v, "flip") ? GIMLET_TRANSFER_FLIP : !strcmp(v, "apic") ? GIMLET_TRANSFER_APIC : -1;
      if (transfer < 0) {
        if (rank_ == 0) fprintf(stderr, "--transfer %s: must be flip or apic\n", v);
        MPI_Finalize();
        return 2;
      }
      i++;
    } else if (!strcmp(a, "--petsc")) petsc = 1;
    else if (!strcmp(a, "--patches")) sscanf(v, "%dx%d", &px, &py), i++;
    else if (!strcmp(a, "--out")) out = v, i++;
    else if (!strcmp(a, "--every")) every = atoi(v), i++;
    else if (!strcmp(a, "--quiet")) quiet = 1;
    else if (!strcmp(a, "--friction")) {
      char *end = NULL;
      friction = strtod(v, &end); /* strtod reads "inf" too */
      if (end == v || *end != '\0' || isnan(friction) || friction < 0) {
        if (rank_ == 0) fprintf(stderr, "--friction %s: must be a number >= 0 or inf\n", v);
        MPI_Finalize();
        return 2;
      }
      friction_set = 1;
      i++;
    } else if (!strcmp(a, "--friction-tol")) friction_tol = atof(v), i++;
    else if (!strcmp(a, "--friction-max-iter")) friction_max_iter = atof(v), i++;
    else {
      if (rank_ == 0) fprintf(stderr, "unknown argument %s (see the comment at the top of wedge_indentation.c)\n", a);
      MPI_Finalize();
      return 2;
    }
  }
  if (!(dt_factor > 0 && dt_factor <= 1)) {
    if (rank_ == 0) fprintf(stderr, "--dt-factor %g: must lie in (0, 1]\n", dt_factor);
    MPI_Finalize();
    return 2;
  }
  if (uniform > 0) {
    h0 = uniform;
    levels = 1;
  }
  /* Room above the surface and beyond the free right face: the face
   * bulges out by tens of nanometres as the load grows, and a particle
   * whose centre leaves the domain is lost (with 125 nm cells everywhere
   * the right column sits 31 nm from x = W). */
  const double W = 30 * um, Hb = 40 * um, top = 1 * um, right = 1 * um;
  /* With --across T the library proposes the levels and boxes: the finest
   * cell gives at least T particles across the expected contact half-width
   * at the final depth (elastic: the half-space closed form; J2: the
   * wedge's intersection with the surface), the finest box reaches F
   * half-widths from the axis (--box-factor F), each coarser box twice as
   * far. Otherwise level l covers [0, B / 2^(l-1)] x [Hb - B / 2^(l-1),
   * Hb + top], B = --box. */
  double proposed[4 * 7];
  if (across > 0) {
    const double domain[5] = {0, 0, W + right, Hb + top, h0};
    double res[GIMLET_PROPOSAL_RESULTS];
    CHECK(gimlet_propose_levels(domain, 0, Hb, GIMLET_INDENTER_WEDGE, half_angle, depth_max,
                                j2 ? GIMLET_RESPONSE_PLASTIC : GIMLET_RESPONSE_ELASTIC, 2, across, box_factor, 8,
                                &levels, proposed, res));
    if (rank_ == 0)
      printf("proposed layout for %g particles across a: expected a = %.1f nm, %d level(s), finest cell %g nm "
             "(%.2f particles across a), finest box reaching %.2f um\n",
             across, res[GIMLET_PROPOSAL_CONTACT_HALF_WIDTH] * 1e9, levels,
             res[GIMLET_PROPOSAL_FINEST_CELL] * 1e9, res[GIMLET_PROPOSAL_PARTICLES_ACROSS],
             levels > 1 ? proposed[4 * (levels - 2) + 2] / um : 0.0);
  }
  GimletSim *sim = NULL;
  CHECK(gimlet_create(MPI_COMM_WORLD, 0, 0, W + right, Hb + top, h0, &sim));
  CHECK(gimlet_set_thickness(sim, 1 * um));
  for (int l = 1; l < levels; l++) {
    double w = box_w / (1 << (l - 1));
    double box[4] = {0, Hb - w, w, Hb + top};
    CHECK(gimlet_add_level(sim, across > 0 ? proposed + 4 * (l - 1) : box, 1));
  }
  for (int l = 0; l < levels; l++) {
    int nboxes, npatches;
    int64_t count = 0;
    double hl, b[4];
    CHECK(gimlet_level_info(sim, l, &hl, &nboxes, &npatches));
    CHECK(gimlet_level_boxes(sim, l, b, 1, &count));
    /* A refined level computes on its box plus a 4-cell ghost ring on the
     * sides away from the domain's edges (here: right and bottom). */
    int wx = (int)lround((b[2] - b[0]) / hl) + (l ? 4 : 0), wy = (int)lround((b[3] - b[1]) / hl) + (l ? 4 : 0);
    CHECK(gimlet_set_patch_size(sim, l, (wx + px - 1) / px, (wy + py - 1) / py));
  }
  int al;
  const double E = 70e9, nu = 0.33, sigma_0 = 100e6;
  if (j2)
    CHECK(gimlet_add_material_j2_power(sim, E, nu, 2700.0, sigma_0, 0.1, sigma_0 / E, &al));
  else
    CHECK(gimlet_add_material_linear_elastic(sim, E, nu, 2700.0, &al));
  CHECK(gimlet_set_face_bc(sim, GIMLET_FACE_LEFT, GIMLET_BC_ROLLER));
  CHECK(gimlet_set_face_bc(sim, GIMLET_FACE_BOTTOM, GIMLET_BC_ROLLER));
  /* MUSL with 5 % PIC: with pure FLIP the particles in contact keep a
   * particle-scale mode that makes the load chatter from step to step. */
  CHECK(gimlet_set_flip(sim, flip));
  /* The paper's weights and transfer (uGIMP, FLIP) unless asked otherwise:
   * the scene's figures in docs/validation.md were measured with them, and they are
   * not the library's default (cpGIMP, APIC). */
  CHECK(gimlet_set_shape(sim, shape));
  CHECK(gimlet_set_transfer(sim, transfer));
  CHECK(gimlet_fill_rectangle(sim, 0, 0, W, Hb, 2, al, 2700.0, 0, 0, NULL));
  int wedge;
  CHECK(gimlet_add_indenter_wedge(sim, half_angle, 10 * um, 0.0, Hb, &wedge));
  /* Coulomb friction at the wedge's flanks (the symmetry plane at x = 0
   * needs nothing more: the apex's tangential traction is along x, which
   * the mirrored half balances). */
  if (friction_set) CHECK(gimlet_set_indenter_friction(sim, wedge, friction));
  if (friction_tol > 0) CHECK(gimlet_set_contact_option(sim, GIMLET_CONTACT_FRICTION_TOL, friction_tol));
  if (friction_max_iter > 0) CHECK(gimlet_set_contact_option(sim, GIMLET_CONTACT_FRICTION_MAX_ITER, friction_max_iter));
  if (petsc) CHECK(gimlet_set_contact_option(sim, GIMLET_CONTACT_DENSE_MAX, 0));
  if (contact_gap >= 0) CHECK(gimlet_set_contact_option(sim, GIMLET_CONTACT_GAP, contact_gap));
  /* Speed history: ramp up over t_r, hold, ramp down to reach depth_max at
   * rest; hold t_r; the same backwards to depth 0, then on at -speed until
   * the wedge is well clear. */
  if (t_r >= depth_max / speed) {
    /* A shallow or fast push: the ramps must fit inside it. */
    t_r = 0.5 * depth_max / speed;
    if (rank_ == 0) printf("the speed ramp is shortened to %g s (half of depth / speed)\n", t_r);
  }
  double t1 = t_r, t2 = depth_max / speed, t3 = t2 + t_r; /* depth(t3) = depth_max */
  double vu = unload_speed > 0 ? unload_speed : speed, tu = depth_max / vu;
  double times[8] = {0, t1, t2, t3, t3 + t_r, t3 + 2 * t_r, t3 + t_r + tu, t3 + 2 * t_r + tu};
  double speeds[8] = {0, speed, speed, 0, 0, -vu, -vu, -vu};
  CHECK(gimlet_set_indenter_motion(sim, wedge, GIMLET_MOTION_VELOCITY, unload ? 8 : 4, times, speeds));
  double t_end = unload ? t3 + 2 * t_r + tu + 0.1 * tu : t3;

  char path[1024];
  CHECK(gimlet_output_open(sim, out, "nanoindentation"));
  FILE *csv = NULL;
  if (rank_ == 0) {
    snprintf(path, sizeof path, "%s/nanoindentation.csv", out);
    csv = fopen(path, "w");
    if (!csv) { fprintf(stderr, "cannot write %s\n", path); MPI_Abort(MPI_COMM_WORLD, 1); }
    fprintf(csv, "time_s,depth_m,load_n_per_m,load_x_n_per_m,contacts,kinetic_j_per_m,strain_j_per_m,sink_m,"
                 "sink_2um,sink_3um,sink_4um,sink_6um,sink_8um\n");
  }
  /* The surface point at r0 the unloading analysis measures depths from:
   * a top-row particle there, followed by id; its downward displacement is
   * the sink. */
  /* Also the sinks at 2, 3, 4, 6 and 8 um (CSV columns sink_2um, ...): the
   * analysis should not depend on r0 (see docs/method.md). */
  enum { NREF = 6 };
  const double ref_x[NREF] = {r0, 2 * um, 3 * um, 4 * um, 6 * um, 8 * um};
  uint64_t ref_id[NREF];
  double ref_y0[NREF];
  for (int j = 0; j < NREF; j++) ref_id[j] = top_particle_near(sim, ref_x[j], Hb);
  particles_y(sim, NREF, ref_id, ref_y0);
  for (int j = 0; j < NREF; j++)
    if (isnan(ref_y0[j])) {
      if (rank_ == 0) fprintf(stderr, "no top-row particle near x = %g m\n", ref_x[j]);
      MPI_Abort(MPI_COMM_WORLD, 1);
    }
  /* The series for the analysis: a point every 5 steps. */
  int64_t ns = 0, cap = 1024;
  double *s_depth = malloc(sizeof(double) * cap), *s_load = malloc(sizeof(double) * cap),
         *s_sink = malloc(sizeof(double) * cap);
  double a_unload = 0, unload_start = t3 + t_r;
  int separated_steps = 0;
  int64_t n = 0;
  CHECK(gimlet_particle_count(sim, NULL, &n));
  if (rank_ == 0)
    printf("wedge nanoindentation: %d rank(s), %d level(s) (finest cell %.4g nm), %lld particles, "
           "speed %g m/s to %g nm%s\n",
           size, levels, h0 / (1 << (levels - 1)) * 1e9, (long long)n, speed, depth_max * 1e9,
           unload ? ", then unloading" : "");
  if (rank_ == 0 && friction_set) printf("  Coulomb friction at the wedge: mu = %g\n", friction);
  double wall = MPI_Wtime(), t = 0, load_at_max = NAN, tip_stress = NAN, tip_at[2] = {0, 0};
  double max_depth = 0, max_load = 0, part_steps = 0, a_at_max = NAN;
  int64_t step = 0, level_particles[8] = {0};
  for (int l = 0; l < levels; l++) {
    int64_t mine = 0;
    CHECK(gimlet_level_particle_count(sim, l, &mine));
    MPI_Allreduce(&mine, &level_particles[l], 1, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);
  }
  int wrote_tip = 0;
  /* Equal steps, dt_factor (0.8) of the stable step at the start (the material keeps
   * its elastic wave speed; the bound tightens a little with the particle
   * speeds and the compression under the tip), landing on t_end. */
  double dt0;
  CHECK(gimlet_stable_dt(sim, &dt0));
  int64_t nsteps = (int64_t)ceil(t_end / (dt_factor * dt0));
  const double dt = t_end / (double)nsteps;
  while (step < nsteps) {
    int64_t steps;
    double dts;
    CHECK(gimlet_stable_dt(sim, &dts));
    if (dt > dts) {
      if (rank_ == 0) fprintf(stderr, "the stable step fell to %g s, below the fixed step %g s\n", dts, dt);
      MPI_Abort(MPI_COMM_WORLD, 1);
    }
    int rc = gimlet_step(sim, dt, &t, &steps);
    if (rc == GIMLET_ERR_UNSTABLE) {
      /* An unstable step (or a frictional solve that did not settle): the
       * step was undone; say where, and stop. */
      char m[1024];
      gimlet_last_error(m, sizeof m, NULL);
      if (rank_ == 0) fprintf(stderr, "step %lld (t = %.6g s): %s\n", (long long)step + 1, t, m);
      MPI_Abort(MPI_COMM_WORLD, 1);
    }
    if (rc == GIMLET_ERR_PARTICLES_LEFT) {
      /* A particle would leave the domain: the step was undone and the
       * message names the first such particle and where it would go; stop,
       * a lost particle is a failed run. */
      char m[1024];
      gimlet_last_error(m, sizeof m, NULL);
      if (rank_ == 0) fprintf(stderr, "step %lld: %s\n", (long long)step + 1, m);
      MPI_Abort(MPI_COMM_WORLD, 1);
    }
    CHECK(rc);
    step++;
    for (int l = 0; l < levels; l++) part_steps += (double)level_particles[l] * (1 << l);
    double d, f[2], ke, se;
    int64_t nc;
    CHECK(gimlet_indenter_state(sim, wedge, &d, NULL, f, &nc));
    double load = 2 * f[1]; /* the full (mirrored) body */
    if (d > max_depth) max_depth = d;
    if (load > max_load) max_load = load;
    int at_max = !wrote_tip && t >= t3 - 0.5 * dt;
    if (unload && t >= t3 - 0.5 * dt && t <= unload_start + 0.5 * dt) {
      /* The contact half-width at the deepest point: the largest over the
       * hold. */
      double a_now = contact_half_width(sim, wedge);
      if (a_now > a_unload) a_unload = a_now;
    }
    int last = step == nsteps;
    if (unload && t > unload_start && nc == 0 && load == 0) {
      /* Separated: go on for 20 more steps (the last load points at zero),
       * then stop. */
      if (++separated_steps >= 20) last = 1;
    }
    if (step % 5 == 0 || at_max || last) {
      double ysink[NREF];
      particles_y(sim, NREF, ref_id, ysink);
      double sink = ref_y0[0] - ysink[0];
      if (ns == cap) {
        cap *= 2;
        s_depth = realloc(s_depth, sizeof(double) * cap);
        s_load = realloc(s_load, sizeof(double) * cap);
        s_sink = realloc(s_sink, sizeof(double) * cap);
      }
      s_depth[ns] = d, s_load[ns] = load, s_sink[ns] = sink, ns++;
      CHECK(gimlet_diagnostics(sim, &ke, &se, NULL, NULL, NULL));
      if (rank_ == 0)
        fprintf(csv, "%.9e,%.9e,%.9e,%.9e,%lld,%.9e,%.9e,%.9e,%.9e,%.9e,%.9e,%.9e,%.9e\n", t, d, load, 2 * f[0],
                (long long)nc, ke / 1e-6, se / 1e-6, sink, ref_y0[1] - ysink[1], ref_y0[2] - ysink[2],
                ref_y0[3] - ysink[3], ref_y0[4] - ysink[4], ref_y0[5] - ysink[5]);
    }
    if (at_max) {
      wrote_tip = 1;
      load_at_max = load;
      a_at_max = contact_half_width(sim, wedge);
      tip_stress = stress_near(sim, 0.0, Hb - d, tip_at);
      CHECK(gimlet_write_output(sim));
      int64_t m = 0;
      CHECK(gimlet_get_contacts(sim, wedge, 0, &m, NULL, NULL, NULL, NULL, NULL, NULL, NULL));
      double *xy = malloc(sizeof(double) * (2 * m + 2)), *pr = malloc(sizeof(double) * (m + 1)),
             *len = malloc(sizeof(double) * (m + 1));
      int *lev = malloc(sizeof(int) * (m + 1));
      CHECK(gimlet_get_contacts(sim, wedge, m, &m, xy, NULL, pr, len, NULL, lev, NULL));
      /* With friction: the tangential side of the same particles, same order. */
      double *tr = NULL, *sl = NULL;
      int *st = NULL;
      if (friction_set) {
        int64_t mf = 0;
        tr = malloc(sizeof(double) * (m + 1)), sl = malloc(sizeof(double) * (m + 1));
        st = malloc(sizeof(int) * (m + 1));
        CHECK(gimlet_get_contact_friction(sim, wedge, m, &mf, tr, sl, st));
        if (mf != m) {
          if (rank_ == 0) fprintf(stderr, "gimlet_get_contact_friction: %lld particles, gimlet_get_contacts %lld\n",
                                  (long long)mf, (long long)m);
          MPI_Abort(MPI_COMM_WORLD, 1);
        }
      }
      if (rank_ == 0) {
        snprintf(path, sizeof path, "%s/nanoindentation_tip.csv", out);
        FILE *f2 = fopen(path, "w");
        if (f2) {
          fprintf(f2, "x_m,y_m,pressure_pa,face_length_m,level%s\n", friction_set ? ",traction_pa,slip_m,stick" : "");
          for (int64_t k = 0; k < m; k++) {
            fprintf(f2, "%.9e,%.9e,%.9e,%.9e,%d", xy[2 * k], xy[2 * k + 1], pr[k], len[k], lev[k]);
            if (friction_set) fprintf(f2, ",%.9e,%.9e,%d", tr[k], sl[k], st[k]);
            fprintf(f2, "\n");
          }
          fclose(f2);
        }
      }
      free(xy); free(pr); free(len); free(lev); free(tr); free(sl); free(st);
    }
    if (!quiet && (step % every == 0 || at_max) && rank_ == 0) {
      double el = MPI_Wtime() - wall;
      printf("  step %6lld  t %8.3f ns  depth %7.2f nm  load %9.4f N/m  contacts %4lld  %6.2f M particle-steps/s  "
             "%5.0f s left\n",
             (long long)step, t * 1e9, d * 1e9, load, (long long)nc, part_steps / el / 1e6,
             el * (t_end - t) / t);
      fflush(stdout);
    }
    if (last) break;
  }
  wall = MPI_Wtime() - wall;
  CHECK(gimlet_write_output(sim));
  double ct[5] = {0};
  int64_t cn[6] = {0};
  CHECK(gimlet_contact_stats(sim, ct, cn));
  double ctot[5];
  MPI_Reduce(ct, ctot, 5, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
  /* Friction: the dissipation and the frictional solves (the whole body's,
   * the same on every rank). */
  double fdiss_all = 0;
  int64_t fc_all[3] = {0, 0, 0};
  if (friction_set) CHECK(gimlet_friction_stats(sim, wedge, &fdiss_all, fc_all));
  /* Where the step time went, summed over levels and ranks (kernel,
   * contact, exchange, migration, level coupling). */
  double lsum[5] = {0}, lall[5];
  for (int l = 0; l < levels; l++) {
    double lt[5];
    int64_t lc[2];
    CHECK(gimlet_level_stats(sim, l, lt, lc));
    for (int k = 0; k < 5; k++) lsum[k] += lt[k];
  }
  MPI_Reduce(lsum, lall, 5, MPI_DOUBLE, MPI_SUM, 0, MPI_COMM_WORLD);
  if (rank_ == 0) {
    fclose(csv);
    printf("done: %lld steps in %.2f s (%.3e particle-steps/s on %d rank(s))\n", (long long)step, wall,
           part_steps / wall, size);
    printf("  load at %.0f nm: %.6g N/m (full body, per metre); largest load %.6g N/m; deepest %.2f nm\n",
           depth_max * 1e9, load_at_max, max_load, max_depth * 1e9);
    printf("  contact half-width at %.0f nm: %.2f nm (%.2f finest particles; the outer edge of the outermost "
           "particle face with pressure)\n",
           depth_max * 1e9, a_at_max * 1e9, a_at_max / (0.5 * h0 / (1 << (levels - 1))));
    printf("  sigma_yy of the particle under the tip (%.1f, %.1f) nm: %.6g GPa\n", tip_at[0] * 1e9,
           tip_at[1] * 1e9, tip_stress / 1e9);
    printf("  contact: %.1f %% of the wall time (detection %.2f s, gather %.2f s, assembly %.2f s, solve %.2f s, "
           "apply %.2f s); %lld solves, largest system %lld, largest contact set %lld, %lld linear solves "
           "(%lld with PETSc), %.1f KSP iterations per PETSc solve\n",
           100 * (ctot[0] + ctot[1] + ctot[2] + ctot[3] + ctot[4]) / wall, ctot[0], ctot[1], ctot[2], ctot[3],
           ctot[4], (long long)cn[0], (long long)cn[1], (long long)cn[2], (long long)cn[3], (long long)cn[4],
           cn[4] ? (double)cn[5] / cn[4] : 0.0);
    if (friction_set)
      printf("  friction (mu = %g): dissipated %.6g J/m at the half model's flank (%.6g J/m for the full body); "
             "%lld frictional solves, %.2f friction-bound iterations per solve, at most %lld\n",
             friction, fdiss_all, 2 * fdiss_all, (long long)fc_all[0],
             fc_all[0] ? (double)fc_all[1] / fc_all[0] : 0.0, (long long)fc_all[2]);
    double all = lall[0] + lall[1] + lall[2] + lall[3] + lall[4];
    printf("  time over all levels and ranks: kernel %.1f %%, contact %.1f %%, exchange %.1f %%, migration %.1f %%, "
           "coupling %.1f %% (of %.1f core-seconds in steps; %.1f core-seconds of wall time)\n",
           100 * lall[0] / all, 100 * lall[1] / all, 100 * lall[2] / all, 100 * lall[3] / all, 100 * lall[4] / all,
           all, wall * size);
    printf("  wrote %s/nanoindentation.csv, %s/nanoindentation_tip.csv, %s/nanoindentation.xdmf\n", out, out,
           out);
    /* The run in one machine-readable line (scripts/bench.py reads it):
     * particle-steps count each level's particles (at the start) once per
     * step of that level. */
    printf("{\"case\":\"wedge\",\"ranks\":%d,\"levels\":%d,\"particles\":%lld,\"steps\":%lld,\"wall_s\":%.4f,"
           "\"particle_steps\":%.6e,\"pstep_per_s\":%.6e,\"depth_m\":%.6e,\"load_at_depth_n_per_m\":%.12e,"
           "\"contact_half_width_m\":%.6e,\"contact_share\":%.4f",
           size, levels, (long long)n, (long long)step, wall, part_steps, part_steps / wall, depth_max,
           load_at_max, a_at_max, (ctot[0] + ctot[1] + ctot[2] + ctot[3] + ctot[4]) / wall);
    /* Shares of the core-seconds in steps, over all levels and ranks:
     * kernel, contact, exchange, migration, coupling. */
    printf(",\"phase_shares\":[%.4f,%.4f,%.4f,%.4f,%.4f]", lall[0] / all, lall[1] / all, lall[2] / all,
           lall[3] / all, lall[4] / all);
    if (friction_set) {
      /* JSON has no infinity: full adhesion is the string "inf". */
      if (isinf(friction)) printf(",\"friction_mu\":\"inf\"");
      else printf(",\"friction_mu\":%.6g", friction);
      printf(",\"friction_dissipation_j_per_m\":%.6e", 2 * fdiss_all);
    }
    printf("}\n");
    fflush(stdout);
  }
  int status = 0;
  if (unload) {
    /* The residual impression: the top particle row after separation. */
    double *rows = NULL;
    int64_t k = surface_profile(sim, Hb, &rows);
    double uy_min = 0, x_min = 0, uy_max = 0, x_max = 0;
    if (rank_ == 0) {
      snprintf(path, sizeof path, "%s/nanoindentation_surface.csv", out);
      FILE *f3 = fopen(path, "w");
      if (!f3) { fprintf(stderr, "cannot write %s\n", path); MPI_Abort(MPI_COMM_WORLD, 1); }
      fprintf(f3, "x0_m,x_m,y_m,uy_m\n");
      for (int64_t i = 0; i < k; i++) {
        fprintf(f3, "%.9e,%.9e,%.9e,%.9e\n", rows[4 * i], rows[4 * i + 1], rows[4 * i + 2], rows[4 * i + 3]);
        if (rows[4 * i + 3] < uy_min) uy_min = rows[4 * i + 3], x_min = rows[4 * i + 1];
        if (rows[4 * i + 3] > uy_max) uy_max = rows[4 * i + 3], x_max = rows[4 * i + 1];
      }
      fclose(f3);
    }
    free(rows);
    /* The unloading analysis (pure; every rank has the same series). */
    double res[GIMLET_INDENTATION_RESULTS], rop[GIMLET_INDENTATION_RESULTS];
    int rc = gimlet_indentation_analysis(ns, s_depth, s_load, s_sink, r0, a_unload, 0.5, 1.0, res);
    /* The same with the contact half-width from Oliver-Pharr's contact
     * depth (independent of the weight function; assumes elastic sink-in). */
    int rc_op = gimlet_indentation_analysis_wedge(ns, s_depth, s_load, s_sink, r0, half_angle, 0.5, 1.0, rop);
    if (rank_ == 0) {
      printf("  residual impression (top particle row, %lld particles): deepest %.2f nm at x = %.1f nm, highest "
             "pile-up %+.2f nm at x = %.1f nm; wrote %s/nanoindentation_surface.csv\n",
             (long long)k, -uy_min * 1e9, x_min * 1e9, uy_max * 1e9, x_max * 1e9, out);
      if (rc != GIMLET_OK) {
        char m[1024];
        gimlet_last_error(m, sizeof m, NULL);
        printf("  unloading analysis failed: %s\n", m);
      } else {
        double es = E / (1 - nu * nu), er = res[GIMLET_INDENTATION_REDUCED_MODULUS];
        printf("  unloading analysis (%s; plane strain, depths relative to the surface at r0 = %.2f um, fit "
               "P = alpha (h - h_f)^m over 50-100 %% of P_max, %d points, RMS %.2g %% of P_max):\n",
               j2 ? "J2 aluminium, sigma_0 = 100 MPa, n = 0.1" : "elastic aluminium", r0 * 1e6,
               (int)res[GIMLET_INDENTATION_FIT_POINTS], 100 * res[GIMLET_INDENTATION_FIT_RMS]);
        printf("    P_max %.5g N/m at depth %.2f nm, contact half-width a %.1f nm (%.1f finest particles)\n",
               res[GIMLET_INDENTATION_UNLOAD_LOAD], res[GIMLET_INDENTATION_MAX_DEPTH] * 1e9, a_unload * 1e9,
               a_unload / (0.5 * h0 / (1 << (levels - 1))));
        printf("    hardness H = P_max / 2a = %.4g GPa\n", res[GIMLET_INDENTATION_HARDNESS] / 1e9);
        printf("    unloading stiffness S = %.4g GPa (m = %.3f)\n", res[GIMLET_INDENTATION_STIFFNESS] / 1e9,
               res[GIMLET_INDENTATION_FIT_M]);
        printf("    reduced modulus E_r = %.4g GPa; E/(1 - nu^2) = %.4g GPa: %+.2f %%\n", er / 1e9, es / 1e9,
               100 * (er / es - 1));
        printf("    residual depth (tip depth where the load returns to zero) %.2f nm\n",
               res[GIMLET_INDENTATION_RESIDUAL_DEPTH] * 1e9);
        if (!j2)
          printf("    elastic check, a from the wedge's closed form P = a E* tan(%g deg): %.1f nm\n", 90 - half_angle,
                 res[GIMLET_INDENTATION_UNLOAD_LOAD] / (es * tan((90 - half_angle) * M_PI / 180)) * 1e9);
      }
      if (rc_op != GIMLET_OK) {
        char m[1024];
        gimlet_last_error(m, sizeof m, NULL);
        printf("  unloading analysis with Oliver-Pharr's contact depth failed: %s\n", m);
      } else {
        double es = E / (1 - nu * nu), er = rop[GIMLET_INDENTATION_REDUCED_MODULUS];
        printf("  the same with a from Oliver-Pharr's contact depth (gimlet_indentation_analysis_wedge: "
               "a = (h - eps P/S) tan psi, elastic sink-in):\n");
        printf("    a %.1f nm, hardness H = %.4g GPa, reduced modulus E_r = %.4g GPa: %+.2f %% from E/(1 - nu^2)\n",
               rop[GIMLET_INDENTATION_CONTACT_HALF_WIDTH] * 1e9, rop[GIMLET_INDENTATION_HARDNESS] / 1e9, er / 1e9,
               100 * (er / es - 1));
        if (expect_modulus > 0 && !(fabs(er / es - 1) <= expect_modulus)) {
          printf("FAILED: the reduced modulus is %+.2f %% from E/(1 - nu^2), beyond %.2f %%\n", 100 * (er / es - 1),
                 100 * expect_modulus);
          status = 1;
        }
      }
    }
    if ((rc != GIMLET_OK || rc_op != GIMLET_OK) && expect_modulus > 0) status = 1;
    MPI_Bcast(&status, 1, MPI_INT, 0, MPI_COMM_WORLD);
  }
  free(s_depth); free(s_load); free(s_sink);
  CHECK(gimlet_destroy(&sim));
  MPI_Finalize();
  return status;
}
