/* The paper's indentation by a surface pressure (section 4, fig. 10) with
 * three nested levels refined under the loaded strip, against the same
 * problem on a uniform grid at the finest cell size (issue "Nested levels
 * with subcycling").
 *
 * Silicon (E = 170 GPa, nu = 0.18, rho = 2330 kg/m^3), 40 um x 40 um half
 * model, plane strain 1 um thick, symmetry roller at x = 0, bottom fixed;
 * a pressure of 2 GPa on the top surface for x < 5 um, ramped over 1500
 * steps of 20 ps. Levels: 1 um cells; 0.5 um on [0, 20] x [20, 40] um;
 * 0.25 um on [0, 10] x [30, 40] um (each a quarter of the next coarser in
 * area), coarse step 20 ps (the finest level takes 4 steps of 5 ps). The
 * uniform run has 0.25 um cells and steps of 5 ps. After STEPS coarse steps
 * (default 500, the paper's comparison with FEM), the stresses of the
 * particles of the finest region are compared with those of the uniform
 * run at the same reference positions (the finest level's particles sit on
 * the uniform run's lattice).
 *
 * Bound: the relative L2 difference of the stress tensor over the finest
 * region, ||s_levels - s_uniform|| / ||s_uniform||, <= 2 %; also printed:
 * the largest difference of s_yy over the largest |s_yy|, and the wall
 * times and particle counts of the two runs.
 *
 *   test_levels_pressure [STEPS]
 */
#include "scenes.h"

static const double um = 1e-6;

/* Reference position and stress (xx, yy, xy, zz) of every particle, by id,
 * on rank 0; those outside the finest region [0, 10] x [30, 40] um are
 * skipped where they are read. */
static Rec *finest_region(GimletSim *s, int64_t *count) {
  const int fields[2] = {GIMLET_FIELD_REFERENCE, GIMLET_FIELD_STRESS};
  return gather(s, MPI_COMM_WORLD, fields, 2, count);
}

static int in_finest(const Rec *r) {
  return r->v[0] <= 10 * um && r->v[1] >= 30 * um;
}

int main(int argc, char **argv) {
  check_begin(&argc, &argv);
  int steps = argc > 1 ? atoi(argv[1]) : 500;
  /* The paper's weights and transfer (uGIMP, FLIP), which this scene's
   * figures were measured with. */
  GimletSim *lev = NULL, *uni = NULL;
  pressure_scene(&lev, MPI_COMM_WORLD, 1 * um, 3, 0, 0, UGIMP_FLIP);
  pressure_scene(&uni, MPI_COMM_WORLD, 0.25 * um, 1, 0, 0, UGIMP_FLIP);
  double t, wall[2];
  int64_t st, np[2];
  MPI_Barrier(MPI_COMM_WORLD);
  wall[0] = MPI_Wtime();
  for (int k = 0; k < steps; k++) MUST(gimlet_step(lev, 20e-12, &t, &st));
  MPI_Barrier(MPI_COMM_WORLD);
  wall[0] = MPI_Wtime() - wall[0];
  wall[1] = MPI_Wtime();
  for (int k = 0; k < 4 * steps; k++) MUST(gimlet_step(uni, 5e-12, &t, &st));
  MPI_Barrier(MPI_COMM_WORLD);
  wall[1] = MPI_Wtime() - wall[1];
  MUST(gimlet_particle_count(lev, NULL, &np[0]));
  MUST(gimlet_particle_count(uni, NULL, &np[1]));
  int64_t nla, nua;
  Rec *a = finest_region(lev, &nla), *b = finest_region(uni, &nua);
  if (rank_ == 0) {
    /* The uniform run's particles on the lattice of spacing 0.125 um. */
    const double sp = 0.125 * um;
    int mm = 80;
    double *grid = calloc((size_t)mm * mm * 4, 8);
    char *has = calloc((size_t)mm * mm, 1);
    int nu = 0, nl = 0;
    for (int64_t k = 0; k < nua; k++) {
      if (!in_finest(&b[k])) continue;
      nu++;
      int i = (int)lround(b[k].v[0] / sp - 0.5), j = (int)lround((b[k].v[1] - 30 * um) / sp - 0.5);
      if (i < 0 || j < 0 || i >= mm || j >= mm) continue;
      for (int c = 0; c < 4; c++) grid[4 * ((size_t)j * mm + i) + c] = b[k].v[2 + c];
      has[(size_t)j * mm + i] = 1;
    }
    double d2 = 0, s2 = 0, dyy = 0, syy = 0;
    int matched = 0;
    for (int64_t k = 0; k < nla; k++) {
      if (!in_finest(&a[k])) continue;
      nl++;
      double fi = a[k].v[0] / sp - 0.5, fj = (a[k].v[1] - 30 * um) / sp - 0.5;
      int i = (int)lround(fi), j = (int)lround(fj);
      if (i < 0 || j < 0 || i >= mm || j >= mm || !has[(size_t)j * mm + i] || fabs(fi - i) > 1e-6 ||
          fabs(fj - j) > 1e-6)
        continue;
      matched++;
      const double *u = grid + 4 * ((size_t)j * mm + i);
      for (int c = 0; c < 4; c++) {
        double d = a[k].v[2 + c] - u[c];
        d2 += d * d;
        s2 += u[c] * u[c];
      }
      dyy = fmax(dyy, fabs(a[k].v[3] - u[1]));
      syy = fmax(syy, fabs(u[1]));
    }
    double rel = sqrt(d2 / s2);
    printf("pressure indentation, %d coarse steps of 20 ps (load factor %.3f): %d finest-region "
           "particles matched (of %d)\n",
           steps, fmin(1.0, steps / 1500.0), matched, nl);
    printf("  relative L2 stress difference, 3 levels vs uniform 0.25 um: %.3e (bound 2e-2); "
           "max |d s_yy| / max |s_yy| = %.3e (max |s_yy| = %.3e Pa)\n",
           rel, dyy / syy, syy);
    printf("  wall: 3 levels %.2f s (%lld particles), uniform finest %.2f s (%lld particles): "
           "ratio %.3f\n",
           wall[0], (long long)np[0], wall[1], (long long)np[1], wall[0] / wall[1]);
    EXPECT(matched == nu && matched > 0, "%d of the uniform run's %d particles matched", matched, nu);
    EXPECT(rel <= 2e-2, "relative L2 stress difference %.3e above 2e-2", rel);
    free(grid);
    free(has);
  }
  free(a);
  free(b);
  MUST(gimlet_destroy(&lev));
  MUST(gimlet_destroy(&uni));
  return check_end("test_levels_pressure");
}
