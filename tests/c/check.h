/* Small helpers shared by the C tests: fail loudly, check statuses and that
 * the last-error message names what it should. */
#ifndef GIMLET_TEST_CHECK_H
#define GIMLET_TEST_CHECK_H
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "gimlet.h"

static int g_failures = 0;
static int g_checks = 0;

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

/* Expect status `want` from `rc`, and (when `word` is non-NULL) the last
 * error message to contain `word`. */
#define EXPECT_STATUS(rc, want, word)                                              \
  do {                                                                             \
    int rc_ = (rc);                                                                \
    g_checks++;                                                                    \
    if (rc_ != (want)) {                                                           \
      fprintf(stderr, "%s:%d: %s returned %d, expected %d (last error: %s)\n",     \
              __FILE__, __LINE__, #rc, rc_, (int)(want), last_error());            \
      g_failures++;                                                                \
    } else if (!message_names(word)) {                                             \
      fprintf(stderr, "%s:%d: %s: message \"%s\" does not name \"%s\"\n",          \
              __FILE__, __LINE__, #rc, last_error(), (word) ? (const char *)(word) : "");        \
      g_failures++;                                                                \
    }                                                                              \
  } while (0)

#define EXPECT_OK(rc) EXPECT_STATUS(rc, GIMLET_OK, NULL)

#ifdef MPI_VERSION
/* A call that must succeed (the test cannot go on otherwise): on failure
 * print the rank, the call and the library's message, and abort the job. */
#define MUST(call)                                                                 \
  do {                                                                             \
    int rc_ = (call);                                                              \
    if (rc_ != GIMLET_OK) {                                                        \
      int r_ = -1;                                                                 \
      MPI_Comm_rank(MPI_COMM_WORLD, &r_);                                          \
      fprintf(stderr, "rank %d: %s:%d: %s -> %d: %s\n", r_, __FILE__, __LINE__,     \
              #call, rc_, last_error());                                           \
      MPI_Abort(MPI_COMM_WORLD, 2);                                                \
    }                                                                              \
  } while (0)
#endif

#define EXPECT_TRUE(cond)                                                          \
  do {                                                                             \
    g_checks++;                                                                    \
    if (!(cond)) {                                                                 \
      fprintf(stderr, "%s:%d: expected %s\n", __FILE__, __LINE__, #cond);          \
      g_failures++;                                                                \
    }                                                                              \
  } while (0)

#endif
