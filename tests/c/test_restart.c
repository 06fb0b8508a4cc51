/* Checkpoint and restart through the C ABI.
 *
 *   test_restart same    SCENE STEPS DIR   (any number of ranks)
 *   test_restart write   SCENE STEPS DIR   (the reference run, e.g. 1 rank)
 *   test_restart compare SCENE STEPS DIR   (another number of ranks)
 *
 * "same": run STEPS steps with a checkpoint at STEPS/2; a new handle made
 * from the checkpoint, and an existing handle that reads it, both continue
 * to STEPS and must match the uninterrupted run bitwise (positions and
 * stresses by id, time, step count); the CSV series continued after the
 * restart must equal the uninterrupted one byte for byte. Then rejected
 * files (missing, a text file, a truncated copy, an output file, a
 * directory) must each give GIMLET_ERR_IO with a message naming the path,
 * leave the handle's state bitwise unchanged, and the handle must still
 * step exactly like the restarted one.
 *
 * "write" runs the same scene, writes the checkpoint at STEPS/2 to
 * DIR/SCENE.ckpt.h5 and the reference state at STEPS (and the step size) to
 * DIR/SCENE.ref; "compare" restarts that checkpoint on its own number of
 * ranks, runs to STEPS and compares with the reference: relative 1e-12
 * (position error over the largest coordinate, stress error over the
 * largest stress component).
 *
 * Scenes (as in rank_invariance.c, 2 x 2 patches): "plate" (vibrating
 * plate, particles cross patch boundaries), "pressure" (the paper's
 * surface-pressure indentation of silicon, ramped load), "levels" (two
 * levels) and "plastic" (the plate with J2 power-law plasticity: it yields
 * in the first steps and reaches several % plastic strain, so the
 * equivalent plastic strain, compared with the positions and stresses, is
 * part of the restarted state), and "indent" (a wedge pushed into a block
 * on two levels, with a contact option set: the indenter, its prescribed
 * motion and the option are part of the restarted state; "indent_friction"
 * adds a friction coefficient, a sideways motion and a friction option;
 * "indent_axisym" is the same block in axisymmetry, a cone on the axis,
 * with the hoop stretches compared too). A scene name with the suffix
 * "_flip"
 * (levels_flip) runs it with uGIMP weights and the FLIP transfer instead
 * of the library's defaults (cpGIMP, APIC). */
#include <sys/stat.h>
#include "scenes.h"

/* The values gathered: position, stress, equivalent plastic strain and
 * the hoop stretch (1 in plane strain). */
static const int fields[4] = {GIMLET_FIELD_POSITION, GIMLET_FIELD_STRESS, GIMLET_FIELD_PLASTIC_STRAIN,
                              GIMLET_FIELD_HOOP_STRETCH};
enum { V_EPS_P = 6 };

static Rec *gather_state(GimletSim *sim, int64_t *n) {
  return gather(sim, MPI_COMM_WORLD, fields, 4, n);
}

/* Builds the scene on MPI_COMM_WORLD with 2 x 2 patches; returns the fixed
 * step size. A scene named NAME_flip is NAME with the paper's uGIMP
 * weights and the FLIP transfer instead of the library's defaults (cpGIMP,
 * APIC, whose affine matrices and run setting are then part of the
 * restarted state). */
/* Whether the first `len` characters of `scene` are exactly `name`. */
static int scene_is(const char *scene, size_t len, const char *name) {
  return strlen(name) == len && !strncmp(scene, name, len);
}

static double setup(GimletSim **sim, const char *scene) {
  size_t len = strlen(scene);
  Weights w = len > 5 && strcmp(scene + len - 5, "_flip") == 0 ? UGIMP_FLIP : WEIGHTS_DEFAULT;
  if (w == UGIMP_FLIP) len -= 5;
  if (scene_is(scene, len, "plate") || scene_is(scene, len, "plastic"))
    return plate_scene(sim, 16, 16, scene_is(scene, len, "plastic"), w);
  if (scene_is(scene, len, "pressure")) return pressure_scene(sim, MPI_COMM_WORLD, 1e-6, 1, 20, 20, w);
  if (scene_is(scene, len, "indent") || scene_is(scene, len, "indent_friction") ||
      scene_is(scene, len, "indent_axisym")) {
    /* A wedge pushed at 1 m/s into an elastic block on two levels, with a
     * contact option off its default: the indenter, its motion and the
     * option are part of the restarted state (contact from the first
     * step; about 30 particles in contact by step 40). */
    Block b = block_defaults();
    b.levels = 2, b.px = 2, b.py = 2, b.shape = SHAPE_WEDGE, b.size = 60.0, b.weights = w;
    /* indent_axisym: the same as a cone in axisymmetry (the geometry and
     * the hoop stretches are part of the restarted state). */
    b.axisym = scene_is(scene, len, "indent_axisym");
    int ind;
    *sim = block_build(&b, &ind);
    const double t[2] = {0, 1}, v[2] = {1, 1};
    MUST(gimlet_set_indenter_motion(*sim, ind, GIMLET_MOTION_VELOCITY, 2, t, v));
    MUST(gimlet_set_contact_option(*sim, GIMLET_CONTACT_GAP, 2));
    if (scene_is(scene, len, "indent_friction")) {
      /* Friction and a sideways motion are part of the restarted state. */
      const double tl[2] = {0, 1}, xl[2] = {0, 0.2};
      MUST(gimlet_set_indenter_friction(*sim, ind, 0.3));
      MUST(gimlet_set_indenter_lateral(*sim, ind, 2, tl, xl));
      MUST(gimlet_set_contact_option(*sim, GIMLET_CONTACT_FRICTION_TOL, 1e-10));
    }
    double dt;
    MUST(gimlet_stable_dt(*sim, &dt));
    return 0.8 * dt;
  }
  if (!scene_is(scene, len, "levels")) {
    if (rank_ == 0)
      fprintf(stderr, "unknown scene '%s' (plate, plastic, pressure, levels, indent, indent_friction or indent_axisym, or NAME_flip)\n", scene);
    MPI_Abort(MPI_COMM_WORLD, 2);
  }
  /* Two levels: a refined square in the middle of a block that is pushed
   * against a roller wall and loaded on top. */
  const double L = 1.0, h = L / 16, E = 1e4, nu = 0.3, rho = 1.0;
  MUST(gimlet_create(MPI_COMM_WORLD, 0, 0, L, L, h, sim));
  double box[4] = {6 * h, 6 * h, 10 * h, 10 * h};
  MUST(gimlet_add_level(*sim, box, 1));
  MUST(gimlet_set_patch_size(*sim, 0, 8, 8));
  MUST(gimlet_set_patch_size(*sim, 1, 8, 8));
  int m;
  MUST(gimlet_add_material_neo_hookean(*sim, E, nu, rho, &m));
  MUST(gimlet_set_face_bc(*sim, GIMLET_FACE_RIGHT, GIMLET_BC_ROLLER));
  MUST(gimlet_set_face_bc(*sim, GIMLET_FACE_BOTTOM, GIMLET_BC_ROLLER));
  MUST(gimlet_fill_rectangle(*sim, 0, 0, L, 14 * h, 2, m, rho, 5.0, 0, NULL));
  int64_t loaded = 0;
  MUST(gimlet_apply_traction(*sim, GIMLET_FACE_TOP, 14 * h, 4 * h, 12 * h, 0, -50.0, &loaded));
  weights_set(*sim, w);
  double dt;
  MUST(gimlet_stable_dt(*sim, &dt));
  return 0.8 * dt;
}

/* Rank 0: bitwise equality of two gathered states (ids, then every value). */
static int same_bits(const Rec *a, int64_t na, const Rec *b, int64_t nb, const char *what) {
  if (rank_ != 0) return 1;
  if (na != nb) {
    fprintf(stderr, "%s: %lld particles vs %lld\n", what, (long long)na, (long long)nb);
    return 0;
  }
  int64_t differ = 0, first = -1;
  for (int64_t i = 0; i < na; i++)
    if (a[i].id != b[i].id || memcmp(a[i].v, b[i].v, sizeof a[i].v) != 0) {
      if (first < 0) first = i;
      differ++;
    }
  if (differ) {
    fprintf(stderr, "%s: %lld of %lld particles differ (first: id %llu vs %llu, x %.17g vs %.17g, sxx %.17g vs %.17g, eps_p %.17g vs %.17g)\n",
            what, (long long)differ, (long long)na, (unsigned long long)a[first].id,
            (unsigned long long)b[first].id, a[first].v[0], b[first].v[0], a[first].v[2], b[first].v[2],
            a[first].v[V_EPS_P], b[first].v[V_EPS_P]);
    return 0;
  }
  double epmax = 0;
  int64_t plastic = 0;
  for (int64_t i = 0; i < na; i++) {
    epmax = fmax(epmax, a[i].v[V_EPS_P]);
    plastic += a[i].v[V_EPS_P] > 0;
  }
  printf("%s: %lld particles bitwise equal (positions, stresses, plastic strains, hoop stretches; %lld yielded, max eps_p %.4g)\n",
         what, (long long)na, (long long)plastic, epmax);
  return 1;
}

/* The same result on every rank for a check made on rank 0. */
static int on_all(int ok) {
  MPI_Bcast(&ok, 1, MPI_INT, 0, MPI_COMM_WORLD);
  return ok;
}

static char *slurp(const char *path, long *len) {
  FILE *f = fopen(path, "rb");
  if (!f) return NULL;
  fseek(f, 0, SEEK_END);
  *len = ftell(f);
  fseek(f, 0, SEEK_SET);
  char *b = malloc(*len + 1);
  if (fread(b, 1, *len, f) != (size_t)*len) { free(b); b = NULL; }
  else b[*len] = 0;
  fclose(f);
  return b;
}

static int spit(const char *path, const char *b, long len) {
  FILE *f = fopen(path, "wb");
  if (!f) return 0;
  int ok = fwrite(b, 1, len, f) == (size_t)len;
  return fclose(f) == 0 && ok;
}

/* Compares two CSV texts: the same header and number of lines, the same
 * time and step columns, other values within *rel (returned: the largest
 * difference relative to each column's largest magnitude). */
static int csv_close(const char *a, const char *b, int *lines, double *rel) {
  *lines = 0;
  *rel = 0;
  if (!a || !b) return 0;
  const char *ea = strchr(a, '\n'), *eb = strchr(b, '\n');
  if (!ea || !eb || ea - a != eb - b || strncmp(a, b, ea - a) != 0) return 0;
  double diff[64] = {0}, scale[64] = {0};
  int ncol = 0, ok = 1;
  *lines = 1;
  const char *pa = ea + 1, *pb = eb + 1;
  while (*pa && *pb && ok) {
    for (int c = 0; c < 64; c++) {
      char *na, *nb;
      double va = strtod(pa, &na), vb = strtod(pb, &nb);
      if (na == pa || nb == pb) { ok = 0; break; }
      if (c < 2 && va != vb) ok = 0;
      if (!isnan(va) || !isnan(vb)) {
        diff[c] = fmax(diff[c], fabs(va - vb));
        scale[c] = fmax(scale[c], fmax(fabs(va), fabs(vb)));
      }
      if (c + 1 > ncol) ncol = c + 1;
      pa = na; pb = nb;
      if (*pa != *pb) { ok = 0; break; }
      if (*pa == '\n') { pa++; pb++; break; }
      pa++; pb++;
    }
    ++*lines;
  }
  if (*pa || *pb) ok = 0;
  for (int c = 0; c < ncol; c++)
    if (scale[c] > 0) *rel = fmax(*rel, diff[c] / scale[c]);
  return ok;
}

static void run_steps(GimletSim *sim, double dt, int n, int csv) {
  for (int s = 0; s < n; s++) {
    MUST(gimlet_step(sim, dt, NULL, NULL));
    if (csv) MUST(gimlet_csv_append(sim));
  }
}

/* Expects `path` to be rejected by gimlet_read_checkpoint on `sim` with
 * GIMLET_ERR_IO, a message naming the path (and `word` when non-NULL), and
 * the state unchanged (compared with `ref`). */
static void expect_rejected(GimletSim *sim, const char *path, const char *word, const Rec *ref,
                            int64_t nref, const char *what) {
  double t0, t1;
  int64_t s0, s1;
  MUST(gimlet_time(sim, &t0, &s0));
  EXPECT_STATUS(gimlet_read_checkpoint(sim, path), GIMLET_ERR_IO, path);
  if (word) EXPECT_TRUE(message_names(word));
  if (rank_ == 0) printf("rejected %s: %s\n", what, last_error());
  MUST(gimlet_time(sim, &t1, &s1));
  EXPECT_TRUE(t0 == t1 && s0 == s1);
  int64_t n;
  Rec *now = gather_state(sim, &n);
  EXPECT_TRUE(on_all(same_bits(ref, nref, now, n, what)));
  free(now);
}

static int mode_same(const char *scene, int steps, const char *dir) {
  char ckpt[512], csv_a[512], csv_b[512];
  snprintf(ckpt, sizeof ckpt, "%s/%s_n%d.ckpt.h5", dir, scene, size_);
  snprintf(csv_a, sizeof csv_a, "%s/%s_n%d_a.csv", dir, scene, size_);
  snprintf(csv_b, sizeof csv_b, "%s/%s_n%d_b.csv", dir, scene, size_);
  int half = steps / 2;

  char out_dir[512], xdmf[600];
  snprintf(out_dir, sizeof out_dir, "%s/%s_n%d_output", dir, scene, size_);
  snprintf(xdmf, sizeof xdmf, "%s/snap.xdmf", out_dir);

  /* A: the uninterrupted run, checkpoint at half; outputs at half, half + 1
   * and the end. */
  GimletSim *a = NULL;
  double dt = setup(&a, scene);
  MUST(gimlet_csv_open(a, csv_a));
  MUST(gimlet_output_open(a, out_dir, "snap"));
  MUST(gimlet_csv_append(a));
  run_steps(a, dt, half, 1);
  double t_half;
  int64_t s_half;
  MUST(gimlet_time(a, &t_half, &s_half));
  MUST(gimlet_write_output(a));
  MUST(gimlet_write_checkpoint(a, ckpt));
  run_steps(a, dt, 1, 1);
  MUST(gimlet_write_output(a));
  run_steps(a, dt, steps - half - 1, 1);
  MUST(gimlet_write_output(a));
  int64_t crossings = 0, na;
  MUST(gimlet_patch_crossings(a, &crossings));
  double ta;
  int64_t sa;
  MUST(gimlet_time(a, &ta, &sa));
  Rec *ra = gather_state(a, &na);
  if (rank_ == 0)
    printf("%s, %d ranks: %lld particles, %d steps of %.6g, checkpoint at step %lld, %lld patch crossings\n",
           scene, size_, (long long)na, steps, dt, (long long)s_half, (long long)crossings);
  if (rank_ == 0 && strcmp(scene, "plastic") == 0) {
    /* The restarted state must carry plastic strain: most of the plate
     * has yielded, by several %. */
    int64_t plastic = 0;
    double epmax = 0;
    for (int64_t i = 0; i < na; i++) {
      plastic += ra[i].v[V_EPS_P] > 0;
      epmax = fmax(epmax, ra[i].v[V_EPS_P]);
    }
    EXPECT_TRUE(plastic > na / 2 && epmax > 0.01);
  }

  /* B: a new handle from the checkpoint, continuing the CSV series of a
   * copy of A's file (rows after the checkpoint must be dropped). */
  if (rank_ == 0) {
    long len = 0;
    char *text = slurp(csv_a, &len);
    EXPECT_TRUE(text != NULL && spit(csv_b, text, len));
    free(text);
  }
  MPI_Barrier(MPI_COMM_WORLD);
  GimletSim *b = NULL;
  MUST(gimlet_create_from_checkpoint(MPI_COMM_WORLD, ckpt, &b));
  double tb;
  int64_t sb;
  MUST(gimlet_time(b, &tb, &sb));
  EXPECT_TRUE(tb == t_half && sb == s_half);
  MUST(gimlet_csv_open(b, csv_b));
  MUST(gimlet_output_open(b, out_dir, "snap"));
  run_steps(b, dt, steps - half, 1);
  /* The continued series lists the outputs up to the checkpoint (half) and
   * B's own (the end), not A's output at half + 1. */
  MUST(gimlet_write_output(b));
  int64_t items = 0;
  MUST(gimlet_check_xdmf(b, xdmf, &items));
  /* Two outputs, each the geometry and 11 attributes; with the default
   * affine transfer also the APIC matrices, in axisymmetry the hoop
   * stretches (the series rebuilt from the files written before the
   * checkpoint keeps them). */
  size_t sl = strlen(scene);
  const int apic = !(sl > 5 && strcmp(scene + sl - 5, "_flip") == 0);
  int geometry = GIMLET_PLANE_STRAIN;
  MUST(gimlet_get_geometry(b, &geometry));
  const int64_t want = 24 + (apic ? 2 : 0) + (geometry == GIMLET_AXISYMMETRIC ? 2 : 0);
  EXPECT(items == want, "%lld XDMF items, want %lld", (long long)items, (long long)want);
  if (rank_ == 0) {
    long len = 0;
    char *x = slurp(xdmf, &len), name[64];
    int times = 0, listed = 0;
    for (const char *q = x; q && (q = strstr(q, "<Time ")) != NULL; q++) times++;
    for (int k = 0; k < 3; k++) {
      long st = k == 0 ? half : k == 1 ? half + 1 : steps;
      snprintf(name, sizeof name, "snap_%06ld.h5:/particles/position", st);
      listed |= (x && strstr(x, name) != NULL) << k;
    }
    printf("output series continued after restart: %d outputs listed (steps %d, %d), %lld XDMF items checked\n",
           times, half, steps, (long long)items);
    EXPECT_TRUE(times == 2 && listed == 5);
    free(x);
  }
  MUST(gimlet_time(b, &tb, &sb));
  EXPECT_TRUE(tb == ta && sb == sa);
  int64_t nb, cb = 0;
  MUST(gimlet_patch_crossings(b, &cb));
  EXPECT_TRUE(cb == crossings);
  Rec *rb = gather_state(b, &nb);
  EXPECT_TRUE(on_all(same_bits(ra, na, rb, nb, "new handle from the checkpoint vs uninterrupted")));
  if (rank_ == 0) {
    long la = 0, lb = 0;
    char *ta_ = slurp(csv_a, &la), *tb_ = slurp(csv_b, &lb);
    double rel = 0;
    int rows = 0, ok = csv_close(ta_, tb_, &rows, &rel);
    int identical = ta_ && tb_ && la == lb && memcmp(ta_, tb_, la) == 0;
    printf("CSV continued after restart: %d lines, %s, max relative difference %.3e\n", rows,
           identical ? "byte-identical" : "not byte-identical", rel);
    /* Global sums depend on which rank holds which patch (the order of the
     * partial sums); on one rank that order is fixed, so the files match
     * byte for byte. */
    EXPECT_TRUE(ok && rows == steps + 2 && rel <= 1e-12);
    if (size_ == 1) EXPECT_TRUE(identical);
    free(ta_); free(tb_);
  }

  /* C: an existing handle (a fresh scene at step 0) reads the checkpoint. */
  GimletSim *c = NULL;
  setup(&c, scene);
  MUST(gimlet_step(c, dt, NULL, NULL));
  MUST(gimlet_read_checkpoint(c, ckpt));
  double tc;
  int64_t sc, nc;
  MUST(gimlet_time(c, &tc, &sc));
  EXPECT_TRUE(tc == t_half && sc == s_half);
  run_steps(c, dt, steps - half, 0);
  Rec *rc = gather_state(c, &nc);
  EXPECT_TRUE(on_all(same_bits(ra, na, rc, nc, "existing handle after gimlet_read_checkpoint vs uninterrupted")));

  /* Rejections on A: the state stays, the handle keeps working. */
  char text[512], cut[512], out_file[600], missing[512];
  snprintf(text, sizeof text, "%s/%s_n%d_notes.txt", dir, scene, size_);
  snprintf(cut, sizeof cut, "%s/%s_n%d_truncated.h5", dir, scene, size_);
  snprintf(out_file, sizeof out_file, "%s/snap_%06lld.h5", out_dir, (long long)sa);
  snprintf(missing, sizeof missing, "%s/%s_n%d_absent.h5", dir, scene, size_);
  if (rank_ == 0) {
    const char *notes = "time,force\n0,1\n";
    EXPECT_TRUE(spit(text, notes, (long)strlen(notes)));
    long len = 0;
    char *bytes = slurp(ckpt, &len);
    EXPECT_TRUE(bytes != NULL && spit(cut, bytes, len / 2));
    free(bytes);
  }
  MPI_Barrier(MPI_COMM_WORLD);
  expect_rejected(a, missing, "no such file", ra, na, "a missing file");
  expect_rejected(a, text, "not an HDF5 file", ra, na, "a text file");
  expect_rejected(a, cut, "truncated", ra, na, "a truncated checkpoint");
  expect_rejected(a, out_file, "gimlet-output", ra, na, "an output file");
  expect_rejected(a, dir, "directory", ra, na, "a directory");
  /* A still steps exactly like the restarted handle B. */
  MUST(gimlet_step(a, dt, NULL, NULL));
  MUST(gimlet_step(b, dt, NULL, NULL));
  Rec *ra2 = gather_state(a, &na), *rb2 = gather_state(b, &nb);
  EXPECT_TRUE(on_all(same_bits(ra2, na, rb2, nb, "handle after the rejections vs restarted, one more step")));

  free(ra); free(rb); free(rc); free(ra2); free(rb2);
  MUST(gimlet_destroy(&a));
  MUST(gimlet_destroy(&b));
  MUST(gimlet_destroy(&c));
  return 0;
}

static void paths(char *ckpt, char *ref, size_t len, const char *dir, const char *scene) {
  snprintf(ckpt, len, "%s/%s.ckpt.h5", dir, scene);
  snprintf(ref, len, "%s/%s.ref", dir, scene);
}

static int mode_write(const char *scene, int steps, const char *dir) {
  char ckpt[512], ref[512];
  paths(ckpt, ref, sizeof ckpt, dir, scene);
  GimletSim *a = NULL;
  double dt = setup(&a, scene);
  run_steps(a, dt, steps / 2, 0);
  MUST(gimlet_write_checkpoint(a, ckpt));
  run_steps(a, dt, steps - steps / 2, 0);
  int64_t n;
  Rec *r = gather_state(a, &n);
  if (rank_ == 0) {
    FILE *f = fopen(ref, "wb");
    int ok = f && fwrite(&dt, 8, 1, f) == 1 && fwrite(&n, 8, 1, f) == 1 &&
             fwrite(r, sizeof(Rec), n, f) == (size_t)n;
    if (f) ok = (fclose(f) == 0) && ok;
    EXPECT_TRUE(ok);
    printf("%s: %d ranks wrote checkpoint %s at step %d and reference %s (%lld particles, step %d)\n",
           scene, size_, ckpt, steps / 2, ref, (long long)n, steps);
  }
  free(r);
  MUST(gimlet_destroy(&a));
  return 0;
}

static int mode_compare(const char *scene, int steps, const char *dir) {
  char ckpt[512], ref[512];
  paths(ckpt, ref, sizeof ckpt, dir, scene);
  double dt = 0;
  int64_t nref = -1;
  Rec *r = NULL;
  if (rank_ == 0) {
    FILE *f = fopen(ref, "rb");
    if (f && fread(&dt, 8, 1, f) == 1 && fread(&nref, 8, 1, f) == 1 && nref >= 0) {
      r = malloc(sizeof(Rec) * (nref + 1));
      if (fread(r, sizeof(Rec), nref, f) != (size_t)nref) nref = -1;
    }
    if (f) fclose(f);
    if (nref < 0) fprintf(stderr, "reference %s is missing or short: run mode write first\n", ref);
  }
  MPI_Bcast(&dt, 1, MPI_DOUBLE, 0, MPI_COMM_WORLD);
  MPI_Bcast(&nref, 1, MPI_INT64_T, 0, MPI_COMM_WORLD);
  if (nref < 0) { g_failures++; return 1; }
  GimletSim *b = NULL;
  MUST(gimlet_create_from_checkpoint(MPI_COMM_WORLD, ckpt, &b));
  int64_t s0;
  MUST(gimlet_time(b, NULL, &s0));
  run_steps(b, dt, steps - (int)s0, 0);
  int64_t n;
  Rec *now = gather_state(b, &n);
  if (rank_ == 0) {
    double ep = 1, es = 1, diff[7], scale[7];
    int same = pos_stress_diff(r, nref, now, n, &ep, &es) && rec_diff(r, nref, now, n, 7, diff, scale);
    double eps_p = diff[V_EPS_P] / (scale[V_EPS_P] > 0 ? scale[V_EPS_P] : 1);
    printf("%s: restarted on %d ranks, %lld particles at step %d: max |dx| / position scale = %.3e, max |dsigma| / "
           "stress scale = %.3e, max |d eps_p| / largest eps_p (%.3g) = %.3e\n",
           scene, size_, (long long)n, steps, ep, es, scale[V_EPS_P], eps_p);
    EXPECT(same, "the restarted run has other particles than the reference");
    EXPECT(ep <= 1e-12 && es <= 1e-12 && eps_p <= 1e-12, "differences above 1e-12 relative");
    if (strcmp(scene, "plastic") == 0) EXPECT(scale[V_EPS_P] > 0.01, "the plate did not yield");
  }
  free(r); free(now);
  MUST(gimlet_destroy(&b));
  return 0;
}

int main(int argc, char **argv) {
  check_begin(&argc, &argv);
  if (argc != 5 || atoi(argv[3]) < 2) {
    if (rank_ == 0) fprintf(stderr, "usage: %s same|write|compare plate|plastic|pressure|levels STEPS>=2 DIR\n", argv[0]);
    MPI_Finalize();
    return 2;
  }
  const char *mode = argv[1], *scene = argv[2], *dir = argv[4];
  int steps = atoi(argv[3]);
  if (rank_ == 0) mkdir(dir, 0755);
  MPI_Barrier(MPI_COMM_WORLD);
  if (strcmp(mode, "same") == 0) mode_same(scene, steps, dir);
  else if (strcmp(mode, "write") == 0) mode_write(scene, steps, dir);
  else if (strcmp(mode, "compare") == 0) mode_compare(scene, steps, dir);
  else { if (rank_ == 0) fprintf(stderr, "unknown mode '%s'\n", mode); g_failures++; }
  return check_end("test_restart");
}
