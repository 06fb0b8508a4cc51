/* Scenes shared by the contact tests: an elastic block (half model with
 * the symmetry plane at x = 0, bottom on rollers) under a rigid indenter
 * whose tip starts on the block's top surface at x = 0. */
#ifndef GIMLET_CONTACT_COMMON_H
#define GIMLET_CONTACT_COMMON_H

#include <math.h>
#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "gimlet.h"

static int rank_ = 0, size_ = 1;

#define CHECK(call)                                                      \
  do {                                                                   \
    if ((call) != GIMLET_OK) {                                           \
      char m_[1024];                                                     \
      gimlet_last_error(m_, sizeof m_, NULL);                            \
      fprintf(stderr, "rank %d: %s failed: %s\n", rank_, #call, m_);     \
      MPI_Abort(MPI_COMM_WORLD, 1);                                      \
    }                                                                    \
  } while (0)

static int failures_ = 0;
#define EXPECT(cond, ...)                                                \
  do {                                                                   \
    if (!(cond)) {                                                       \
      failures_++;                                                       \
      if (rank_ == 0) {                                                  \
        fprintf(stderr, "FAILED %s:%d: %s: ", __FILE__, __LINE__, #cond); \
        fprintf(stderr, __VA_ARGS__);                                    \
        fprintf(stderr, "\n");                                           \
      }                                                                  \
    }                                                                    \
  } while (0)

enum { SHAPE_PUNCH, SHAPE_CYLINDER, SHAPE_WEDGE };

typedef struct {
  double w, hb, top;     /* block half-width, height, room above it */
  double h0;             /* coarse cell */
  int levels;            /* nested levels refining [0, w/2^l] x [hb - hb/2^l, hb + top] */
  double refine;         /* fraction of the block each finer level covers (0.5: a quarter in area) */
  int px, py;            /* patches per level (x, y) */
  double e, nu, rho;     /* material */
  int shape;             /* SHAPE_* */
  double size;           /* punch half-width, cylinder radius, wedge half-angle (deg) */
  double gap0;           /* initial tip height above the surface */
  int scheme;            /* GIMLET_SCHEME_* or -1 for the default */
  double flip;           /* < 0: the default */
  int weights;           /* GIMLET_SHAPE_* (particle weights, with the FLIP
                            transfer), -1 for uGIMP with FLIP (the paper's,
                            which the contact figures were measured with) or
                            WEIGHTS_LIBRARY for the library's defaults
                            (cpGIMP, APIC: nothing set) */
} Scene;

/* Scene.weights: the library's default weights and transfer. */
#define WEIGHTS_LIBRARY (-2)

/* The name of a Scene.weights value, for the figures' lines. */
static const char *weights_name(int weights) {
  return weights == WEIGHTS_LIBRARY ? "library default: cpGIMP, APIC"
         : weights == GIMLET_SHAPE_CPGIMP ? "cpGIMP"
                                          : "uGIMP";
}

static Scene scene_defaults(void) {
  Scene s;
  s.w = 1.0;
  s.hb = 1.0;
  s.top = 0.0;
  s.h0 = 1.0 / 16;
  s.levels = 1;
  s.refine = 0.5;
  s.px = 1;
  s.py = 1;
  s.e = 1e7;
  s.nu = 0.3;
  s.rho = 1000;
  s.shape = SHAPE_PUNCH;
  s.size = 0.25;
  s.gap0 = 0;
  s.scheme = -1;
  s.flip = -1;
  s.weights = -1;
  return s;
}

/* Builds the scene; `*ind` receives the indenter. */
static GimletSim *scene_build(const Scene *s, int *ind) {
  GimletSim *sim = NULL;
  double top = s->top > 0 ? s->top : 2 * s->h0;
  CHECK(gimlet_create(MPI_COMM_WORLD, 0, 0, s->w, s->hb + top, s->h0, &sim));
  double fx = 1.0, fy = 1.0;
  for (int l = 1; l < s->levels; l++) {
    fx *= s->refine;
    fy *= s->refine;
    double box[4] = {0, s->hb - fy * s->hb, fx * s->w, s->hb + top};
    CHECK(gimlet_add_level(sim, box, 1));
  }
  for (int l = 0; l < s->levels; l++) {
    int nboxes, npatches;
    int64_t count = 0;
    double hl, b[4];
    CHECK(gimlet_level_info(sim, l, &hl, &nboxes, &npatches));
    CHECK(gimlet_level_boxes(sim, l, b, 1, &count));
    int wx = (int)lround((b[2] - b[0]) / hl) + (l ? 4 : 0), wy = (int)lround((b[3] - b[1]) / hl) + (l ? 4 : 0);
    CHECK(gimlet_set_patch_size(sim, l, (wx + s->px - 1) / s->px, (wy + s->py - 1) / s->py));
  }
  int m;
  CHECK(gimlet_add_material_linear_elastic(sim, s->e, s->nu, s->rho, &m));
  CHECK(gimlet_set_face_bc(sim, GIMLET_FACE_LEFT, GIMLET_BC_ROLLER));
  CHECK(gimlet_set_face_bc(sim, GIMLET_FACE_BOTTOM, GIMLET_BC_ROLLER));
  if (s->scheme >= 0) CHECK(gimlet_set_scheme(sim, s->scheme));
  if (s->flip >= 0) CHECK(gimlet_set_flip(sim, s->flip));
  if (s->weights != WEIGHTS_LIBRARY) {
    CHECK(gimlet_set_shape(sim, s->weights >= 0 ? s->weights : GIMLET_SHAPE_UGIMP));
    CHECK(gimlet_set_transfer(sim, GIMLET_TRANSFER_FLIP));
  }
  CHECK(gimlet_fill_rectangle(sim, 0, 0, s->w, s->hb, 2, m, s->rho, 0, 0, NULL));
  double yt = s->hb + s->gap0;
  switch (s->shape) {
    case SHAPE_PUNCH:
      CHECK(gimlet_add_indenter_flat_punch(sim, s->size, 0.0, 0.5 * s->hb, 0.0, yt, ind));
      break;
    case SHAPE_CYLINDER:
      CHECK(gimlet_add_indenter_cylinder(sim, s->size, 0.0, yt, ind));
      break;
    default:
      CHECK(gimlet_add_indenter_wedge(sim, s->size, 0.5 * s->hb, 0.0, yt, ind));
  }
  return sim;
}

/* The plane-strain P-wave speed. */
static double wave_speed(const Scene *s) {
  double lam = s->e * s->nu / ((1 + s->nu) * (1 - 2 * s->nu)), mu = s->e / (2 * (1 + s->nu));
  return sqrt((lam + 2 * mu) / s->rho);
}

/* Every contact point of indenter `ind` (owned ones), identical on every
 * rank; arrays malloc'ed, to be freed by the caller. */
typedef struct {
  int64_t n;
  double *x, *normal, *p, *len;
  int64_t *id;
  int *level;
} Contacts;

static Contacts contacts_get(GimletSim *sim, int ind) {
  Contacts c;
  CHECK(gimlet_get_contacts(sim, ind, 0, &c.n, NULL, NULL, NULL, NULL, NULL, NULL, NULL));
  c.x = malloc(sizeof(double) * (2 * c.n + 2));
  c.normal = malloc(sizeof(double) * (2 * c.n + 2));
  c.p = malloc(sizeof(double) * (c.n + 1));
  c.len = malloc(sizeof(double) * (c.n + 1));
  c.id = malloc(sizeof(int64_t) * (c.n + 1));
  c.level = malloc(sizeof(int) * (c.n + 1));
  CHECK(gimlet_get_contacts(sim, ind, c.n, &c.n, c.x, c.normal, c.p, c.len, c.id, c.level, NULL));
  return c;
}

static void contacts_free(Contacts *c) {
  free(c->x);
  free(c->normal);
  free(c->p);
  free(c->len);
  free(c->id);
  free(c->level);
}

#endif
