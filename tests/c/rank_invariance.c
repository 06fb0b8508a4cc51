/* Rank and patch invariance. Runs a scene on the ranks it is started with
 * and a given patch layout, gathers positions and stresses by global id on
 * rank 0, and either writes them (mode "write") or compares them with a
 * reference file written by a 1-rank, 1-patch run (mode "compare"). The
 * bound is 1e-12 relative: position differences over the largest
 * coordinate, stress differences over the largest stress component (a
 * component that vanishes analytically, like the plate's shear, is measured
 * against the stress scale, not against its own round-off).
 *
 *   rank_invariance write|compare FILE SCENE PATCHES STEPS [WEIGHTS]
 *
 * PATCHES is "PXxPY" (patches along x and y, e.g. 2x1) or one number N for
 * N x N. WEIGHTS is "ugimp_flip" (the default here: uGIMP weights with
 * the FLIP transfer, the paper's, which the examples and the main job use)
 * or "cpgimp_apic" (the library's default, cpGIMP weights with the APIC
 * transfer; both are set explicitly. cpGIMP with APIC is the
 * combination whose affine matrices once depended on the patch layout
 * through the nodes beyond the roller plane that only the tails of the
 * cpGIMP domains reach); the reference must be written with
 * the same WEIGHTS.
 *
 * Scenes: "plate" (vibrating plate, rollers on all faces, amplitude about
 * one cell so particles cross patch boundaries), "plastic" (the plate with
 * J2 power-law plasticity, as in test_restart.c: it yields in the first
 * steps, so the J2 particles' nodal average of the dilatation, summed
 * over patches, is exercised across patch borders) and "pressure" (the
 * paper's indentation of silicon by a ramped surface pressure, half
 * model). */
#include "scenes.h"

/* Builds the scene with px x py patches; returns the fixed step size. */
static double setup(GimletSim **sim, const char *scene, int px, int py, Weights w) {
  if (strcmp(scene, "plate") == 0 || strcmp(scene, "plastic") == 0)
    return plate_scene(sim, (32 + px - 1) / px, (32 + py - 1) / py, strcmp(scene, "plastic") == 0, w);
  return pressure_scene(sim, MPI_COMM_WORLD, 1e-6, 1, (40 + px - 1) / px, (40 + py - 1) / py, w);
}

int main(int argc, char **argv) {
  check_begin(&argc, &argv);
  int w = argc == 7 ? weights_parse(argv[6]) : UGIMP_FLIP, px = 1, py = 1;
  if ((argc != 6 && argc != 7) || w < 0) {
    if (rank_ == 0)
      fprintf(stderr, "usage: %s write|compare FILE SCENE PXxPY STEPS [ugimp_flip|cpgimp_apic]\n", argv[0]);
    MPI_Finalize();
    return 2;
  }
  const char *mode = argv[1], *file = argv[2], *scene = argv[3];
  int steps = atoi(argv[5]);
  if (sscanf(argv[4], "%dx%d", &px, &py) != 2) py = px = atoi(argv[4]);
  if (px < 1 || py < 1 || steps < 1) {
    if (rank_ == 0) fprintf(stderr, "PATCHES and STEPS must be positive\n");
    MPI_Finalize();
    return 2;
  }
  GimletSim *sim = NULL;
  double dt = setup(&sim, scene, px, py, (Weights)w);
  for (int s = 0; s < steps; s++) MUST(gimlet_step(sim, dt, NULL, NULL));
  int64_t crossings = 0;
  MUST(gimlet_patch_crossings(sim, &crossings));
  if (rank_ == 0)
    printf("%s (%s) %d ranks %dx%d patches: %lld patch crossings in %d steps\n", scene, weights_name(w), size_, px,
           py, (long long)crossings, steps);
  /* The plate must exercise migration: particles cross patch boundaries. */
  if (strcmp(scene, "plate") == 0 && px * py > 1)
    EXPECT(crossings > 0, "no particle crossed a patch boundary: the test does not exercise migration");

  const int fields[2] = {GIMLET_FIELD_POSITION, GIMLET_FIELD_STRESS};
  int64_t n = 0;
  Rec *all = gather(sim, MPI_COMM_WORLD, fields, 2, &n);
  if (rank_ == 0 && strcmp(mode, "write") == 0) {
    FILE *f = fopen(file, "wb");
    EXPECT(f && fwrite(&n, 8, 1, f) == 1 && fwrite(all, sizeof(Rec), n, f) == (size_t)n, "cannot write %s", file);
    if (f) fclose(f);
    printf("%s: wrote %lld particles after %d steps (%d ranks, %dx%d patches)\n", scene, (long long)n, steps, size_,
           px, py);
  } else if (rank_ == 0) {
    FILE *f = fopen(file, "rb");
    int64_t nref = -1;
    Rec *ref = NULL;
    if (f && fread(&nref, 8, 1, f) == 1 && nref >= 0) {
      ref = malloc(sizeof(Rec) * (nref + 1));
      if (fread(ref, sizeof(Rec), nref, f) != (size_t)nref) nref = -1;
    }
    if (f) fclose(f);
    double dpos = 1, dstress = 1;
    int same = pos_stress_diff(ref, nref, all, n, &dpos, &dstress);
    printf("%s %d ranks %dx%d patches: max |dx| / position scale = %.3e, max |dsigma| / stress scale = %.3e "
           "(bound 1e-12)\n",
           scene, size_, px, py, dpos, dstress);
    EXPECT(same, "reference %s missing or with other particles (%lld of them; this run: %lld)", file,
           (long long)nref, (long long)n);
    EXPECT(dpos <= 1e-12 && dstress <= 1e-12, "differences above 1e-12 relative");
    free(ref);
  }
  MUST(gimlet_destroy(&sim));
  free(all);
  return check_end("rank_invariance");
}
