/* The paper's multiscale nanoindentation (Ma et al. 2005, end of section 4):
 * nanometres to a quarter of a millimetre in one run, loaded and unloaded.
 *
 * Aluminium (E = 70 GPa, nu = 0.33, rho = 2700 kg/m^3, linear elastic,
 * plane strain), a 0.25 mm x 0.125 mm workpiece modelled by its half:
 * x in [0, 125 um] with the symmetry plane at x = 0 (roller), the bottom
 * fixed in y (roller), the right face free, 2x2 particles per cell. The coarse cell is
 * 125 um / 64 = 1.95 um (particles of 0.98 um); with 5 levels the finest
 * cell is 122 nm (particles of 61 nm: the 9.8 um depth is 160 of them).
 *
 * Sizing of the refined regions: an elastic wedge on a half-space sinks
 * the surface in, so the contact half-width is far below the geometric
 * d tan(65 deg) = 21 um at d = 9.8 um; measured here, it is about 7 um. The
 * finest level of the 5-level run covers [0, 25.4 um] x [top - 15.6 um,
 * top] (13 x 8 coarse cells), more than three contact half-widths across
 * and two deep, where the stress under the wedge varies fastest; each
 * coarser level doubles both extents (50.8 x 31.3 um, 101.6 x 62.5 um), the
 * first one spans the width and 101.6 um of the depth. With L levels the
 * L-1 coarsest of these boxes are used, so 4 levels drop the finest and
 * 6 levels add one of 12.7 x 7.8 um of 61 nm cells at the tip.
 *
 * The rigid wedge (tip half-angle 65 deg) starts with its apex on the
 * surface on the symmetry axis. Its speed ramps from 0 to 150 m/s over
 * t_r = 10 ns and is held; it decelerates over t_r so that it comes to
 * rest at 9.8 um, then accelerates upwards to 150 m/s over t_r and is
 * withdrawn until the body has been out of contact for 20 steps.
 *
 *   multiscale_indentation [--levels L | --across T [--box-factor F]] [--speed V] [--depth M] [--ramp S]
 *                          [--patches PXxPY] [--flip F] [--cfl C] [--petsc]
 *                          [--out DIR] [--name NAME] [--every N] [--quiet]
 *                          [--steps N]
 *
 *   --across T    the levels and boxes proposed by gimlet_propose_levels
 *                 for at least T finest particles across the expected
 *                 elastic contact half-width at the deepest point (the
 *                 half-space estimate with the workpiece's depth: 7.3 um at
 *                 9.8 um, where about 7 um is measured), instead of the boxes
 *                 below; --box-factor F (default 3.5) sets the finest box's
 *                 reach in half-widths
 *
 * Writes DIR/NAME.csv every coarse step (time, depth, load on the full body
 * per metre of thickness, contacts, and the energy balance of the full
 * body per metre: the indenter's work, kinetic and strain energy, and
 * their difference, what the scheme dissipated), DIR/NAME_profiles.csv
 * (the contact pressures at 1/4, 1/2, 3/4 and all of the depth while
 * loading, and at 1/2 while unloading), DIR/NAME_levels.csv (the level
 * boxes), DIR/NAME_deepest.csv (sigma_yy and level of the particles within
 * 4 depths of the axis and 3 below the surface at the deepest point), DIR/NAME.xdmf + DIR/NAME_*.h5 (particle fields at the deepest
 * point and at the end), and prints a summary: depth reached, load at the
 * deepest point, sigma_yy under the tip, hysteresis and residual depth,
 * energy balance, stability checks, wall time and where the contact
 * phase's time went. Plots: scripts/plot_multiscale.py DIR NAME.
 * --cfl C is the Courant number of the stable step (default 0.8, above
 * the library's 0.5: measured on this scene with 5 levels, the load at
 * 9.8 um differs by 0.6 % between 0.5 and 0.8 (the 4th-to-5th-level
 * refinement changes it by about 1 %), for 37 % fewer steps; the scheme's
 * dissipation grows from 5.8 % to 7.1 % of the loading work).
 * --steps N stops after N coarse steps (a benchmark of the first part of
 * the loading; the summary then describes the part that ran). */
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

/* Allocates n elements of size s or stops the run. */
static void *alloc(int64_t n, size_t s) {
  void *p = malloc((size_t)(n + 1) * s);
  if (!p) {
    fprintf(stderr, "rank %d: out of memory\n", rank_);
    MPI_Abort(MPI_COMM_WORLD, 1);
  }
  return p;
}

/* What the particles look like over all ranks: sigma_yy of the particle
 * nearest to (x, y) and where it is, the smallest det F, the largest speed,
 * and whether every value is finite. */
typedef struct {
  double tip_stress, tip_at[2], min_det, max_speed;
  int finite;
} Survey;

static Survey survey(GimletSim *sim, double x, double y) {
  int64_t n = 0;
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_POSITION, NULL, 0, &n));
  double *p = alloc(2 * n, sizeof(double)), *s = alloc(4 * n, sizeof(double));
  double *v = alloc(2 * n, sizeof(double)), *F = alloc(4 * n, sizeof(double));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_POSITION, p, n, &n));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_STRESS, s, n, &n));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_VELOCITY, v, n, &n));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_DEFGRAD, F, n, &n));
  struct { double d; int r; } best = {INFINITY, rank_}, all;
  double mine[3] = {0, 0, 0}, ext[2] = {INFINITY, 0}; /* min det, -max speed */
  int finite = 1;
  for (int64_t i = 0; i < n; i++) {
    double d = hypot(p[2 * i] - x, p[2 * i + 1] - y);
    if (d < best.d) {
      best.d = d;
      mine[0] = s[4 * i + 1];
      mine[1] = p[2 * i];
      mine[2] = p[2 * i + 1];
    }
    double det = F[4 * i] * F[4 * i + 3] - F[4 * i + 1] * F[4 * i + 2];
    double sp = hypot(v[2 * i], v[2 * i + 1]);
    if (det < ext[0]) ext[0] = det;
    if (-sp < ext[1]) ext[1] = -sp;
    for (int k = 0; k < 4; k++) finite &= isfinite(s[4 * i + k]) && isfinite(F[4 * i + k]);
    finite &= isfinite(p[2 * i]) && isfinite(p[2 * i + 1]) && isfinite(sp);
  }
  Survey r;
  MPI_Allreduce(&best, &all, 1, MPI_DOUBLE_INT, MPI_MINLOC, MPI_COMM_WORLD);
  MPI_Bcast(mine, 3, MPI_DOUBLE, all.r, MPI_COMM_WORLD);
  double gext[2];
  MPI_Allreduce(ext, gext, 2, MPI_DOUBLE, MPI_MIN, MPI_COMM_WORLD);
  MPI_Allreduce(&finite, &r.finite, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  r.tip_stress = mine[0];
  r.tip_at[0] = mine[1];
  r.tip_at[1] = mine[2];
  r.min_det = gext[0];
  r.max_speed = -gext[1];
  free(p);
  free(s);
  free(v);
  free(F);
  return r;
}

/* Appends the contact particles now to the profiles file (rank 0). */
static void write_profile(GimletSim *sim, int wedge, FILE *f, const char *phase, double depth) {
  int64_t m = 0;
  CHECK(gimlet_get_contacts(sim, wedge, 0, &m, NULL, NULL, NULL, NULL, NULL, NULL, NULL));
  double *xy = alloc(2 * m, sizeof(double)), *pr = alloc(m, sizeof(double)), *len = alloc(m, sizeof(double));
  int *lev = alloc(m, sizeof(int)), *rk = alloc(m, sizeof(int));
  CHECK(gimlet_get_contacts(sim, wedge, m, &m, xy, NULL, pr, len, NULL, lev, rk));
  if (f)
    for (int64_t k = 0; k < m; k++)
      fprintf(f, "%s,%.9e,%.9e,%.9e,%.9e,%.9e,%d,%d\n", phase, depth, xy[2 * k], xy[2 * k + 1], pr[k], len[k],
              lev[k], rk[k]);
  free(xy);
  free(pr);
  free(len);
  free(lev);
  free(rk);
}

/* Writes x, y, sigma_yy and level of the particles in [0, x1] x [y0, inf)
 * over all ranks to f (rank 0). */
static void write_window(GimletSim *sim, FILE *f, double x1, double y0) {
  int64_t n = 0;
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_POSITION, NULL, 0, &n));
  double *p = alloc(2 * n, sizeof(double)), *s = alloc(4 * n, sizeof(double)), *lv = alloc(n, sizeof(double));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_POSITION, p, n, &n));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_STRESS, s, n, &n));
  CHECK(gimlet_get_field(sim, GIMLET_FIELD_LEVEL, lv, n, &n));
  double *mine = alloc(4 * n, sizeof(double));
  int m = 0;
  for (int64_t i = 0; i < n; i++)
    if (p[2 * i] <= x1 && p[2 * i + 1] >= y0) {
      mine[4 * m] = p[2 * i];
      mine[4 * m + 1] = p[2 * i + 1];
      mine[4 * m + 2] = s[4 * i + 1];
      mine[4 * m + 3] = lv[i];
      m++;
    }
  int size, cnt = 4 * m;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  int *counts = alloc(size, sizeof(int)), *displ = alloc(size, sizeof(int));
  MPI_Gather(&cnt, 1, MPI_INT, counts, 1, MPI_INT, 0, MPI_COMM_WORLD);
  int total = 0;
  if (rank_ == 0)
    for (int r = 0; r < size; r++) displ[r] = total, total += counts[r];
  double *all = alloc(rank_ == 0 ? total : 0, sizeof(double));
  MPI_Gatherv(mine, cnt, MPI_DOUBLE, all, counts, displ, MPI_DOUBLE, 0, MPI_COMM_WORLD);
  if (f) {
    fprintf(f, "x_m,y_m,sigma_yy_pa,level\n");
    for (int k = 0; k < total / 4; k++)
      fprintf(f, "%.7e,%.7e,%.6e,%d\n", all[4 * k], all[4 * k + 1], all[4 * k + 2], (int)all[4 * k + 3]);
  }
  free(p);
  free(s);
  free(lv);
  free(mine);
  free(counts);
  free(displ);
  free(all);
}

static FILE *open_out(const char *dir, const char *name, const char *suffix) {
  char path[1024];
  snprintf(path, sizeof path, "%s/%s%s", dir, name, suffix);
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
  int size;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  const double um = 1e-6;
  int levels = 5, px = 2, py = 2, every = 100, quiet = 0, petsc = 0;
  long long max_steps = -1;
  double speed = 150.0, depth_max = 9.8 * um, t_r = 10e-9, flip = 0.95, cfl = 0.8;
  double across = 0, box_factor = 3.5;
  const char *out = "results", *name = "multiscale";
  for (int i = 1; i < argc; i++) {
    const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : "";
    if (!strcmp(a, "--levels")) levels = atoi(v), i++;
    else if (!strcmp(a, "--speed")) speed = atof(v), i++;
    else if (!strcmp(a, "--across")) across = atof(v), i++;
    else if (!strcmp(a, "--box-factor")) box_factor = atof(v), i++;
    else if (!strcmp(a, "--depth")) depth_max = atof(v), i++;
    else if (!strcmp(a, "--ramp")) t_r = atof(v), i++;
    else if (!strcmp(a, "--flip")) flip = atof(v), i++;
    else if (!strcmp(a, "--cfl")) cfl = atof(v), i++;
    else if (!strcmp(a, "--petsc")) petsc = 1;
    else if (!strcmp(a, "--patches")) sscanf(v, "%dx%d", &px, &py), i++;
    else if (!strcmp(a, "--out")) out = v, i++;
    else if (!strcmp(a, "--name")) name = v, i++;
    else if (!strcmp(a, "--every")) every = atoi(v), i++;
    else if (!strcmp(a, "--quiet")) quiet = 1;
    else if (!strcmp(a, "--steps")) max_steps = atoll(v), i++;
    else {
      if (rank_ == 0) fprintf(stderr, "unknown argument %s (see the comment at the top of multiscale_indentation.c)\n", a);
      MPI_Finalize();
      return 2;
    }
  }
  if (levels < 1 || levels > 6 || px < 1 || py < 1 || !(speed > 0) || !(depth_max > 0) || !(t_r > 0) ||
      depth_max <= speed * t_r) {
    if (rank_ == 0)
      fprintf(stderr, "need 1 <= levels <= 6, patches >= 1x1, speed, depth, ramp > 0 and depth > speed * ramp\n");
    MPI_Finalize();
    return 2;
  }
  /* The domain: the half workpiece and 4 coarse cells of room above it and
   * beside its free right face (which the stress waves move outwards). */
  const double W = 125 * um, Hb = 125 * um, h0 = W / 64, top = Hb + 4 * h0;
  /* Refined boxes [0, X] x [Hb - Y, top], coarsest first (see the top). */
  const double box_x[5] = {64 * h0, 52 * h0, 26 * h0, 13 * h0, 6.5 * h0};
  const double box_y[5] = {52 * h0, 32 * h0, 16 * h0, 8 * h0, 4 * h0};
  /* --across T: the library proposes the levels and boxes for at least T
   * finest particles across the expected (elastic) contact half-width at
   * the deepest point, the finest box reaching --box-factor half-widths. */
  double proposed[4 * 5];
  if (across > 0) {
    const double domain[5] = {0, 0, W + 4 * h0, top, h0};
    double res[GIMLET_PROPOSAL_RESULTS];
    CHECK(gimlet_propose_levels(domain, 0, Hb, GIMLET_INDENTER_WEDGE, 65.0, depth_max, GIMLET_RESPONSE_ELASTIC, 2,
                                across, box_factor, 6, &levels, proposed, res));
    if (rank_ == 0)
      printf("proposed layout for %g particles across a: expected a = %.2f um, %d level(s), finest cell %.1f nm "
             "(%.2f particles across a)\n",
             across, res[GIMLET_PROPOSAL_CONTACT_HALF_WIDTH] / um, levels, res[GIMLET_PROPOSAL_FINEST_CELL] * 1e9,
             res[GIMLET_PROPOSAL_PARTICLES_ACROSS]);
  }
  GimletSim *sim = NULL;
  CHECK(gimlet_create(MPI_COMM_WORLD, 0, 0, W + 4 * h0, top, h0, &sim));
  CHECK(gimlet_set_thickness(sim, 1 * um));
  for (int l = 1; l < levels; l++) {
    double box[4] = {0, Hb - box_y[l - 1], box_x[l - 1], top};
    CHECK(gimlet_add_level(sim, across > 0 ? proposed + 4 * (l - 1) : box, 1));
  }
  double level_cells[6] = {0}, level_h[6] = {0};
  FILE *lf = rank_ == 0 ? open_out(out, name, "_levels.csv") : NULL;
  if (lf) fprintf(lf, "level,cell_m,x0_m,y0_m,x1_m,y1_m,patches\n");
  for (int l = 0; l < levels; l++) {
    int nboxes, npatches;
    int64_t count = 0;
    double hl, b[4];
    CHECK(gimlet_level_info(sim, l, &hl, &nboxes, &npatches));
    CHECK(gimlet_level_boxes(sim, l, b, 1, &count));
    /* A refined level computes on its box plus a 4-cell ghost ring on the
     * sides away from the domain's edges. */
    int wx = (int)lround((b[2] - b[0]) / hl) + (l ? 4 : 0), wy = (int)lround((b[3] - b[1]) / hl) + (l ? 4 : 0);
    CHECK(gimlet_set_patch_size(sim, l, (wx + px - 1) / px, (wy + py - 1) / py));
    CHECK(gimlet_level_info(sim, l, &hl, &nboxes, &npatches));
    level_h[l] = hl;
    level_cells[l] = (b[2] - b[0]) * (b[3] - b[1]) / (hl * hl);
    if (lf) fprintf(lf, "%d,%.9e,%.9e,%.9e,%.9e,%.9e,%d\n", l, hl, b[0], b[1], b[2], b[3], npatches);
  }
  if (lf) fclose(lf);
  int al;
  CHECK(gimlet_add_material_linear_elastic(sim, 70e9, 0.33, 2700.0, &al));
  CHECK(gimlet_set_face_bc(sim, GIMLET_FACE_LEFT, GIMLET_BC_ROLLER));
  CHECK(gimlet_set_face_bc(sim, GIMLET_FACE_BOTTOM, GIMLET_BC_ROLLER));
  /* MUSL with 5 % PIC: with pure FLIP the particles in contact keep a
   * particle-scale mode that makes the load chatter from step to step. */
  CHECK(gimlet_set_flip(sim, flip));
  /* The paper's weights and transfer (uGIMP, FLIP), which this scene's
   * figures were measured with; the library's defaults are cpGIMP, APIC. */
  CHECK(gimlet_set_shape(sim, GIMLET_SHAPE_UGIMP));
  CHECK(gimlet_set_transfer(sim, GIMLET_TRANSFER_FLIP));
  CHECK(gimlet_set_cfl(sim, cfl));
  CHECK(gimlet_fill_rectangle(sim, 0, 0, W, Hb, 2, al, 2700.0, 0, 0, NULL));
  int wedge;
  CHECK(gimlet_add_indenter_wedge(sim, 65.0, 40 * um, 0.0, Hb, &wedge));
  if (petsc) CHECK(gimlet_set_contact_option(sim, GIMLET_CONTACT_DENSE_MAX, 0));
  /* Speeds: up to v over t_r, held, down to 0 over t_r reaching depth_max
   * (at t3), up to -v over t_r, held. */
  double t2 = depth_max / speed, t3 = t2 + t_r;
  double times[6] = {0, t_r, t2, t3, t3 + t_r, t3 + 2 * t_r};
  double speeds[6] = {0, speed, speed, 0, -speed, -speed};
  CHECK(gimlet_set_indenter_motion(sim, wedge, GIMLET_MOTION_VELOCITY, 6, times, speeds));
  /* A bound on the run: the withdrawal takes at most as long as the
   * loading; separation ends it earlier. */
  double t_stop = t3 + 2 * t_r + t2;

  CHECK(gimlet_output_open(sim, out, name));
  FILE *csv = rank_ == 0 ? open_out(out, name, ".csv") : NULL;
  FILE *prof = rank_ == 0 ? open_out(out, name, "_profiles.csv") : NULL;
  if (csv)
    fprintf(csv, "time_s,depth_m,load_n_per_m,load_x_n_per_m,contacts,work_j_per_m,kinetic_j_per_m,"
                 "strain_j_per_m,dissipated_j_per_m\n");
  if (prof) fprintf(prof, "phase,depth_m,x_m,y_m,pressure_pa,face_length_m,level,rank\n");
  int64_t n0 = 0, level_particles[6] = {0};
  CHECK(gimlet_particle_count(sim, NULL, &n0));
  for (int l = 0; l < levels; l++) {
    int64_t mine = 0;
    CHECK(gimlet_level_particle_count(sim, l, &mine));
    MPI_Allreduce(&mine, &level_particles[l], 1, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);
  }
  if (rank_ == 0) {
    printf("multiscale nanoindentation: %d rank(s), %d level(s): cells %.4g um to %.4g nm (particles %.4g um to "
           "%.4g nm), %lld particles\n",
           size, levels, h0 / um, h0 / (1 << (levels - 1)) * 1e9, h0 / 2 / um, h0 / (1 << levels) * 1e9,
           (long long)n0);
    for (int l = 0; l < levels; l++)
      printf("  level %d: %lld particles, %d substep(s) per coarse step\n", l, (long long)level_particles[l],
             1 << l);
    printf("  wedge 65 deg at up to %g m/s to %g um, then withdrawn until separation\n", speed, depth_max / um);
  }
  /* Thickness 1 um: energies per metre of thickness of the half model are
   * the diagnostics over 1e-6; the full body is twice the half. */
  const double per_m = 2.0 / 1e-6;
  double wall = MPI_Wtime(), t = 0, work = 0, last_depth = 0, part_steps = 0;
  double max_depth = 0, max_load = 0, load_at_max = NAN, w_load = 0, w_unload = 0;
  double depth_sep = NAN, max_dissipated = 0;
  int64_t step = 0, max_contacts = 0, dt_steps = 0;
  int free_steps = 0, next_profile = 1, wrote_unload = 0;
  /* The survey at the deepest point; a run stopped early by --steps never
   * takes it, and then only the end state is judged. */
  Survey deep = {0};
  deep.finite = 1;
  int reached_deepest = 0;
  const double fractions[4] = {0.25, 0.5, 0.75, 1.0};
  while (t < t_stop) {
    double dt;
    CHECK(gimlet_stable_dt(sim, &dt));
    int64_t steps;
    int st = gimlet_step(sim, dt, &t, &steps);
    /* A step in which particles would leave the domain fails with
     * GIMLET_ERR_PARTICLES_LEFT and is undone (GIMLET_OUTFLOW_FAIL, the
     * default); its message names the first particle and where it was. */
    CHECK(st);
    step++;
    dt_steps++;
    for (int l = 0; l < levels; l++) part_steps += (double)level_particles[l] * (1 << l);
    double d, f[2], ke, se;
    int64_t nc;
    CHECK(gimlet_indenter_state(sim, wedge, &d, NULL, f, &nc));
    double load = 2 * f[1];
    /* The step's mean force times the step's displacement. */
    double dw = load * (d - last_depth);
    work += dw;
    if (t <= t3 + 0.5 * dt) w_load += dw;
    else w_unload -= dw;
    last_depth = d;
    if (d > max_depth) max_depth = d;
    if (load > max_load) max_load = load;
    if (nc > max_contacts) max_contacts = nc;
    CHECK(gimlet_diagnostics(sim, &ke, &se, NULL, NULL, NULL));
    double dis = work - (ke + se) * per_m;
    if (dis > max_dissipated) max_dissipated = dis;
    if (csv)
      fprintf(csv, "%.9e,%.9e,%.9e,%.9e,%lld,%.9e,%.9e,%.9e,%.9e\n", t, d, load, 2 * f[0], (long long)nc, work,
              ke * per_m, se * per_m, dis);
    /* Pressure profiles while loading, the last at the deepest point. */
    while (next_profile <= 4 && t <= t3 + 0.5 * dt && (d >= fractions[next_profile - 1] * depth_max * (1 - 1e-9) ||
                                                        (next_profile == 4 && t >= t3 - 0.5 * dt))) {
      write_profile(sim, wedge, prof, "loading", d);
      if (next_profile == 4) {
        load_at_max = load;
        deep = survey(sim, 0.0, Hb - d);
        reached_deepest = 1;
        CHECK(gimlet_write_output(sim));
        FILE *wf = rank_ == 0 ? open_out(out, name, "_deepest.csv") : NULL;
        write_window(sim, wf, 4 * depth_max, Hb - 3 * depth_max);
        if (wf) fclose(wf);
      }
      next_profile++;
    }
    if (!wrote_unload && t > t3 && d <= 0.5 * depth_max) {
      write_profile(sim, wedge, prof, "unloading", d);
      wrote_unload = 1;
    }
    if (t > t3 && nc == 0 && f[1] == 0.0) {
      if (free_steps == 0) depth_sep = d;
      free_steps++;
    } else {
      free_steps = 0;
    }
    if (!quiet && step % every == 0 && rank_ == 0) {
      double el = MPI_Wtime() - wall;
      printf("  step %6lld  t %8.3f ns  depth %8.4f um  load %10.4f N/m  contacts %4lld  %6.2f M particle-steps/s\n",
             (long long)step, t * 1e9, d / um, load, (long long)nc, part_steps / el / 1e6);
      fflush(stdout);
    }
    if (free_steps >= 20) break;
    if (max_steps >= 0 && step >= max_steps) break;
  }
  wall = MPI_Wtime() - wall;
  Survey end = survey(sim, 0.0, Hb);
  CHECK(gimlet_write_output(sim));
  int64_t n_end = 0, lost = 0;
  CHECK(gimlet_particle_count(sim, NULL, &n_end));
  CHECK(gimlet_lost_particles(sim, NULL, NULL, 0, &lost));
  double ct[5] = {0}, ctot[5];
  int64_t cn[6] = {0};
  CHECK(gimlet_contact_stats(sim, ct, cn));
  MPI_Reduce(ct, ctot, 5, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
  double ke, se;
  CHECK(gimlet_diagnostics(sim, &ke, &se, NULL, NULL, NULL));
  /* Per level: times summed over ranks (kernel, contact, exchange,
   * migration, coupling) and steps. */
  double lt[6][5], lt_all[6][5];
  int64_t lsteps[6] = {0};
  for (int l = 0; l < levels; l++) {
    int64_t c[2];
    CHECK(gimlet_level_stats(sim, l, lt[l], c));
    lsteps[l] = c[0];
  }
  MPI_Reduce(lt, lt_all, 6 * 5, MPI_DOUBLE, MPI_SUM, 0, MPI_COMM_WORLD);
  if (rank_ == 0) {
    double sum[5] = {0}, cells = 0, hf = level_h[levels - 1];
    printf("  level  cell (nm)  cells    particles  steps   kernel  contact  exchange  migration  coupling  "
           "M particle-steps/s per core\n");
    for (int l = 0; l < levels; l++) {
      double tl = 0;
      for (int k = 0; k < 5; k++) tl += lt_all[l][k], sum[k] += lt_all[l][k];
      cells += level_cells[l];
      printf("  %5d  %9.1f  %7.0f  %9lld  %5lld  %6.1f  %7.1f  %8.1f  %9.1f  %8.1f  %.3g\n", l, level_h[l] * 1e9,
             level_cells[l], (long long)level_particles[l], (long long)lsteps[l], lt_all[l][0], lt_all[l][1],
             lt_all[l][2], lt_all[l][3], lt_all[l][4], (double)level_particles[l] * lsteps[l] / tl / 1e6);
    }
    double all = sum[0] + sum[1] + sum[2] + sum[3] + sum[4];
    printf("  time over all levels and ranks: kernel %.1f %%, contact %.1f %%, exchange %.1f %%, migration %.1f %%, "
           "coupling %.1f %% (of %.1f core-seconds in steps; %.1f core-seconds of wall time)\n",
           100 * sum[0] / all, 100 * sum[1] / all, 100 * sum[2] / all, 100 * sum[3] / all, 100 * sum[4] / all, all,
           wall * size);
    double uc = (W + 4 * h0) * top / (hf * hf), up = 4 * W * Hb / (hf * hf);
    printf("  against a uniform grid of the finest cells: %.0f cells (%.2f %%), %lld particles (%.2f %%), and "
           "%.3g particle-steps (%.2f %%)\n",
           cells, 100 * cells / uc, (long long)n0, 100 * n0 / up, part_steps,
           100 * part_steps / (up * (double)step * (1 << (levels - 1))));
  }
  if (rank_ == 0) {
    fclose(csv);
    fclose(prof);
    printf("done: %lld coarse steps in %.1f s on %d rank(s), %.3e particle-steps (%.3g M per second per core)\n",
           (long long)step, wall, size, part_steps, part_steps / wall / size / 1e6);
    printf("  deepest %.4f um (target %.4f um, %.0f finest particles); load there %.6g N/m (full body, per metre), "
           "largest %.6g N/m\n",
           max_depth / um, depth_max / um, max_depth / (h0 / (1 << levels)), load_at_max, max_load);
    if (reached_deepest)
      printf("  sigma_yy of the particle under the tip (%.3f, %.3f) um at the deepest point: %.6g GPa\n",
             deep.tip_at[0] / um, deep.tip_at[1] / um, deep.tip_stress / 1e9);
    else
      printf("  the run stopped before the deepest point (--steps): no load or tip stress there\n");
    printf("  largest contact set %lld particles (largest system solved %lld unknowns)\n", (long long)max_contacts,
           (long long)cn[1]);
    printf("  separation at depth %.4f um (residual depth after separation), the run ended at t = %.3f ns\n",
           depth_sep / um, t * 1e9);
    printf("  hysteresis: loading work %.6g J/m, returned while unloading %.6g J/m: (W_load - W_unload) / W_load "
           "= %.4f\n",
           w_load, w_unload, (w_load - w_unload) / w_load);
    printf("  energy balance at the end (J/m, full body): indenter work %.6g = kinetic %.6g + strain %.6g + "
           "dissipated %.6g (%.2f %% of the loading work; largest during the run %.6g)\n",
           work, ke * per_m, se * per_m, work - (ke + se) * per_m, 100 * (work - (ke + se) * per_m) / w_load,
           max_dissipated);
    printf("  stability: particles %lld -> %lld (lost %lld), all values finite: %s, smallest det F %.4f "
           "(deepest point %.4f), largest particle speed %.4g m/s (deepest point %.4g)\n",
           (long long)n0, (long long)n_end, (long long)lost, end.finite && deep.finite ? "yes" : "NO",
           end.min_det, deep.min_det, end.max_speed, deep.max_speed);
    printf("  contact: %.1f %% of the wall time (detection %.2f s, gather %.2f s, assembly %.2f s, solve %.2f s, "
           "apply %.2f s); %lld solves, %lld linear solves (%lld with PETSc)\n",
           100 * (ctot[0] + ctot[1] + ctot[2] + ctot[3] + ctot[4]) / wall, ctot[0], ctot[1], ctot[2], ctot[3],
           ctot[4], (long long)cn[0], (long long)cn[3], (long long)cn[4]);
    printf("  wrote %s/%s.csv, %s_profiles.csv, %s_levels.csv, %s_deepest.csv, %s.xdmf\n", out, name, name, name, name,
           name);
  }
  CHECK(gimlet_destroy(&sim));
  MPI_Finalize();
  return (n_end == n0 && lost == 0 && end.finite && deep.finite && end.min_det > 0) ? 0 : 1;
}
