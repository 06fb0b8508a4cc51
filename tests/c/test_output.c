/* Output a user can open: HDF5 snapshots + XDMF series, and the CSV series.
 *
 *   test_output DIR
 *
 * Runs the vibrating plate (2 x 2 patches, particles crossing patches) and
 * writes outputs at steps 5 and 10 into DIR/nested/out (created by the
 * library), the second one twice (a rewrite replaces it in the series). Then
 * rank 0 reads the last HDF5 file with the HDF5 C API and checks, by global
 * id, that positions, stresses, velocities and masses equal the in-memory
 * query bitwise, that the rank column names the rank holding each particle,
 * that each particle lies in the cells of the patch it is listed in, and
 * that the grid layout (patches, owners, per-patch counts) is consistent.
 * The XDMF file is validated against the HDF5 datasets it names
 * (gimlet_check_xdmf) and its text is checked (two times, the right files,
 * the particle count, the last time exactly). The CSV series must have the
 * documented header, one row per append, and its last row must equal
 * gimlet_diagnostics and the particle count exactly. Misuse (no series
 * open, a bad basename) gives the documented status. Then the same plate
 * under the APIC transfer: its output also holds the affine matrices,
 * equal to the query bitwise and named in its XDMF file (the FLIP run's
 * output has none). */
#include <mpi.h>
#include <math.h>
#include <dirent.h>
#include <stdint.h>
#include <sys/stat.h>
#include <hdf5.h>
#include "scenes.h"

/* id, x, y, sxx, syy, sxy, szz, vx, vy, mass, rank, plastic strain,
 * APIC matrix C (xx, xy, yx, yy; zero unless the transfer is APIC) */
static const int fields[7] = {GIMLET_FIELD_POSITION, GIMLET_FIELD_STRESS, GIMLET_FIELD_VELOCITY, GIMLET_FIELD_MASS,
                              FIELD_RANK, GIMLET_FIELD_PLASTIC_STRAIN, GIMLET_FIELD_AFFINE};

/* The plate (2 x 2 patches) with the library's cpGIMP weights and the
 * given transfer. */
static GimletSim *plate(double *dt, int transfer) {
  GimletSim *sim = NULL;
  *dt = plate_scene(&sim, 16, 16, 0, transfer == GIMLET_TRANSFER_APIC ? CPGIMP_APIC : CPGIMP_FLIP);
  return sim;
}

/* The in-memory state by id on rank 0 (NULL elsewhere). */
static Rec *gather_state(GimletSim *sim, int64_t *n) {
  return gather(sim, MPI_COMM_WORLD, fields, 7, n);
}

/* Reads a whole dataset of `rows` x `cols` values of memory type `mt` into
 * `buf`; returns 0 when the shape differs or a call fails. */
static int read_ds(hid_t f, const char *name, hid_t mt, hsize_t rows, hsize_t cols, void *buf) {
  hid_t d = H5Dopen2(f, name, H5P_DEFAULT);
  if (d < 0) { fprintf(stderr, "dataset %s missing\n", name); return 0; }
  hid_t s = H5Dget_space(d);
  hsize_t dims[2] = {0, 0};
  int nd = H5Sget_simple_extent_dims(s, dims, NULL);
  int ok = (cols == 1 ? (nd == 1 || (nd == 2 && dims[1] == 1)) : (nd == 2 && dims[1] == cols)) &&
           dims[0] == rows;
  if (!ok) fprintf(stderr, "dataset %s has shape %llu x %llu, expected %llu x %llu\n", name,
                   (unsigned long long)dims[0], (unsigned long long)(nd == 2 ? dims[1] : 1),
                   (unsigned long long)rows, (unsigned long long)cols);
  if (ok && rows > 0) ok = H5Dread(d, mt, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf) >= 0;
  H5Sclose(s);
  H5Dclose(d);
  return ok;
}

static double attr_f64(hid_t f, const char *name) {
  double v = NAN;
  hid_t a = H5Aopen(f, name, H5P_DEFAULT);
  if (a >= 0) { H5Aread(a, H5T_NATIVE_DOUBLE, &v); H5Aclose(a); }
  return v;
}

/* Rank 0: checks the output file against the in-memory state `mem`; the
 * file has `/particles/affine` exactly when `affine` (the APIC transfer). */
static void check_file(const char *path, const Rec *mem, int64_t n, double time, int64_t step, int affine) {
  hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
  EXPECT_TRUE(f >= 0);
  if (f < 0) return;
  EXPECT_TRUE(attr_f64(f, "time") == time);
  EXPECT_TRUE(attr_f64(f, "step") == (double)step);
  EXPECT_TRUE(attr_f64(f, "num_particles") == (double)n);
  int64_t *id = malloc(8 * n);
  int *level = malloc(4 * n), *patch = malloc(4 * n), *rank = malloc(4 * n);
  double *pos = malloc(16 * n), *sig = malloc(32 * n), *vel = malloc(24 * n), *mass = malloc(8 * n),
         *epl = malloc(8 * n), *aff = calloc(4 * n + 4, 8);
  EXPECT_TRUE((H5Lexists(f, "/particles/affine", H5P_DEFAULT) > 0) == affine);
  /* F_θθ only in axisymmetry (test_axisym lame checks it there). */
  EXPECT_TRUE(H5Lexists(f, "/particles/hoop_stretch", H5P_DEFAULT) == 0);
  int ok = read_ds(f, "/particles/id", H5T_NATIVE_INT64, n, 1, id) &&
           read_ds(f, "/particles/level", H5T_NATIVE_INT, n, 1, level) &&
           read_ds(f, "/particles/patch", H5T_NATIVE_INT, n, 1, patch) &&
           read_ds(f, "/particles/rank", H5T_NATIVE_INT, n, 1, rank) &&
           read_ds(f, "/particles/position", H5T_NATIVE_DOUBLE, n, 2, pos) &&
           read_ds(f, "/particles/stress", H5T_NATIVE_DOUBLE, n, 4, sig) &&
           read_ds(f, "/particles/velocity", H5T_NATIVE_DOUBLE, n, 3, vel) &&
           read_ds(f, "/particles/mass", H5T_NATIVE_DOUBLE, n, 1, mass) &&
           read_ds(f, "/particles/plastic_strain", H5T_NATIVE_DOUBLE, n, 1, epl) &&
           (!affine || read_ds(f, "/particles/affine", H5T_NATIVE_DOUBLE, n, 4, aff));
  EXPECT_TRUE(ok);
  /* Grid layout: 2 x 2 patches of 16 x 16 cells. */
  int64_t boxes[4 * 4], patches[4 * 4], counts[4];
  int owner[4];
  int gok = read_ds(f, "/grid/level_0/boxes", H5T_NATIVE_INT64, 1, 4, boxes) &&
            read_ds(f, "/grid/level_0/patches", H5T_NATIVE_INT64, 4, 4, patches) &&
            read_ds(f, "/grid/level_0/owner", H5T_NATIVE_INT, 4, 1, owner) &&
            read_ds(f, "/grid/level_0/patch_particles", H5T_NATIVE_INT64, 4, 1, counts);
  EXPECT_TRUE(gok);
  H5Fclose(f);
  if (!ok || !gok) return;
  EXPECT_TRUE(boxes[0] == 0 && boxes[1] == 0 && boxes[2] == 32 && boxes[3] == 32);
  int64_t sum = 0;
  for (int k = 0; k < 4; k++) {
    EXPECT_TRUE(owner[k] >= 0 && owner[k] < size_);
    EXPECT_TRUE(patches[4 * k + 2] - patches[4 * k] == 16 && patches[4 * k + 3] - patches[4 * k + 1] == 16);
    sum += counts[k];
  }
  EXPECT_TRUE(sum == n);
  /* Sort the file's rows by id (a permutation), then compare. */
  Rec *file = malloc(sizeof(Rec) * n);
  int64_t in_patch = 0, per_patch[4] = {0, 0, 0, 0}, bad_owner = 0;
  const double h = 1.0 / 32;
  for (int64_t i = 0; i < n; i++) {
    Rec *r = &file[i];
    r->id = (uint64_t)id[i];
    r->v[0] = pos[2 * i];
    r->v[1] = pos[2 * i + 1];
    for (int c = 0; c < 4; c++) r->v[2 + c] = sig[4 * i + c];
    r->v[6] = vel[3 * i];
    r->v[7] = vel[3 * i + 1];
    r->v[8] = mass[i];
    r->v[9] = rank[i];
    r->v[10] = epl[i];
    for (int c = 0; c < 4; c++) r->v[11 + c] = aff[4 * i + c];
    int k = patch[i];
    if (level[i] == 0 && k >= 0 && k < 4 && vel[3 * i + 2] == 0) {
      long ci = (long)floor(pos[2 * i] / h), cj = (long)floor(pos[2 * i + 1] / h);
      in_patch += ci >= patches[4 * k] && ci < patches[4 * k + 2] && cj >= patches[4 * k + 1] &&
                  cj < patches[4 * k + 3];
      per_patch[k]++;
      bad_owner += owner[k] != rank[i];
    }
  }
  EXPECT_TRUE(in_patch == n);
  EXPECT_TRUE(bad_owner == 0);
  for (int k = 0; k < 4; k++) EXPECT_TRUE(per_patch[k] == counts[k]);
  qsort(file, n, sizeof(Rec), rec_by_id);
  int64_t differ = 0;
  for (int64_t i = 0; i < n; i++)
    differ += file[i].id != mem[i].id || memcmp(file[i].v, mem[i].v, sizeof file[i].v) != 0;
  EXPECT_TRUE(differ == 0);
  printf("%s: %lld particles; ids, positions, stresses, velocities, masses, ranks, plastic strains%s equal the query (%lld differ); all in their patch's cells\n",
         path, (long long)n, affine ? ", APIC matrices" : "", (long long)differ);
  free(file); free(id); free(level); free(patch); free(rank); free(pos); free(sig); free(vel); free(mass); free(epl);
  free(aff);
}

static char *slurp(const char *path) {
  FILE *f = fopen(path, "rb");
  if (!f) return NULL;
  fseek(f, 0, SEEK_END);
  long len = ftell(f);
  fseek(f, 0, SEEK_SET);
  char *b = malloc(len + 1);
  if (fread(b, 1, len, f) != (size_t)len) { free(b); fclose(f); return NULL; }
  b[len] = 0;
  fclose(f);
  return b;
}

static int count_of(const char *text, const char *word) {
  int n = 0;
  for (const char *p = text; (p = strstr(p, word)) != NULL; p += strlen(word)) n++;
  return n;
}

/* Rank 0: the XDMF text names both files, two times, the particle count,
 * and the last output's time exactly. */
static void check_xdmf_text(const char *path, int64_t n, double t_last) {
  char *x = slurp(path);
  EXPECT_TRUE(x != NULL);
  if (!x) return;
  char elems[64];
  snprintf(elems, sizeof elems, "NumberOfElements=\"%lld\"", (long long)n);
  EXPECT_TRUE(count_of(x, "<Time Value=") == 2);
  EXPECT_TRUE(count_of(x, elems) == 2);
  EXPECT_TRUE(count_of(x, "plate_000005.h5:/particles/position") == 1);
  EXPECT_TRUE(count_of(x, "plate_000010.h5:/particles/position") == 1);
  EXPECT_TRUE(count_of(x, "Name=\"rank\"") == 2 && count_of(x, "Name=\"level\"") == 2 &&
              count_of(x, "Name=\"patch\"") == 2 && count_of(x, "Name=\"plastic_strain\"") == 2);
  const char *last = strstr(strstr(x, "<Time Value=\"") + 1, "<Time Value=\"");
  EXPECT_TRUE(last && strtod(last + strlen("<Time Value=\""), NULL) == t_last);
  free(x);
}

static int leftovers(const char *dir) {
  DIR *d = opendir(dir);
  if (!d) return -1;
  int n = 0;
  struct dirent *e;
  while ((e = readdir(d)) != NULL) n += strstr(e->d_name, ".tmp-") != NULL;
  closedir(d);
  return n;
}

/* Rank 0: the CSV has the documented header, `rows` data rows, and its last
 * row equals the given values exactly. */
static void check_csv(const char *path, int rows, const double *last, int nlast) {
  char *t = slurp(path);
  EXPECT_TRUE(t != NULL);
  if (!t) return;
  const char *header =
      "time,step,indenter_displacement,indenter_force,indenter_force_x,contacts,kinetic_energy,"
      "strain_energy,momentum_x,momentum_y,mass,particles_level_0\n";
  EXPECT_TRUE(strncmp(t, header, strlen(header)) == 0);
  EXPECT_TRUE(count_of(t, "\n") == rows + 1);
  size_t len = strlen(t);
  const char *p = t + len - 1;
  while (p > t && p[-1] != '\n') p--;
  int ok = 1;
  for (int c = 0; c < nlast && ok; c++) {
    char *end;
    double v = strtod(p, &end);
    ok = end != p && ((isnan(last[c]) && isnan(v)) || v == last[c]);
    if (!ok) fprintf(stderr, "CSV column %d: %.17g, expected %.17g\n", c, v, last[c]);
    p = end + 1;
  }
  EXPECT_TRUE(ok);
  printf("%s: header and %d rows; last row equals the diagnostics exactly: %s\n", path, rows, ok ? "yes" : "no");
  free(t);
}

int main(int argc, char **argv) {
  check_begin(&argc, &argv);
  if (argc != 2) {
    if (rank_ == 0) fprintf(stderr, "usage: %s DIR\n", argv[0]);
    MPI_Finalize();
    return 2;
  }
  char base[400], out[512], xdmf[600], h5[600], csv[512];
  snprintf(base, sizeof base, "%s/n%d", argv[1], size_);
  snprintf(out, sizeof out, "%s/nested/out", base);
  snprintf(xdmf, sizeof xdmf, "%s/plate.xdmf", out);
  snprintf(csv, sizeof csv, "%s/series.csv", base);
  if (rank_ == 0) { mkdir(argv[1], 0755); mkdir(base, 0755); }
  MPI_Barrier(MPI_COMM_WORLD);

  double dt;
  GimletSim *sim = plate(&dt, GIMLET_TRANSFER_FLIP);
  EXPECT_STATUS(gimlet_write_output(sim), GIMLET_ERR_INVALID_STATE, "gimlet_output_open");
  EXPECT_STATUS(gimlet_csv_append(sim), GIMLET_ERR_INVALID_STATE, "gimlet_csv_open");
  EXPECT_STATUS(gimlet_output_open(sim, out, "a/b"), GIMLET_ERR_INVALID_ARGUMENT, "basename");
  EXPECT_STATUS(gimlet_output_open(sim, NULL, "plate"), GIMLET_ERR_NULL_POINTER, "dir");
  MUST(gimlet_output_open(sim, out, "plate"));
  MUST(gimlet_csv_open(sim, csv));
  MUST(gimlet_csv_append(sim));
  for (int s = 0; s < 5; s++) { MUST(gimlet_step(sim, dt, NULL, NULL)); MUST(gimlet_csv_append(sim)); }
  MUST(gimlet_write_output(sim));
  for (int s = 0; s < 5; s++) { MUST(gimlet_step(sim, dt, NULL, NULL)); MUST(gimlet_csv_append(sim)); }
  MUST(gimlet_write_output(sim));
  MUST(gimlet_write_output(sim)); /* the same step again: replaces it */
  double t;
  int64_t step, n, crossings;
  MUST(gimlet_time(sim, &t, &step));
  MUST(gimlet_patch_crossings(sim, &crossings));
  snprintf(h5, sizeof h5, "%s/plate_%06lld.h5", out, (long long)step);
  Rec *mem = gather_state(sim, &n);
  if (rank_ == 0) {
    printf("plate on %d ranks: %lld particles, step %lld, %lld patch crossings\n", size_, (long long)n,
           (long long)step, (long long)crossings);
    check_file(h5, mem, n, t, step, 0);
    check_xdmf_text(xdmf, n, t);
    EXPECT_TRUE(leftovers(out) == 0);
  }
  int64_t items = 0;
  MUST(gimlet_check_xdmf(sim, xdmf, &items));
  /* Two snapshots, each with the geometry and 11 attributes. */
  EXPECT_TRUE(items == 24);
  if (rank_ == 0) printf("%s: %lld data items match the HDF5 datasets they name\n", xdmf, (long long)items);

  double d[5];
  MUST(gimlet_diagnostics(sim, &d[0], &d[1], &d[2], &d[3], &d[4]));
  double last[12] = {t, (double)step, NAN, NAN, NAN, 0.0, d[0], d[1], d[2], d[3], d[4], (double)n};
  if (rank_ == 0) check_csv(csv, 11, last, 12);

  free(mem);
  MUST(gimlet_destroy(&sim));

  /* The same plate under the APIC transfer: the output has the particles'
   * affine matrices (`affine`, n x 4, bitwise the query's) and its XDMF
   * names them (geometry and 12 attributes). */
  char outa[600], xdmfa[700];
  snprintf(outa, sizeof outa, "%s/apic", base);
  snprintf(xdmfa, sizeof xdmfa, "%s/plate.xdmf", outa);
  sim = plate(&dt, GIMLET_TRANSFER_APIC);
  MUST(gimlet_output_open(sim, outa, "plate"));
  for (int s = 0; s < 5; s++) MUST(gimlet_step(sim, dt, NULL, NULL));
  MUST(gimlet_write_output(sim));
  MUST(gimlet_time(sim, &t, &step));
  snprintf(h5, sizeof h5, "%s/plate_%06lld.h5", outa, (long long)step);
  mem = gather_state(sim, &n);
  if (rank_ == 0) {
    double cmax = 0;
    for (int64_t i = 0; i < n; i++)
      for (int c = 0; c < 4; c++) cmax = fmax(cmax, fabs(mem[i].v[11 + c]));
    EXPECT_TRUE(cmax > 0); /* the vibrating plate has a velocity gradient */
    check_file(h5, mem, n, t, step, 1);
  }
  MUST(gimlet_check_xdmf(sim, xdmfa, &items));
  EXPECT_TRUE(items == 13);
  if (rank_ == 0) printf("%s: %lld data items match the HDF5 datasets they name\n", xdmfa, (long long)items);
  free(mem);
  MUST(gimlet_destroy(&sim));
  return check_end("test_output");
}
