/* Checkpoints you can trust (issue "Never abort, never hang", item 6), on 1
 * and 2 ranks:
 *
 *   1. data region: for every dataset of a checkpoint (/particles/*,
 *      /lost/*), a sample of bytes spread over its data, every bit of each
 *      flipped in turn (one flip per trial): every trial must be rejected
 *      by gimlet_read_checkpoint with GIMLET_ERR_IO, and the handle must
 *      keep its state;
 *   2. the whole file: one bit flipped at positions spread evenly over the
 *      file (superblock, object headers, attributes, data, free space):
 *      every trial must be rejected, or load a state identical to the
 *      original one (also after one more step); a silently different state
 *      fails the test. No trial may abort the process.
 *
 * Prints the counts. Usage: test_bitflip <work-dir> [quick] (quick: the
 * first and last byte of each dataset, 200 whole-file positions). */
#include <hdf5.h>
#include <math.h>
#include <mpi.h>
#include <stdint.h>
#include "check.h"

static int rank = 0, size = 1;

/* An order-independent fingerprint of the whole state (collective): the
 * sum over particles of a hash of its id and every queryable field, the
 * lost list, the clock, the diagnostics. */
static uint64_t fingerprint(GimletSim *s) {
  static const int fields[] = {GIMLET_FIELD_POSITION, GIMLET_FIELD_VELOCITY, GIMLET_FIELD_STRESS,
                               GIMLET_FIELD_DEFGRAD,  GIMLET_FIELD_HALF_LENGTH, GIMLET_FIELD_MASS,
                               GIMLET_FIELD_LEVEL,    GIMLET_FIELD_VOLUME0,  GIMLET_FIELD_REFERENCE};
  int64_t n = 0;
  gimlet_get_ids(s, NULL, 0, &n);
  uint64_t *ids = malloc((size_t)(n + 1) * sizeof *ids);
  uint64_t *h = malloc((size_t)(n + 1) * sizeof *h);
  gimlet_get_ids(s, ids, n, &n);
  for (int64_t i = 0; i < n; i++) h[i] = fnv(0xcbf29ce484222325ULL, &ids[i], 8);
  double *buf = malloc((size_t)(4 * n + 4) * sizeof *buf);
  for (size_t f = 0; f < sizeof fields / sizeof fields[0]; f++) {
    int nc = 0;
    int64_t got = 0;
    gimlet_field_components(s, fields[f], &nc);
    gimlet_get_field(s, fields[f], buf, n, &got);
    for (int64_t i = 0; i < n; i++) h[i] = fnv(h[i], &buf[i * nc], (size_t)nc * sizeof(double));
  }
  uint64_t local = 0;
  for (int64_t i = 0; i < n; i++) local += h[i];
  int64_t nl = 0;
  gimlet_lost_particles(s, NULL, NULL, 0, &nl);
  uint64_t *lid = malloc((size_t)(nl + 1) * sizeof *lid);
  double *lxy = malloc((size_t)(2 * nl + 2) * sizeof *lxy);
  gimlet_lost_particles(s, lid, lxy, nl, &nl);
  for (int64_t i = 0; i < nl; i++) local += fnv(fnv(0x1234, &lid[i], 8), &lxy[2 * i], 16);
  uint64_t total = 0;
  MPI_Allreduce(&local, &total, 1, MPI_UINT64_T, MPI_SUM, MPI_COMM_WORLD);
  double t = 0, d[5] = {0};
  int64_t st = 0;
  gimlet_time(s, &t, &st);
  gimlet_diagnostics(s, &d[0], &d[1], &d[2], &d[3], &d[4]);
  total = fnv(fnv(fnv(total, &t, 8), &st, 8), d, sizeof d);
  free(ids), free(h), free(buf), free(lid), free(lxy);
  return total;
}

/* Data extents (file offset, bytes) of the non-empty datasets of a group. */
typedef struct {
  char name[64];
  haddr_t off;
  hsize_t bytes;
} Extent;

static int extents(const char *path, Extent *out, int cap) {
  static const char *particles[] = {"id", "material", "level", "patch", "x", "y", "x0", "y0", "vx", "vy",
                                    "mass", "vol0", "lpx0", "lpy0", "lpx", "lpy", "fxx", "fxy", "fyx", "fyy",
                                    "sxx", "syy", "sxy", "szz", "fext_x", "fext_y", "copy"};
  static const char *lost[] = {"id", "x", "y", "rank"};
  int n = 0;
  hid_t f = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return -1;
  for (int g = 0; g < 2; g++) {
    int m = g ? 4 : (int)(sizeof particles / sizeof particles[0]);
    for (int k = 0; k < m && n < cap; k++) {
      char full[96];
      snprintf(full, sizeof full, "/%s/%s", g ? "lost" : "particles", g ? lost[k] : particles[k]);
      if (H5Lexists(f, full, H5P_DEFAULT) <= 0) continue;
      hid_t d = H5Dopen2(f, full, H5P_DEFAULT);
      haddr_t off = H5Dget_offset(d);
      hsize_t bytes = H5Dget_storage_size(d);
      H5Dclose(d);
      if (off == HADDR_UNDEF || bytes == 0) continue;
      snprintf(out[n].name, sizeof out[n].name, "%s", full);
      out[n].off = off;
      out[n].bytes = bytes;
      n++;
    }
  }
  H5Fclose(f);
  return n;
}

static unsigned char *slurp(const char *path, long *len) {
  FILE *f = fopen(path, "rb");
  if (!f) return NULL;
  fseek(f, 0, SEEK_END);
  *len = ftell(f);
  fseek(f, 0, SEEK_SET);
  unsigned char *b = malloc((size_t)*len);
  if (fread(b, 1, (size_t)*len, f) != (size_t)*len) *len = -1;
  fclose(f);
  return b;
}

/* Rank 0 writes `orig` with bit `bit` of byte `pos` flipped to `path`. */
static void write_flipped(const char *path, const unsigned char *orig, long len, long pos, int bit) {
  if (rank == 0) {
    FILE *f = fopen(path, "wb");
    fwrite(orig, 1, (size_t)pos, f);
    unsigned char b = orig[pos] ^ (unsigned char)(1u << bit);
    fwrite(&b, 1, 1, f);
    fwrite(orig + pos + 1, 1, (size_t)(len - pos - 1), f);
    fclose(f);
  }
  MPI_Barrier(MPI_COMM_WORLD);
}

int main(int argc, char **argv) {
  check_begin(&argc, &argv);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
  const char *work = argc > 1 ? argv[1] : "bitflip-out";
  int quick = argc > 2 && strcmp(argv[2], "quick") == 0;
  if (rank == 0) {
    char cmd[1200];
    snprintf(cmd, sizeof cmd, "mkdir -p '%s'", work);
    if (system(cmd) != 0) MPI_Abort(MPI_COMM_WORLD, 2);
  }
  MPI_Barrier(MPI_COMM_WORLD);
  char ck[1024], bad[1024];
  snprintf(ck, sizeof ck, "%s/ck.h5", work);
  snprintf(bad, sizeof bad, "%s/flipped.h5", work);

  /* A scene with two levels, some steps, and particles lost through the
   * right face (so /lost is not empty). */
  GimletSim *sim = NULL;
  EXPECT_OK(gimlet_create(MPI_COMM_WORLD, 0, 0, 8, 4, 0.25, &sim));
  double box[4] = {2, 0, 5, 2};
  EXPECT_OK(gimlet_add_level(sim, box, 1));
  int id = -1;
  EXPECT_OK(gimlet_add_material_neo_hookean(sim, 1e9, 0.3, 1000, &id));
  EXPECT_OK(gimlet_set_outflow(sim, GIMLET_OUTFLOW_REMOVE));
  EXPECT_OK(gimlet_fill_rectangle(sim, 1, 0.5, 4, 1.5, 2, id, 1000, 0, -1, NULL));
  EXPECT_OK(gimlet_fill_rectangle(sim, 7.5, 3, 8, 3.5, 2, id, 1000, 400, 0, NULL));
  for (int i = 0; i < 12; i++) EXPECT_OK(gimlet_step(sim, 0, NULL, NULL));
  int64_t nlost = 0, loc = 0, glob = 0;
  EXPECT_OK(gimlet_lost_particles(sim, NULL, NULL, 0, &nlost));
  int64_t lost_all = 0;
  MPI_Allreduce(&nlost, &lost_all, 1, MPI_INT64_T, MPI_SUM, MPI_COMM_WORLD);
  EXPECT_TRUE(lost_all > 0);
  EXPECT_OK(gimlet_particle_count(sim, &loc, &glob));
  EXPECT_OK(gimlet_write_checkpoint(sim, ck));
  EXPECT_OK(gimlet_read_checkpoint(sim, ck));
  uint64_t ref = fingerprint(sim);
  EXPECT_OK(gimlet_step(sim, 0, NULL, NULL));
  uint64_t ref_step = fingerprint(sim);
  EXPECT_OK(gimlet_read_checkpoint(sim, ck));
  EXPECT_TRUE(fingerprint(sim) == ref);

  long len = 0;
  unsigned char *orig = NULL;
  Extent ext[64];
  int next = 0;
  if (rank == 0) {
    orig = slurp(ck, &len);
    next = extents(ck, ext, 64);
  }
  MPI_Bcast(&len, 1, MPI_LONG, 0, MPI_COMM_WORLD);
  MPI_Bcast(&next, 1, MPI_INT, 0, MPI_COMM_WORLD);
  MPI_Bcast(ext, (int)sizeof ext, MPI_BYTE, 0, MPI_COMM_WORLD);
  if (rank != 0) orig = calloc((size_t)len, 1);
  EXPECT_TRUE(len > 0 && next >= 27);

  /* 1. The data region: 4 bytes per dataset (first, last and two between;
   *    2 when quick), every bit of each. */
  int trials = 0, detected = 0, unchanged = 1;
  for (int k = 0; k < next; k++) {
    long span = (long)ext[k].bytes;
    long at[4] = {0, span - 1, span / 3, (2 * span) / 3};
    int nat = quick ? 2 : 4;
    for (int j = 0; j < nat; j++) {
      for (int bit = 0; bit < 8; bit++) {
        write_flipped(bad, orig, len, (long)ext[k].off + at[j], bit);
        int rc = gimlet_read_checkpoint(sim, bad);
        int rcs_ok = 0, mine = rc == GIMLET_ERR_IO;
        MPI_Allreduce(&mine, &rcs_ok, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
        trials++;
        detected += rcs_ok;
        if (!rcs_ok && rank == 0)
          fprintf(stderr, "NOT DETECTED: %s byte %ld bit %d (status %d: %s)\n", ext[k].name, at[j], bit, rc, last_error());
        if (!rcs_ok) EXPECT_OK(gimlet_read_checkpoint(sim, ck));
      }
    }
    unchanged &= fingerprint(sim) == ref; /* rejected reads changed nothing */
  }
  EXPECT_TRUE(detected == trials);
  EXPECT_TRUE(unchanged);
  if (rank == 0)
    printf("data region: %d datasets, %d bytes x 8 bits = %d single-bit flips, %d detected (GIMLET_ERR_IO on every rank), handle unchanged: %s\n",
           next, trials / 8, trials, detected, unchanged ? "yes" : "NO");

  /* 2. The whole file: one bit at positions spread evenly over it. */
  int positions = quick ? 200 : 600, rejected = 0, rejected_io = 0, harmless = 0, silent = 0;
  for (int i = 0; i < positions; i++) {
    long pos = (long)((double)i * (double)(len - 1) / (positions - 1));
    write_flipped(bad, orig, len, pos, i % 8);
    int rc = gimlet_read_checkpoint(sim, bad);
    int any_ok = 0, mine = rc == GIMLET_OK;
    MPI_Allreduce(&mine, &any_ok, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    if (!any_ok) {
      rejected++;
      int io = rc == GIMLET_ERR_IO, all_io = 0;
      MPI_Allreduce(&io, &all_io, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
      rejected_io += all_io;
      if (!all_io && rank == 0) fprintf(stderr, "byte %ld bit %d rejected with status %d: %s\n", pos, i % 8, rc, last_error());
      continue;
    }
    int same = fingerprint(sim) == ref;
    EXPECT_OK(gimlet_step(sim, 0, NULL, NULL));
    same &= fingerprint(sim) == ref_step;
    if (same) {
      harmless++;
    } else {
      silent++;
      if (rank == 0) fprintf(stderr, "SILENT: byte %ld bit %d loads a different state\n", pos, i % 8);
    }
    EXPECT_OK(gimlet_read_checkpoint(sim, ck));
  }
  EXPECT_TRUE(silent == 0);
  EXPECT_TRUE(rejected_io == rejected);
  if (rank == 0)
    printf("whole file (%ld bytes): %d single-bit flips spread over it: %d rejected (%d with GIMLET_ERR_IO), %d loaded an identical state (unused bytes), %d silently different\n",
           len, positions, rejected, rejected_io, harmless, silent);

  EXPECT_OK(gimlet_destroy(&sim));
  free(orig);
  if (rank == 0) printf("test_bitflip: %d particles, %lld lost\n", (int)glob, (long long)lost_all);
  return check_end("test_bitflip");
}
