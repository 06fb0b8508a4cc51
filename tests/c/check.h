/* The checks every C test uses: counted expectations that say what failed
 * and where, calls that must succeed, the library's last error, a field of
 * this rank's particles as an array, and the closing line and exit status.
 *
 *   EXPECT(cond, fmt, ...)        a check; on failure prints the condition
 *                                 and the formatted explanation
 *   EXPECT_TRUE(cond)             a check without an explanation
 *   EXPECT_STATUS(rc, want, word) the call returned `want`, and the last
 *                                 error names `word` (unless NULL)
 *   EXPECT_OK(rc)                 the call succeeded
 *   MUST(call)                    a call the test cannot go on without: on
 *                                 failure the job stops (MPI_Abort)
 *
 * A test calls check_begin() first and returns check_end("name") from
 * main: the failures of every rank are summed, rank 0 prints one line, and
 * every rank returns the same status. test_no_mpi.c, which runs before
 * MPI_Init, uses the checks alone. */
#ifndef GIMLET_TEST_CHECK_H
#define GIMLET_TEST_CHECK_H
#include <math.h>
#include <mpi.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "gimlet.h"

static int g_failures = 0;
static int g_checks = 0;
/* This rank and the size of MPI_COMM_WORLD (set by check_begin). */
static int rank_ = 0, size_ = 1;

static const char *last_error(void) {
  static char buf[1024];
  size_t needed = 0;
  buf[0] = 0;
  gimlet_last_error(buf, sizeof buf, &needed);
  return buf;
}

/* True when `word` is NULL or the last error message contains it. */
static int message_names(const char *word) {
  return word == NULL || strstr(last_error(), word) != NULL;
}

static int mpi_running(void) {
  int init = 0, fin = 0;
  MPI_Initialized(&init);
  MPI_Finalized(&fin);
  return init && !fin;
}

#define EXPECT(cond, ...)                                                        \
  do {                                                                           \
    g_checks++;                                                                  \
    if (!(cond)) {                                                               \
      g_failures++;                                                              \
      fprintf(stderr, "rank %d: %s:%d: FAILED %s: ", rank_, __FILE__, __LINE__, #cond); \
      fprintf(stderr, __VA_ARGS__);                                              \
      fprintf(stderr, "\n");                                                     \
    }                                                                            \
  } while (0)

#define EXPECT_TRUE(cond) EXPECT(cond, "%s", "expected true")

#define EXPECT_STATUS(rc, want, word)                                                \
  do {                                                                               \
    int rc_ = (rc);                                                                  \
    const char *w_ = (word);                                                         \
    EXPECT(rc_ == (want) && message_names(w_), "%s returned %d, expected %d; last error \"%s\"%s%s", \
           #rc, rc_, (int)(want), last_error(), w_ ? ", which must name " : "", w_ ? w_ : ""); \
  } while (0)

#define EXPECT_OK(rc) EXPECT_STATUS(rc, GIMLET_OK, NULL)

#define MUST(call)                                                                   \
  do {                                                                               \
    int rc_ = (call);                                                                \
    if (rc_ != GIMLET_OK) {                                                          \
      fprintf(stderr, "rank %d: %s:%d: %s -> %d: %s\n", rank_, __FILE__, __LINE__,   \
              #call, rc_, last_error());                                             \
      if (mpi_running()) MPI_Abort(MPI_COMM_WORLD, 2);                               \
      exit(2);                                                                       \
    }                                                                                \
  } while (0)

static void check_begin(int *argc, char ***argv) {
  MPI_Init(argc, argv);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
}

/* Sums the failures over the ranks, prints `name`'s line on rank 0,
 * finalizes MPI and returns the exit status (the same on every rank). */
static int check_end(const char *name) {
  int all = g_failures;
  MPI_Allreduce(MPI_IN_PLACE, &all, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
  if (rank_ == 0)
    printf("%s: %d checks per rank on %d rank(s), %d failure(s): %s\n", name, g_checks, size_, all,
           all ? "FAILED" : "passed");
  MPI_Finalize();
  return all ? 1 : 0;
}

/* FNV-1a of `n` bytes at `p`, continuing from `h`: the fingerprints of
 * states that tests compare. */
static uint64_t fnv(uint64_t h, const void *p, size_t n) {
  const unsigned char *b = p;
  for (size_t i = 0; i < n; i++) {
    h ^= b[i];
    h *= 0x100000001b3ULL;
  }
  return h;
}

/* Field `fld` of this rank's particles (malloc'ed, to be freed; room for
 * one particle more, so never NULL); `*n` receives their number. */
static double *field(GimletSim *sim, int fld, int64_t *n) {
  int nc = 0;
  MUST(gimlet_field_components(sim, fld, &nc));
  MUST(gimlet_get_field(sim, fld, NULL, 0, n));
  double *v = malloc(sizeof(double) * (size_t)(nc * (*n + 1)));
  MUST(gimlet_get_field(sim, fld, v, *n, n));
  return v;
}

#endif
