/* The paper's wedge nanoindentation (Ma et al. 2005, section 4, third
 * example), on as many ranks as it is started with: the main job.
 *
 * Aluminium (E = 70 GPa, nu = 0.33, rho = 2700 kg/m^3, linear elastic,
 * plane strain), a 60 um x 40 um block modelled by its half, x in [0, 30 um]
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
 *   wedge_indentation [--levels L] [--h0 M] [--uniform M] [--speed V]
 *                     [--depth M] [--ramp S] [--patches PXxPY] [--out DIR]
 *                     [--every N] [--quiet]
 *
 *   --levels L    number of levels (default 3: 500/250/125 nm)
 *   --h0 M        coarse cell size in metres (default 5e-7)
 *   --uniform M   one level of cell size M instead (e.g. 1.25e-7)
 *   --speed V     indenter speed in m/s (default 10)
 *   --depth M     final depth in metres (default 4.5e-7)
 *   --ramp S      speed ramp duration in seconds (default 1e-8)
 *   --unload 0    stop at the final depth (no unloading)
 *   --flip F      FLIP fraction (default 0.95)
 *   --petsc       every contact solve with PETSc (default: small systems
 *                 by a direct solve on every rank)
 *
 * Writes DIR/nanoindentation.csv (time, depth_m: the tip's distance below
 * the undeformed top surface, load_n_per_m: the load on the full (mirrored)
 * body per metre of thickness, ...), DIR/nanoindentation_tip.csv (the
 * contact pressures at the deepest point), DIR/nanoindentation.xdmf with
 * DIR/nanoindentation_*.h5 (particle fields) and prints progress lines and
 * a summary: the load at the final depth, the stress sigma_yy of the
 * particle under the tip, the wall time and where the contact phase's time
 * went. */
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

int main(int argc, char **argv) {
  MPI_Init(&argc, &argv);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  int size;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  const double um = 1e-6;
  int levels = 3, px = 2, py = 2, every = 200, quiet = 0, unload = 1;
  double h0 = 0.5 * um, uniform = 0, speed = 10.0, depth_max = 0.45 * um, t_r = 10e-9, flip = 0.95;
  int petsc = 0;
  const char *out = "results";
  for (int i = 1; i < argc; i++) {
    const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : "";
    if (!strcmp(a, "--levels")) levels = atoi(v), i++;
    else if (!strcmp(a, "--h0")) h0 = atof(v), i++;
    else if (!strcmp(a, "--uniform")) uniform = atof(v), i++;
    else if (!strcmp(a, "--speed")) speed = atof(v), i++;
    else if (!strcmp(a, "--depth")) depth_max = atof(v), i++;
    else if (!strcmp(a, "--ramp")) t_r = atof(v), i++;
    else if (!strcmp(a, "--unload")) unload = atoi(v), i++;
    else if (!strcmp(a, "--flip")) flip = atof(v), i++;
    else if (!strcmp(a, "--petsc")) petsc = 1;
    else if (!strcmp(a, "--patches")) sscanf(v, "%dx%d", &px, &py), i++;
    else if (!strcmp(a, "--out")) out = v, i++;
    else if (!strcmp(a, "--every")) every = atoi(v), i++;
    else if (!strcmp(a, "--quiet")) quiet = 1;
    else {
      if (rank_ == 0) fprintf(stderr, "unknown argument %s (see the comment at the top of wedge_indentation.c)\n", a);
      MPI_Finalize();
      return 2;
    }
  }
  if (uniform > 0) {
    h0 = uniform;
    levels = 1;
  }
  const double W = 30 * um, Hb = 40 * um, top = 1 * um; /* room above the surface */
  GimletSim *sim = NULL;
  CHECK(gimlet_create(MPI_COMM_WORLD, 0, 0, W, Hb + top, h0, &sim));
  CHECK(gimlet_set_thickness(sim, 1 * um));
  /* Level l covers [0, 10 um / 2^(l-1)] x [Hb - 10 um / 2^(l-1), Hb + top]. */
  for (int l = 1; l < levels; l++) {
    double w = 10 * um / (1 << (l - 1));
    double box[4] = {0, Hb - w, w, Hb + top};
    CHECK(gimlet_add_level(sim, box, 1));
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
  CHECK(gimlet_add_material_linear_elastic(sim, 70e9, 0.33, 2700.0, &al));
  CHECK(gimlet_set_face_bc(sim, GIMLET_FACE_LEFT, GIMLET_BC_ROLLER));
  CHECK(gimlet_set_face_bc(sim, GIMLET_FACE_BOTTOM, GIMLET_BC_ROLLER));
  /* MUSL with 5 % PIC: with pure FLIP the particles in contact keep a
   * particle-scale mode that makes the load chatter from step to step. */
  CHECK(gimlet_set_flip(sim, flip));
  CHECK(gimlet_fill_rectangle(sim, 0, 0, W, Hb, 2, al, 2700.0, 0, 0, NULL));
  int wedge;
  CHECK(gimlet_add_indenter_wedge(sim, 65.0, 10 * um, 0.0, Hb, &wedge));
  if (petsc) CHECK(gimlet_set_contact_option(sim, GIMLET_CONTACT_DENSE_MAX, 0));
  /* Speed history: ramp up over t_r, hold, ramp down to reach depth_max at
   * rest; hold t_r; the same backwards to depth 0, then on at -speed until
   * the wedge is well clear. */
  double t1 = t_r, t2 = depth_max / speed, t3 = t2 + t_r; /* depth(t3) = depth_max */
  double times[8] = {0, t1, t2, t3, t3 + t_r, t3 + 2 * t_r, t3 + t_r + t2, t3 + 2 * t_r + t2};
  double speeds[8] = {0, speed, speed, 0, 0, -speed, -speed, -speed};
  CHECK(gimlet_set_indenter_motion(sim, wedge, GIMLET_MOTION_VELOCITY, unload ? 8 : 4, times, speeds));
  double t_end = unload ? t3 + 2 * t_r + t2 + 0.1 * t2 : t3;

  char path[1024];
  CHECK(gimlet_output_open(sim, out, "nanoindentation"));
  FILE *csv = NULL;
  if (rank_ == 0) {
    snprintf(path, sizeof path, "%s/nanoindentation.csv", out);
    csv = fopen(path, "w");
    if (!csv) { fprintf(stderr, "cannot write %s\n", path); MPI_Abort(MPI_COMM_WORLD, 1); }
    fprintf(csv, "time_s,depth_m,load_n_per_m,load_x_n_per_m,contacts,kinetic_j_per_m,strain_j_per_m\n");
  }
  int64_t n = 0;
  CHECK(gimlet_particle_count(sim, NULL, &n));
  if (rank_ == 0)
    printf("wedge nanoindentation: %d rank(s), %d level(s) (finest cell %.4g nm), %lld particles, "
           "speed %g m/s to %g nm%s\n",
           size, levels, h0 / (1 << (levels - 1)) * 1e9, (long long)n, speed, depth_max * 1e9,
           unload ? ", then unloading" : "");
  double wall = MPI_Wtime(), t = 0, load_at_max = NAN, tip_stress = NAN, tip_at[2] = {0, 0};
  double max_depth = 0, max_load = 0, part_steps = 0;
  int64_t step = 0, level_particles[8] = {0};
  for (int l = 0; l < levels; l++) {
    int64_t mine = 0;
    CHECK(gimlet_level_particle_count(sim, l, &mine));
    MPI_Allreduce(&mine, &level_particles[l], 1, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);
  }
  int wrote_tip = 0;
  while (t < t_end) {
    double dt;
    CHECK(gimlet_stable_dt(sim, &dt));
    if (t + dt > t_end) dt = t_end - t;
    int64_t steps;
    CHECK(gimlet_step(sim, dt, &t, &steps));
    step++;
    for (int l = 0; l < levels; l++) part_steps += (double)level_particles[l] * (1 << l);
    double d, f[2], ke, se;
    int64_t nc;
    CHECK(gimlet_indenter_state(sim, wedge, &d, NULL, f, &nc));
    double load = 2 * f[1]; /* the full (mirrored) body */
    if (d > max_depth) max_depth = d;
    if (load > max_load) max_load = load;
    int at_max = !wrote_tip && t >= t3 - 0.5 * dt;
    if (step % 10 == 0 || at_max || t >= t_end) {
      CHECK(gimlet_diagnostics(sim, &ke, &se, NULL, NULL, NULL));
      if (rank_ == 0)
        fprintf(csv, "%.9e,%.9e,%.9e,%.9e,%lld,%.9e,%.9e\n", t, d, load, 2 * f[0], (long long)nc, ke / 1e-6,
                se / 1e-6);
    }
    if (at_max) {
      wrote_tip = 1;
      load_at_max = load;
      tip_stress = stress_near(sim, 0.0, Hb - d, tip_at);
      CHECK(gimlet_write_output(sim));
      int64_t m = 0;
      CHECK(gimlet_get_contacts(sim, wedge, 0, &m, NULL, NULL, NULL, NULL, NULL, NULL, NULL));
      double *xy = malloc(sizeof(double) * (2 * m + 2)), *pr = malloc(sizeof(double) * (m + 1)),
             *len = malloc(sizeof(double) * (m + 1));
      int *lev = malloc(sizeof(int) * (m + 1));
      CHECK(gimlet_get_contacts(sim, wedge, m, &m, xy, NULL, pr, len, NULL, lev, NULL));
      if (rank_ == 0) {
        snprintf(path, sizeof path, "%s/nanoindentation_tip.csv", out);
        FILE *f2 = fopen(path, "w");
        if (f2) {
          fprintf(f2, "x_m,y_m,pressure_pa,face_length_m,level\n");
          for (int64_t k = 0; k < m; k++)
            fprintf(f2, "%.9e,%.9e,%.9e,%.9e,%d\n", xy[2 * k], xy[2 * k + 1], pr[k], len[k], lev[k]);
          fclose(f2);
        }
      }
      free(xy); free(pr); free(len); free(lev);
    }
    if (!quiet && (step % every == 0 || at_max) && rank_ == 0) {
      double el = MPI_Wtime() - wall;
      printf("  step %6lld  t %8.3f ns  depth %7.2f nm  load %9.4f N/m  contacts %4lld  %6.2f M particle-steps/s  "
             "%5.0f s left\n",
             (long long)step, t * 1e9, d * 1e9, load, (long long)nc, part_steps / el / 1e6,
             el * (t_end - t) / t);
      fflush(stdout);
    }
  }
  wall = MPI_Wtime() - wall;
  CHECK(gimlet_write_output(sim));
  double ct[5] = {0};
  int64_t cn[6] = {0};
  CHECK(gimlet_contact_stats(sim, ct, cn));
  double ctot[5];
  MPI_Reduce(ct, ctot, 5, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
  if (rank_ == 0) {
    fclose(csv);
    printf("done: %lld steps in %.2f s (%.3e particle-steps/s on %d rank(s))\n", (long long)step, wall,
           part_steps / wall, size);
    printf("  load at %.0f nm: %.6g N/m (full body, per metre); largest load %.6g N/m; deepest %.2f nm\n",
           depth_max * 1e9, load_at_max, max_load, max_depth * 1e9);
    printf("  sigma_yy of the particle under the tip (%.1f, %.1f) nm: %.6g GPa\n", tip_at[0] * 1e9,
           tip_at[1] * 1e9, tip_stress / 1e9);
    printf("  contact: %.1f %% of the wall time (detection %.2f s, gather %.2f s, assembly %.2f s, solve %.2f s, "
           "apply %.2f s); %lld solves, largest system %lld, largest contact set %lld, %lld linear solves "
           "(%lld with PETSc), %.1f KSP iterations per PETSc solve\n",
           100 * (ctot[0] + ctot[1] + ctot[2] + ctot[3] + ctot[4]) / wall, ctot[0], ctot[1], ctot[2], ctot[3],
           ctot[4], (long long)cn[0], (long long)cn[1], (long long)cn[2], (long long)cn[3], (long long)cn[4],
           cn[4] ? (double)cn[5] / cn[4] : 0.0);
    printf("  wrote %s/nanoindentation.csv, %s/nanoindentation_tip.csv, %s/nanoindentation.xdmf\n", out, out,
           out);
  }
  CHECK(gimlet_destroy(&sim));
  MPI_Finalize();
  return 0;
}
