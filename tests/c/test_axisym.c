/* The axisymmetric mode through the C API (gimlet_set_geometry), each case
 * against a bound that means something.
 *
 *   test_axisym errors   bad geometries and the calls the mode refuses:
 *                        each gets its status and a message naming the
 *                        argument, and the handle stays usable
 *   test_axisym lame     Lamé's thick-walled cylinder under internal
 *                        pressure, in plane strain along the axis (rollers
 *                        on the top and bottom faces): a = 1, b = 2 m,
 *                        E = 1e7 Pa, nu = 0.3, p = 1e4 Pa ramped over 1 s
 *                        (about 11 periods of the breathing mode) with 5 %
 *                        PIC damping, then held; 16 cells across the wall,
 *                        2 x 2 particles per cell, uGIMP/MUSL, and the
 *                        library's default scheme with `default`. The
 *                        radial displacement of the inner column and the
 *                        hoop stress of the particles averaged over the
 *                        hold must match the closed form
 *                          u_r = p a² (1 + nu) ((1 - 2 nu) r + b²/r) / (E (b² - a²))
 *                          σ_θθ = p a² (1 + b²/r²) / (b² - a²)
 *                        within 1.5 % (u_r at the inner wall) and 1.5 %
 *                        (the hoop stress relative to the closed form at
 *                        each particle more than a cell from the walls,
 *                        averaged over them and the hold). Without
 *                        the hoop stress in the radial force the wall
 *                        would not hold the pressure at all (the kernel's
 *                        unit test `hydrostatic_stress_gives_no_force...`
 *                        shows that term is what balances it).
 *                        `lame plain DIR` also writes an output into DIR:
 *                        its /particles/hoop_stretch equals the field, and
 *                        its XDMF checks against the file.
 *   test_axisym lame_levels  the same cylinder on two levels against its
 *                        uniform finest twin (u_r within 0.5 %), and in 3
 *                        patches per level (identical to round-off)
 *   test_axisym punch|sphere|cone
 *                        the indenters on the axis against the half-space
 *                        closed forms (see `indentation`). NOT in ctest
 *                        yet: on four nested levels the held load depends
 *                        on the loading time (the punch at H = 16 m: 1.072
 *                        of 2aE*h with a 1 s ramp, 1.055 with 2 s, 1.029
 *                        with 4 s; on two levels 1.089 and 1.083), so the
 *                        finite-body extrapolation is not clean (issue 28).
 *                        Knobs for that study: AXI_H (one body height
 *                        only), AXI_T (ramp time factor), AXI_H0 (coarse
 *                        cell), AXI_HF (finest cell), AXI_TRACE, AXI_PLANE
 *                        (the same half model in plane strain). */
#include "scenes.h"
#include <hdf5.h>
#include <sys/stat.h>

static const double E_ = 1e7, NU_ = 0.3, RHO_ = 1000;

static void errors(void) {
  GimletSim *sim = NULL;
  /* A domain left of the axis. */
  MUST(gimlet_create(MPI_COMM_WORLD, -1, 0, 2, 1, 0.25, &sim));
  EXPECT_STATUS(gimlet_set_geometry(sim, GIMLET_AXISYMMETRIC), GIMLET_ERR_INVALID_ARGUMENT, "x0");
  EXPECT_STATUS(gimlet_set_geometry(sim, 7), GIMLET_ERR_INVALID_ARGUMENT, "geometry");
  int g = -1;
  EXPECT_OK(gimlet_get_geometry(sim, &g));
  EXPECT(g == GIMLET_PLANE_STRAIN, "geometry %d after the rejected calls", g);
  gimlet_destroy(&sim);

  MUST(gimlet_create(MPI_COMM_WORLD, 0, 0, 2, 1, 0.25, &sim));
  /* Indenters set up in plane strain: one off the axis, then one on it
   * that moves sideways; the mode is refused for each. */
  int i0 = -1;
  MUST(gimlet_add_indenter_cylinder(sim, 0.5, 0.3, 1.0, &i0));
  EXPECT_STATUS(gimlet_set_geometry(sim, GIMLET_AXISYMMETRIC), GIMLET_ERR_INVALID_STATE, "axis");
  gimlet_destroy(&sim);
  MUST(gimlet_create(MPI_COMM_WORLD, 0, 0, 2, 1, 0.25, &sim));
  MUST(gimlet_add_indenter_cylinder(sim, 0.5, 0.0, 1.0, &i0));
  double t2[2] = {0, 1}, x2[2] = {0, 0.1};
  MUST(gimlet_set_indenter_lateral(sim, i0, 2, t2, x2));
  EXPECT_STATUS(gimlet_set_geometry(sim, GIMLET_AXISYMMETRIC), GIMLET_ERR_INVALID_STATE, "sideways");
  gimlet_destroy(&sim);

  MUST(gimlet_create(MPI_COMM_WORLD, 0, 0, 2, 1, 0.25, &sim));
  /* A thickness first: the mode is then refused. */
  MUST(gimlet_set_thickness(sim, 0.5));
  EXPECT_STATUS(gimlet_set_geometry(sim, GIMLET_AXISYMMETRIC), GIMLET_ERR_INVALID_STATE, "thickness");
  gimlet_destroy(&sim);

  MUST(gimlet_create(MPI_COMM_WORLD, 0, 0, 2, 1, 0.25, &sim));
  EXPECT_OK(gimlet_set_geometry(sim, GIMLET_AXISYMMETRIC));
  EXPECT_OK(gimlet_get_geometry(sim, &g));
  EXPECT(g == GIMLET_AXISYMMETRIC, "geometry %d", g);
  EXPECT_STATUS(gimlet_set_thickness(sim, 2.0), GIMLET_ERR_INVALID_STATE, "thickness");
  int m = -1, ind = -1;
  MUST(gimlet_add_material_linear_elastic(sim, E_, NU_, RHO_, &m));
  /* An indenter off the axis, and one that would move sideways. */
  EXPECT_STATUS(gimlet_add_indenter_wedge(sim, 70.3, 0.5, 0.3, 1.0, &ind), GIMLET_ERR_INVALID_ARGUMENT, "x_tip");
  EXPECT_OK(gimlet_add_indenter_wedge(sim, 70.3, 0.5, 0.0, 1.0, &ind));
  double tt[2] = {0, 1}, xx[2] = {0, 0.1};
  EXPECT_STATUS(gimlet_set_indenter_lateral(sim, ind, 2, tt, xx), GIMLET_ERR_INVALID_ARGUMENT, "sideways");
  /* A particle across the axis (only rank 0 inserts). */
  double x[1] = {0.05}, y[1] = {0.5}, l[1] = {0.1}, v[1] = {0}, rho[1] = {RHO_};
  int mat[1] = {m};
  int64_t n = rank_ == 0 ? 1 : 0;
  EXPECT_STATUS(gimlet_insert_particles(sim, n, x, y, l, l, v, v, NULL, rho, mat), GIMLET_ERR_INVALID_ARGUMENT,
                "axis");
  /* The handle is usable: a particle touching the axis is accepted, and
   * its volume is per radian (4 lpx lpy r). */
  x[0] = 0.1;
  EXPECT_OK(gimlet_insert_particles(sim, n, x, y, l, l, v, v, NULL, rho, mat));
  int64_t np = 0;
  double *vol = field(sim, GIMLET_FIELD_VOLUME0, &np);
  if (np == 1) EXPECT(fabs(vol[0] - 4 * 0.1 * 0.1 * 0.1) < 1e-15, "volume %g, want %g per radian", vol[0], 0.004);
  free(vol);
  /* The diagnostics are the whole body's: the ring's mass 2π ρ 4 lp² r. */
  double mass = 0;
  EXPECT_OK(gimlet_diagnostics(sim, NULL, NULL, NULL, NULL, &mass));
  double ring = 2 * M_PI * RHO_ * 4 * 0.1 * 0.1 * 0.1;
  EXPECT(fabs(mass - ring) < 1e-12 * ring, "mass %.15g, want the ring's %.15g", mass, ring);
  EXPECT_STATUS(gimlet_set_geometry(sim, GIMLET_PLANE_STRAIN), GIMLET_ERR_INVALID_STATE, "insertion");
  gimlet_destroy(&sim);
}

static double u_lame(double p, double a, double b, double r) {
  return p * a * a * (1 + NU_) * ((1 - 2 * NU_) * r + b * b / r) / (E_ * (b * b - a * a));
}

static double hoop_lame(double p, double a, double b, double r) {
  return p * a * a * (1 + b * b / (r * r)) / (b * b - a * a);
}

/* The Lamé run: finest cell h = 1/16; with `levels` 2 the coarse cell is
 * 1/8 and the fine level covers r < 1.5 (the inner half of the wall), all
 * heights; `patches` splits each level into that many patches in x. */
static void lame_run(int default_scheme, int levels, int patches, double *u_out, double *s_out, const char *out_dir);

static int cmp_double(const void *a, const void *b) {
  double x = *(const double *)a, y = *(const double *)b;
  return (x > y) - (x < y);
}

/* The output of an axisymmetric run: its HDF5 file holds F_θθ as
 * /particles/hoop_stretch, the same values as GIMLET_FIELD_HOOP_STRETCH (as
 * sorted lists: the file's row order is the output's), and its XDMF names
 * the dataset among the geometry and the 12 attributes (FLIP: no affine
 * matrices), each checked against the file by gimlet_check_xdmf. */
static void check_hoop_output(GimletSim *sim, const char *dir) {
  MUST(gimlet_output_open(sim, dir, "lame"));
  MUST(gimlet_write_output(sim));
  int64_t step = 0, items = 0, n = 0;
  MUST(gimlet_time(sim, NULL, &step));
  char h5[600], xdmf[600];
  snprintf(h5, sizeof h5, "%s/lame_%06lld.h5", dir, (long long)step);
  snprintf(xdmf, sizeof xdmf, "%s/lame.xdmf", dir);
  MUST(gimlet_check_xdmf(sim, xdmf, &items));
  EXPECT(items == 13, "%lld XDMF data items, want 13 (the geometry and 12 attributes with hoop_stretch)",
         (long long)items);
  double *ft = field(sim, GIMLET_FIELD_HOOP_STRETCH, &n);
  if (size_ == 1) {
    hid_t f = H5Fopen(h5, H5F_ACC_RDONLY, H5P_DEFAULT);
    EXPECT(f >= 0, "cannot open %s", h5);
    double *got = calloc((size_t)n + 1, sizeof *got);
    hid_t d = f >= 0 ? H5Dopen2(f, "/particles/hoop_stretch", H5P_DEFAULT) : -1;
    EXPECT(d >= 0, "%s has no /particles/hoop_stretch", h5);
    hsize_t dims[2] = {0, 0};
    if (d >= 0) {
      hid_t sp = H5Dget_space(d);
      EXPECT(H5Sget_simple_extent_ndims(sp) == 1 && H5Sget_simple_extent_dims(sp, dims, NULL) == 1 &&
                 dims[0] == (hsize_t)n,
             "hoop_stretch has %llu rows, want %lld", (unsigned long long)dims[0], (long long)n);
      H5Sclose(sp);
      if (dims[0] == (hsize_t)n) H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, got);
      H5Dclose(d);
    }
    if (f >= 0) H5Fclose(f);
    qsort(got, (size_t)n, sizeof *got, cmp_double);
    qsort(ft, (size_t)n, sizeof *ft, cmp_double);
    int differ = 0, stretched = 0;
    for (int64_t i = 0; i < n; i++) differ += got[i] != ft[i], stretched += ft[i] > 1;
    EXPECT(differ == 0 && stretched > 0, "hoop_stretch in the file: %d of %lld values differ from the field "
           "(%d stretched)", differ, (long long)n, stretched);
    if (rank_ == 0) printf("lame output: %lld hoop stretches in %s, equal to the field; %lld XDMF items\n",
                           (long long)n, h5, (long long)items);
    free(got);
  }
  free(ft);
}

static void lame_run(int default_scheme, int levels, int patches, double *u_out, double *s_out, const char *out_dir) {
  const double a = 1, b = 2, h = 0.0625, p = 1e4, t_ramp = 1.0, t_end = 1.4;
  const double h0 = levels == 2 ? 2 * h : h, hz = 2 * h0;
  GimletSim *sim = NULL;
  MUST(gimlet_create(MPI_COMM_WORLD, 0, 0, b + 2 * h0, hz, h0, &sim));
  if (levels == 2) {
    double box[4] = {0, 0, 1.5, hz};
    MUST(gimlet_add_level(sim, box, 1));
  }
  if (patches > 1) patches_per_level(sim, patches, 1);
  MUST(gimlet_set_geometry(sim, GIMLET_AXISYMMETRIC));
  int m;
  MUST(gimlet_add_material_linear_elastic(sim, E_, NU_, RHO_, &m));
  MUST(gimlet_set_face_bc(sim, GIMLET_FACE_BOTTOM, GIMLET_BC_ROLLER));
  MUST(gimlet_set_face_bc(sim, GIMLET_FACE_TOP, GIMLET_BC_ROLLER));
  if (!default_scheme) {
    MUST(gimlet_set_shape(sim, GIMLET_SHAPE_UGIMP));
    MUST(gimlet_set_transfer(sim, GIMLET_TRANSFER_FLIP));
    MUST(gimlet_set_flip(sim, 0.95));
  } else {
    /* APIC carries no PIC damping: XPIC's would do, FLIP/PIC keeps it simple. */
    MUST(gimlet_set_transfer(sim, GIMLET_TRANSFER_FLIP));
    MUST(gimlet_set_flip(sim, 0.95));
  }
  MUST(gimlet_fill_rectangle(sim, a, 0, b, hz, 2, m, RHO_, 0, 0, NULL));
  int64_t loaded = 0;
  MUST(gimlet_apply_traction(sim, GIMLET_FACE_LEFT, a, 0, hz, p, 0, &loaded));
  EXPECT(loaded == (int64_t)(2 * hz / h), "%lld particles loaded on the inner wall, want %d", (long long)loaded,
         (int)(2 * hz / h));
  MUST(gimlet_set_load_ramp(sim, t_ramp));
  double dt = 0, t = 0;
  MUST(gimlet_stable_dt(sim, &dt));
  dt *= 0.9;
  int64_t steps = 0;
  double u_sum = 0, s_sum = 0;
  int n_avg = 0;
  double worst_s = 0, ft_err = 0;
  while (t < t_end) {
    MUST(gimlet_step(sim, dt, &t, &steps));
    if (t < t_ramp + 0.1) continue;
    int64_t n = 0;
    double *x = field(sim, GIMLET_FIELD_POSITION, &n);
    double *x0 = field(sim, GIMLET_FIELD_REFERENCE, &n);
    double *sg = field(sim, GIMLET_FIELD_STRESS, &n);
    double *ft = field(sim, GIMLET_FIELD_HOOP_STRETCH, &n);
    double us = 0, ss = 0, se = 0;
    int nu = 0, ns = 0;
    for (int64_t i = 0; i < n; i++) {
      if (x0[2 * i] < a + 0.5 * h) {
        us += (x[2 * i] - x0[2 * i]) / u_lame(p, a, b, x0[2 * i]);
        nu++;
      }
      /* F_θθ integrates v_r/r over the volume, r/R only to O(lp²/r²) and
       * the step's error; the field reports the particle's own value. */
      ft_err = fmax(ft_err, fabs(ft[i] - x[2 * i] / x0[2 * i]) / (x[2 * i] / x0[2 * i] - 1));
      /* The hoop stress away from the two free walls (the GIMP stress of
       * the outer particle columns carries an O(h) error at a free
       * surface, 3-4 % of sigma_tt(a) here). */
      if (x0[2 * i] > a + h && x0[2 * i] < b - h) {
        double e = sg[4 * i + 3] / hoop_lame(p, a, b, x0[2 * i]) - 1;
        ss = fmax(ss, fabs(e));
        se += e;
        ns++;
      }
    }
    /* Sums over ranks: the inner column may live on either. */
    double loc[5] = {us, nu, se, ns, ss}, glob[5];
    MPI_Allreduce(loc, glob, 4, MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    MPI_Allreduce(&loc[4], &glob[4], 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    u_sum += glob[0] / glob[1];
    s_sum += glob[2] / glob[3];
    worst_s = fmax(worst_s, glob[4]);
    n_avg++;
    free(x), free(x0), free(sg), free(ft);
  }
  double u_ratio = u_sum / n_avg, s_err = s_sum / n_avg;
  if (rank_ == 0)
    printf("lame (%s, %d level(s), %d patch(es) per level): u_r(a) / closed form %.5f over %d steps of the hold; "
           "hoop stress (a cell in from the walls): mean relative error %+.4f (largest single value %.4f while "
           "ringing)\n",
           default_scheme ? "default scheme" : "uGIMP/FLIP", levels, patches, u_ratio, n_avg, s_err, worst_s);
  EXPECT(fabs(u_ratio - 1) < 0.015, "u_r at the inner wall %.5f of the closed form (bound 1.5 %%)", u_ratio);
  EXPECT(fabs(s_err) < 0.015, "hoop stress off by %+.4f on average (bound 1.5 %%)", s_err);
  double loc_ft = ft_err;
  MPI_Allreduce(&loc_ft, &ft_err, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
  if (rank_ == 0) printf("lame: F_tt against r/R: largest error %.4f of the hoop strain\n", ft_err);
  EXPECT(ft_err < 0.02, "GIMLET_FIELD_HOOP_STRETCH off r/R by %.4f of the hoop strain (bound 2 %%)", ft_err);
  *u_out = u_ratio;
  *s_out = s_err;
  if (out_dir) check_hoop_output(sim, out_dir);
  gimlet_destroy(&sim);
}

static void lame(int default_scheme, const char *out_dir) {
  double u, s;
  if (out_dir && rank_ == 0) mkdir(out_dir, 0755);
  lame_run(default_scheme, 1, 1, &u, &s, out_dir);
}

/* Two levels (the fine one over the inner half of the wall) against the
 * uniform finest twin, and the same two levels in 3 patches per level: the
 * inner wall's displacement and the hoop stress agree with the twin within
 * 0.5 % (both are within 1.5 % of Lamé), and the patches change nothing
 * beyond round-off. */
static void lame_levels(void) {
  double u1, s1, u2, s2, u3, s3;
  lame_run(0, 1, 1, &u1, &s1, NULL);
  lame_run(0, 2, 1, &u2, &s2, NULL);
  lame_run(0, 2, 3, &u3, &s3, NULL);
  if (rank_ == 0)
    printf("lame levels: u_r(a) 2 levels / uniform finest %.5f; hoop error %+.4f against %+.4f; 3 patches: u_r "
           "differs by %.2e, hoop by %.2e\n",
           u2 / u1, s2, s1, fabs(u3 - u2), fabs(s3 - s2));
  EXPECT(fabs(u2 / u1 - 1) < 0.005, "2 levels give u_r(a) %.5f of the uniform twin's (bound 0.5 %%)", u2 / u1);
  EXPECT(fabs(s2 - s1) < 0.005, "2 levels' hoop error %+.4f against the twin's %+.4f (bound 0.5 %%)", s2, s1);
  EXPECT(fabs(u3 - u2) < 1e-9 && fabs(s3 - s2) < 1e-9, "patches change u_r by %.2e, hoop by %.2e", fabs(u3 - u2),
         fabs(s3 - s2));
}

/* ------------------------------------------------------------ indentation */

enum { IND_PUNCH, IND_SPHERE, IND_CONE };
static const char *ind_name[] = {"flat cylindrical punch", "sphere", "cone"};

/* An elastic cylinder of radius and height `H` (bottom on rollers, the side
 * free) under an indenter on the axis, pressed to `depth` by a smooth ramp
 * over 1 s (7 wave transits of H = 16 m), then held 0.5 s: nested levels
 * halve the cell from H/16 down to 1/8 m (8 cells across a contact radius
 * of 1 m) in boxes of radius and depth H/2^l at the axis. uGIMP, MUSL,
 * FLIP with 5 % PIC to calm the ringing. Returns the whole body's load
 * (gimlet_indenter_state, 2π per radian) averaged over the hold. */
static double indent(int shape, double size, double depth, double H) {
  const double hf = getenv("AXI_HF") ? atof(getenv("AXI_HF")) : 0.125, room = 2, t_ramp = H / 16 * (getenv("AXI_T") ? atof(getenv("AXI_T")) : 1), t_hold = t_ramp / 2 * (getenv("AXI_HOLD") ? atof(getenv("AXI_HOLD")) : 1);
  const double h0 = getenv("AXI_H0") ? atof(getenv("AXI_H0")) : 1;
  int levels = 1 + (int)lround(log2(h0 / hf));
  GimletSim *sim = NULL;
  /* AXI_FULL (with AXI_PLANE): the whole body, the punch in the middle. */
  const double xc = getenv("AXI_FULL") ? H : 0;
  MUST(gimlet_create(MPI_COMM_WORLD, 0, 0, H + xc, H + room, h0, &sim));
  for (int l = 1; l < levels; l++) {
    double r = 16.0 * h0 / (1 << l) * (getenv("AXI_BOX") ? atof(getenv("AXI_BOX")) : 1);
    double box[4] = {xc > 0 ? xc - r : 0, H - r, xc + r, H + room};
    MUST(gimlet_add_level(sim, box, 1));
  }
  /* AXI_PLANE: the same scene in plane strain (the half model, x = 0 a
   * symmetry plane), for comparing the levels' behaviour. */
  if (getenv("AXI_PLANE")) {
    if (!xc) MUST(gimlet_set_face_bc(sim, GIMLET_FACE_LEFT, GIMLET_BC_ROLLER));
  }
  else
    MUST(gimlet_set_geometry(sim, GIMLET_AXISYMMETRIC));
  int m, ind;
  MUST(gimlet_add_material_linear_elastic(sim, E_, NU_, RHO_, &m));
  MUST(gimlet_set_face_bc(sim, GIMLET_FACE_BOTTOM, GIMLET_BC_ROLLER));
  if (!getenv("AXI_DEFAULT")) {
    MUST(gimlet_set_shape(sim, GIMLET_SHAPE_UGIMP));
    MUST(gimlet_set_scheme(sim, GIMLET_SCHEME_MUSL));
    MUST(gimlet_set_transfer(sim, GIMLET_TRANSFER_FLIP));
    MUST(gimlet_set_flip(sim, 0.95));
  }
  MUST(gimlet_fill_rectangle(sim, 0, 0, H + xc, H, 2, m, RHO_, 0, 0, NULL));
  ind = -1;
  if (getenv("AXI_TRACTION")) {
    int64_t nl = 0;
    MUST(gimlet_apply_traction(sim, GIMLET_FACE_TOP, H, xc - size, xc + size, 0, -atof(getenv("AXI_TRACTION")), &nl));
    MUST(gimlet_set_load_ramp(sim, t_ramp));
  } else if (shape == IND_PUNCH)
    MUST(gimlet_add_indenter_flat_punch(sim, size, 0, room / 2, xc, H, &ind));
  else if (shape == IND_SPHERE)
    MUST(gimlet_add_indenter_cylinder(sim, size, 0, H, &ind));
  else
    MUST(gimlet_add_indenter_wedge(sim, size, room / 2, 0, H, &ind));
  enum { KN = 33 };
  double tt[KN], dd[KN];
  for (int i = 0; i < KN; i++) {
    double q = (double)i / (KN - 1);
    tt[i] = q * t_ramp;
    dd[i] = depth * (q - sin(2 * M_PI * q) / (2 * M_PI));
  }
  if (ind >= 0) MUST(gimlet_set_indenter_motion(sim, ind, GIMLET_MOTION_DEPTH, KN, tt, dd));
  double dt = 0, t = 0, acc = 0;
  MUST(gimlet_stable_dt(sim, &dt));
  dt *= getenv("AXI_CFL") ? atof(getenv("AXI_CFL")) : 0.5;
  int n = 0;
  while (t < t_ramp + t_hold) {
    MUST(gimlet_step(sim, dt, &t, NULL));
    if (getenv("AXI_TRACE") && rank_ == 0) {
      static int k = 0;
      if (k++ % (getenv("AXI_EVERY") ? atoi(getenv("AXI_EVERY")) : 200) == 0) {
        double f[2] = {0, 0}, d = 0;
        if (ind >= 0) MUST(gimlet_indenter_state(sim, ind, &d, NULL, f, NULL));
        double ke, se, py;
        MUST(gimlet_diagnostics(sim, &ke, &se, NULL, &py, NULL));
        int64_t np = 0;
        double *x = field(sim, GIMLET_FIELD_POSITION, &np), *x0 = field(sim, GIMLET_FIELD_REFERENCE, &np);
        double us = 0;
        int nu = 0;
        for (int64_t i = 0; i < np; i++)
          if (x0[2 * i + 1] > H - 0.25 && fabs(x0[2 * i] - xc) < size) us += x[2 * i + 1] - x0[2 * i + 1], nu++;
        free(x), free(x0);
        printf("t %.4f depth %.6f force %.6g kinetic %.4g strain %.6g momentum_y %.4g uy %.6g\n", t, d, f[1], ke, se, py,
               us / (nu ? nu : 1));
      }
    }
    if (getenv("AXI_DUMP")) {
      static int kd = 0;
      double every = atof(getenv("AXI_DUMP"));
      if (t >= kd * every) {
        char name[64];
        snprintf(name, sizeof name, "/tmp/drift/dump_%d.txt", kd++);
        FILE *fp = fopen(name, "w");
        int64_t np = 0;
        double *x = field(sim, GIMLET_FIELD_POSITION, &np), *x0 = field(sim, GIMLET_FIELD_REFERENCE, &np);
        double *v = field(sim, GIMLET_FIELD_VELOCITY, &np), *sg = field(sim, GIMLET_FIELD_STRESS, &np);
        double *lv = field(sim, GIMLET_FIELD_LEVEL, &np), *ms = field(sim, GIMLET_FIELD_MASS, &np);
        for (int64_t i = 0; i < np; i++)
          fprintf(fp, "%.9g %.9g %.12g %.12g %.6g %.6g %.8g %.8g %.8g %.8g %g %g\n", x0[2 * i], x0[2 * i + 1], x[2 * i],
                  x[2 * i + 1], v[2 * i], v[2 * i + 1], sg[4 * i], sg[4 * i + 1], sg[4 * i + 2], sg[4 * i + 3], lv[i],
                  ms[i]);
        fclose(fp);
        free(x), free(x0), free(v), free(sg), free(lv), free(ms);
      }
    }
    if (t <= t_ramp + 0.5 * t_hold) continue;
    double f[2] = {0, 0};
    if (ind >= 0) MUST(gimlet_indenter_state(sim, ind, NULL, NULL, f, NULL));
    acc += f[1];
    n++;
  }
  gimlet_destroy(&sim);
  return acc / n;
}

/* Against the half-space's closed forms (E* = E/(1 - nu²)):
 *   punch: P = 2 a E* h (a = 1 m, h = 5 mm);
 *   sphere: P = (4/3) E* R^1/2 h^3/2 (R = 10 m, h = 0.1 m: a = 1 m);
 *   cone: Sneddon's P = (2/π) E* tan ψ h² (ψ = 70.3°, h = 0.5 m).
 * The body is finite (H = 16 m and 32 m, 16 and 32 contact radii); its
 * extra stiffness falls as a/H, so the half-space load is the two runs'
 * extrapolation in a/H, 2 P(32) - P(16). */
static void indentation(int shape) {
  double es = E_ / (1 - NU_ * NU_), size, depth, ref;
  if (shape == IND_PUNCH)
    size = 1, depth = 0.005, ref = 2 * size * es * depth;
  else if (shape == IND_SPHERE)
    size = 10, depth = 0.1, ref = 4.0 / 3.0 * es * sqrt(size) * pow(depth, 1.5);
  else
    size = 70.3, depth = 0.5, ref = 2 / M_PI * es * tan(size * M_PI / 180) * depth * depth;
  if (getenv("AXI_H")) {
    double hh = atof(getenv("AXI_H"));
    double p = indent(shape, size, depth, hh);
    if (rank_ == 0) printf("%s: H = %g m: %.4f\n", ind_name[shape], hh, p / ref);
    return;
  }
  double p16 = indent(shape, size, depth, 16), p32 = indent(shape, size, depth, 32);
  double pinf = 2 * p32 - p16;
  if (rank_ == 0)
    printf("%s: load / half-space closed form: H = 16 m %.4f, H = 32 m %.4f, extrapolated %.4f\n", ind_name[shape],
           p16 / ref, p32 / ref, pinf / ref);
  EXPECT(p16 > p32 && p32 > 0, "the larger body must be softer: P(16) %.6g, P(32) %.6g", p16, p32);
  EXPECT(fabs(pinf / ref - 1) < 0.03, "%s: extrapolated load %.4f of the closed form (bound 3 %%)", ind_name[shape],
         pinf / ref);
}

int main(int argc, char **argv) {
  check_begin(&argc, &argv);
  const char *what = argc > 1 ? argv[1] : "errors";
  if (!strcmp(what, "errors"))
    errors();
  else if (!strcmp(what, "lame"))
    lame(argc > 2 && !strcmp(argv[2], "default"), argc > 3 ? argv[3] : NULL);
  else if (!strcmp(what, "lame_levels"))
    lame_levels();
  else if (!strcmp(what, "punch"))
    indentation(IND_PUNCH);
  else if (!strcmp(what, "sphere"))
    indentation(IND_SPHERE);
  else if (!strcmp(what, "cone"))
    indentation(IND_CONE);
  else
    EXPECT(0, "unknown case %s", what);
  return check_end("test_axisym");
}
