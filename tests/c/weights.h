/* The two weight-and-transfer choices the invariance tests run
 * (rank_invariance.c, test_levels_invariance.c), named by their last
 * argument: "ugimp_flip" (uGIMP weights, the FLIP transfer: the paper's,
 * which the examples and the main job use; the tests' default) and
 * "cpgimp_apic" (cpGIMP weights, the APIC transfer: the library's
 * defaults). Both are set explicitly. */
#ifndef GIMLET_TEST_WEIGHTS_H
#define GIMLET_TEST_WEIGHTS_H
#include <string.h>
#include "gimlet.h"

/* 1 for "cpgimp_apic", 0 for "ugimp_flip", -1 for any other name. */
static int weights_parse(const char *name) {
  if (strcmp(name, "cpgimp_apic") == 0) return 1;
  if (strcmp(name, "ugimp_flip") == 0) return 0;
  return -1;
}

/* Sets the weights and transfer (`cpgimp_apic` as weights_parse returns)
 * on a new simulation, before particles are inserted, so that the cpGIMP
 * half-lengths start from the inserted ones. Returns the first status
 * that is not GIMLET_OK. */
static int weights_set(GimletSim *sim, int cpgimp_apic) {
  int rc = gimlet_set_shape(sim, cpgimp_apic ? GIMLET_SHAPE_CPGIMP : GIMLET_SHAPE_UGIMP);
  if (rc != GIMLET_OK) return rc;
  return gimlet_set_transfer(sim, cpgimp_apic ? GIMLET_TRANSFER_APIC : GIMLET_TRANSFER_FLIP);
}

#endif
