/* The scenes several C tests run, and the gathering of particles by id that
 * compares two runs of them.
 *
 *   weights        the weight function and transfer a test sets (or leaves
 *                  at the library's defaults)
 *   plate_scene    the vibrating plate (particles cross patch boundaries)
 *   pressure_scene the paper's indentation of silicon by a surface
 *                  pressure, on 1 or 3 levels
 *   Block          an elastic block under a rigid indenter (the contact
 *                  tests), and patches_per_level for any layered block
 *   gather         every particle's id and chosen fields, sorted by id, on
 *                  the root; rec_diff compares two such lists */
#ifndef GIMLET_TEST_SCENES_H
#define GIMLET_TEST_SCENES_H
#include "check.h"

/* ------------------------------------------------------------- weights */

/* The weight function and velocity transfer a scene runs with. Those
 * other than WEIGHTS_DEFAULT are set explicitly (before any particle, so
 * that cpGIMP half-lengths start from the inserted ones). */
typedef enum {
  WEIGHTS_DEFAULT, /* nothing set: the library's defaults, cpGIMP and APIC */
  UGIMP_FLIP,      /* the paper's (the examples and the main job run it) */
  CPGIMP_FLIP,
  CPGIMP_APIC      /* the library's defaults, set explicitly */
} Weights;

/* The Weights named by a command-line word ("ugimp_flip", "cpgimp_apic"),
 * or -1. */
static int weights_parse(const char *name) {
  if (strcmp(name, "ugimp_flip") == 0) return UGIMP_FLIP;
  if (strcmp(name, "cpgimp_apic") == 0) return CPGIMP_APIC;
  return -1;
}

static const char *weights_name(Weights w) {
  switch (w) {
    case UGIMP_FLIP: return "uGIMP, FLIP";
    case CPGIMP_FLIP: return "cpGIMP, FLIP";
    case CPGIMP_APIC: return "cpGIMP, APIC";
    default: return "library defaults: cpGIMP, APIC";
  }
}

static void weights_set(GimletSim *sim, Weights w) {
  if (w == WEIGHTS_DEFAULT) return;
  MUST(gimlet_set_shape(sim, w == UGIMP_FLIP ? GIMLET_SHAPE_UGIMP : GIMLET_SHAPE_CPGIMP));
  MUST(gimlet_set_transfer(sim, w == CPGIMP_APIC ? GIMLET_TRANSFER_APIC : GIMLET_TRANSFER_FLIP));
}

/* ------------------------------------------------------- vibrating plate */

/* The vibrating plate on MPI_COMM_WORLD: the unit square in 32 x 32 cells,
 * rollers on every face, 2 x 2 particles per cell inserted by rank 0 (their
 * ids follow the lattice, the same on any number of ranks; the library
 * sends each to its owner), velocity v0 sin(pi X / L) in each direction
 * with an amplitude of one cell, so that particles cross patch boundaries.
 * Neo-Hookean, or (`plastic`) J2 with power-law hardening, which yields in
 * the first steps. Patches of px x py cells. Returns 0.8 of the stable
 * step. */
static double plate_scene(GimletSim **sim, int px, int py, int plastic, Weights w) {
  const double L = 1.0, h = L / 32, E = 1e4, nu = 0.3, rho = 1.0;
  MUST(gimlet_create(MPI_COMM_WORLD, 0, 0, L, L, h, sim));
  weights_set(*sim, w);
  MUST(gimlet_set_patch_size(*sim, 0, px, py));
  int m;
  if (plastic)
    MUST(gimlet_add_material_j2_power(*sim, E, nu, rho, 0.01 * E, 0.2, 0.01, &m));
  else
    MUST(gimlet_add_material_neo_hookean(*sim, E, nu, rho, &m));
  for (int f = 0; f < 4; f++) MUST(gimlet_set_face_bc(*sim, f, GIMLET_BC_ROLLER));
  double lam = E * nu / ((1 + nu) * (1 - 2 * nu)), mu = E / (2 * (1 + nu));
  double omega = M_PI / L * sqrt((lam + 2 * mu) / rho), v0 = omega * h;
  const int np = 64 * 64;
  int mine = 0;
  double *x = malloc(8 * np), *y = malloc(8 * np), *lp = malloc(8 * np), *vx = malloc(8 * np),
         *vy = malloc(8 * np), *d = malloc(8 * np);
  int *mat = malloc(sizeof(int) * np);
  if (rank_ == 0)
    for (int j = 0; j < 64; j++)
      for (int i = 0; i < 64; i++, mine++) {
        x[mine] = (i + 0.5) * h / 2;
        y[mine] = (j + 0.5) * h / 2;
        lp[mine] = h / 4;
        vx[mine] = v0 * sin(M_PI * x[mine] / L);
        vy[mine] = v0 * sin(M_PI * y[mine] / L);
        d[mine] = rho;
        mat[mine] = m;
      }
  MUST(gimlet_insert_particles(*sim, mine, x, y, lp, lp, vx, vy, NULL, d, mat));
  free(x), free(y), free(lp), free(vx), free(vy), free(d), free(mat);
  double dt;
  MUST(gimlet_stable_dt(*sim, &dt));
  return 0.8 * dt;
}

/* --------------------------------------------------- pressure indentation */

/* The paper's indentation of silicon by a surface pressure (section 4),
 * half model on `comm`: 40 um x 40 um, E = 170 GPa, nu = 0.18, rho = 2330
 * kg/m^3, plane strain 1 um thick, symmetry roller at x = 0, bottom fixed,
 * 2 x 2 particles per cell; a pressure of 2 GPa on the top surface for
 * x < 5 um, ramped over 1500 steps of 20 ps. Level-0 cells `h`; with
 * `levels` = 3, 0.5 um cells on [0, 20] x [20, 40] um and 0.25 um on
 * [0, 10] x [30, 40] um (each a quarter of the next coarser in area).
 * Every level is tiled by patches of px x py cells when px > 0. Returns the
 * coarse step, 20 ps. */
static double pressure_scene(GimletSim **sim, MPI_Comm comm, double h, int levels, int px, int py, Weights w) {
  const double um = 1e-6;
  MUST(gimlet_create(comm, 0, 0, 40 * um, 40 * um, h, sim));
  weights_set(*sim, w);
  if (levels == 3) {
    double b1[4] = {0, 20 * um, 20 * um, 40 * um}, b2[4] = {0, 30 * um, 10 * um, 40 * um};
    MUST(gimlet_add_level(*sim, b1, 1));
    MUST(gimlet_add_level(*sim, b2, 1));
  }
  if (px > 0)
    for (int l = 0; l < levels; l++) MUST(gimlet_set_patch_size(*sim, l, px, py));
  MUST(gimlet_set_thickness(*sim, 1 * um));
  int m;
  MUST(gimlet_add_material_linear_elastic(*sim, 170e9, 0.18, 2330.0, &m));
  MUST(gimlet_set_face_bc(*sim, GIMLET_FACE_LEFT, GIMLET_BC_ROLLER));
  MUST(gimlet_set_face_bc(*sim, GIMLET_FACE_BOTTOM, GIMLET_BC_FIXED));
  MUST(gimlet_fill_rectangle(*sim, 0, 0, 40 * um, 40 * um, 2, m, 2330.0, 0, 0, NULL));
  int64_t loaded = 0;
  MUST(gimlet_apply_traction(*sim, GIMLET_FACE_TOP, 40 * um, 0, 5 * um, 0, -2e9, &loaded));
  MUST(gimlet_set_load_ramp(*sim, 1500 * 20e-12));
  return 20e-12;
}

/* ------------------------------------------------ block under an indenter */

/* Tiles every level of `sim` with px x py patches (a refined level's boxes
 * with its 4-cell ghost ring; one box per level). */
static void patches_per_level(GimletSim *sim, int px, int py) {
  int levels = 0;
  MUST(gimlet_num_levels(sim, &levels));
  for (int l = 0; l < levels; l++) {
    int nboxes, npatches;
    int64_t count = 0;
    double hl, b[4];
    MUST(gimlet_level_info(sim, l, &hl, &nboxes, &npatches));
    MUST(gimlet_level_boxes(sim, l, b, 1, &count));
    int wx = (int)lround((b[2] - b[0]) / hl) + (l ? 4 : 0), wy = (int)lround((b[3] - b[1]) / hl) + (l ? 4 : 0);
    MUST(gimlet_set_patch_size(sim, l, (wx + px - 1) / px, (wy + py - 1) / py));
  }
}

enum { SHAPE_PUNCH, SHAPE_CYLINDER, SHAPE_WEDGE };

/* An elastic block, half model with the symmetry plane at x = 0 and the
 * bottom on rollers, under a rigid indenter whose tip starts `gap0` above
 * the block's top surface at x = 0. */
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
  Weights weights;       /* UGIMP_FLIP unless set: the contact figures were measured with it */
  int axisym;            /* 1: axisymmetric (x the radius, the indenter on the axis) */
} Block;

static Block block_defaults(void) {
  Block s = {.w = 1.0, .hb = 1.0, .top = 0.0, .h0 = 1.0 / 16, .levels = 1, .refine = 0.5, .px = 1, .py = 1,
             .e = 1e7, .nu = 0.3, .rho = 1000, .shape = SHAPE_PUNCH, .size = 0.25, .gap0 = 0, .scheme = -1,
             .flip = -1, .weights = UGIMP_FLIP, .axisym = 0};
  return s;
}

/* Builds the block; `*ind` receives the indenter. */
static GimletSim *block_build(const Block *s, int *ind) {
  GimletSim *sim = NULL;
  double top = s->top > 0 ? s->top : 2 * s->h0;
  MUST(gimlet_create(MPI_COMM_WORLD, 0, 0, s->w, s->hb + top, s->h0, &sim));
  double fx = 1.0, fy = 1.0;
  for (int l = 1; l < s->levels; l++) {
    fx *= s->refine;
    fy *= s->refine;
    double box[4] = {0, s->hb - fy * s->hb, fx * s->w, s->hb + top};
    MUST(gimlet_add_level(sim, box, 1));
  }
  patches_per_level(sim, s->px, s->py);
  /* In axisymmetry the free left face x = 0 is the axis (a roller). */
  if (s->axisym) MUST(gimlet_set_geometry(sim, GIMLET_AXISYMMETRIC));
  int m;
  MUST(gimlet_add_material_linear_elastic(sim, s->e, s->nu, s->rho, &m));
  if (!s->axisym) MUST(gimlet_set_face_bc(sim, GIMLET_FACE_LEFT, GIMLET_BC_ROLLER));
  MUST(gimlet_set_face_bc(sim, GIMLET_FACE_BOTTOM, GIMLET_BC_ROLLER));
  if (s->scheme >= 0) MUST(gimlet_set_scheme(sim, s->scheme));
  if (s->flip >= 0) MUST(gimlet_set_flip(sim, s->flip));
  weights_set(sim, s->weights);
  MUST(gimlet_fill_rectangle(sim, 0, 0, s->w, s->hb, 2, m, s->rho, 0, 0, NULL));
  double yt = s->hb + s->gap0;
  switch (s->shape) {
    case SHAPE_PUNCH:
      MUST(gimlet_add_indenter_flat_punch(sim, s->size, 0.0, 0.5 * s->hb, 0.0, yt, ind));
      break;
    case SHAPE_CYLINDER:
      MUST(gimlet_add_indenter_cylinder(sim, s->size, 0.0, yt, ind));
      break;
    default:
      MUST(gimlet_add_indenter_wedge(sim, s->size, 0.5 * s->hb, 0.0, yt, ind));
  }
  /* GIMLET_TEST_CONTACT_GAP=G runs the scene with another contact gap
   * (GIMLET_CONTACT_GAP; to compare the measuring points). */
  if (getenv("GIMLET_TEST_CONTACT_GAP"))
    MUST(gimlet_set_contact_option(sim, GIMLET_CONTACT_GAP, atof(getenv("GIMLET_TEST_CONTACT_GAP"))));
  return sim;
}

/* The plane-strain P-wave speed of the block. */
static double wave_speed(const Block *s) {
  double lam = s->e * s->nu / ((1 + s->nu) * (1 - 2 * s->nu)), mu = s->e / (2 * (1 + s->nu));
  return sqrt((lam + 2 * mu) / s->rho);
}

/* Every contact point of indenter `ind`, identical on every rank; arrays
 * malloc'ed, freed by contacts_free. */
typedef struct {
  int64_t n;
  double *x, *normal, *p, *len;
  int64_t *id;
  int *level;
} Contacts;

static Contacts contacts_get(GimletSim *sim, int ind) {
  Contacts c;
  MUST(gimlet_get_contacts(sim, ind, 0, &c.n, NULL, NULL, NULL, NULL, NULL, NULL, NULL));
  c.x = malloc(sizeof(double) * (2 * c.n + 2));
  c.normal = malloc(sizeof(double) * (2 * c.n + 2));
  c.p = malloc(sizeof(double) * (c.n + 1));
  c.len = malloc(sizeof(double) * (c.n + 1));
  c.id = malloc(sizeof(int64_t) * (c.n + 1));
  c.level = malloc(sizeof(int) * (c.n + 1));
  MUST(gimlet_get_contacts(sim, ind, c.n, &c.n, c.x, c.normal, c.p, c.len, c.id, c.level, NULL));
  return c;
}

static void contacts_free(Contacts *c) {
  free(c->x), free(c->normal), free(c->p), free(c->len), free(c->id), free(c->level);
}

/* -------------------------------------------------- particles by global id */

enum { REC_VALUES = 15 };

/* A particle: its global id and the components of the fields gathered, in
 * the order asked (unused values are zero). */
typedef struct {
  uint64_t id;
  double v[REC_VALUES];
} Rec;

/* A field for gather that the library does not have: the rank holding the
 * particle. */
#define FIELD_RANK (-1)

static int rec_by_id(const void *a, const void *b) {
  uint64_t x = ((const Rec *)a)->id, y = ((const Rec *)b)->id;
  return x < y ? -1 : x > y;
}

/* Every particle of `sim` on `comm` with the components of `fields` (in
 * order; FIELD_RANK for the holding rank), sorted by id, on rank 0 of
 * `comm` (NULL elsewhere); `*count` receives their number there. */
static Rec *gather(GimletSim *sim, MPI_Comm comm, const int *fields, int nfields, int64_t *count) {
  int64_t n = 0;
  MUST(gimlet_get_ids(sim, NULL, 0, &n));
  uint64_t *ids = malloc(8 * (size_t)(n + 1));
  MUST(gimlet_get_ids(sim, ids, n, &n));
  Rec *mine = calloc((size_t)(n + 1), sizeof(Rec));
  for (int64_t i = 0; i < n; i++) mine[i].id = ids[i];
  int me, size, at = 0;
  MPI_Comm_rank(comm, &me);
  MPI_Comm_size(comm, &size);
  for (int f = 0; f < nfields; f++) {
    if (fields[f] == FIELD_RANK) {
      for (int64_t i = 0; i < n; i++) mine[i].v[at] = rank_;
      at++;
      continue;
    }
    int nc = 0;
    int64_t nf = 0;
    MUST(gimlet_field_components(sim, fields[f], &nc));
    double *v = field(sim, fields[f], &nf);
    EXPECT(nf == n && at + nc <= REC_VALUES, "field %d: %lld particles (ids: %lld), %d values from %d", fields[f],
           (long long)nf, (long long)n, nc, at);
    for (int64_t i = 0; i < n && i < nf && at + nc <= REC_VALUES; i++)
      for (int c = 0; c < nc; c++) mine[i].v[at + c] = v[nc * i + c];
    at += nc;
    free(v);
  }
  int cnt = (int)(n * (int64_t)sizeof(Rec)), total = 0;
  int *counts = malloc(sizeof(int) * (size_t)size), *displ = malloc(sizeof(int) * (size_t)size);
  MPI_Gather(&cnt, 1, MPI_INT, counts, 1, MPI_INT, 0, comm);
  if (me == 0)
    for (int r = 0; r < size; r++) displ[r] = total, total += counts[r];
  Rec *all = me == 0 ? malloc((size_t)total + sizeof(Rec)) : NULL;
  MPI_Gatherv(mine, cnt, MPI_BYTE, all, counts, displ, MPI_BYTE, 0, comm);
  *count = total / (int64_t)sizeof(Rec);
  if (me == 0) qsort(all, (size_t)*count, sizeof(Rec), rec_by_id);
  free(ids), free(mine), free(counts), free(displ);
  return all;
}

/* Over two lists sorted by id, with the same ids (returns 0 otherwise):
 * the largest difference of each of the first `nv` values, and the largest
 * magnitude of each in either list. */
static int rec_diff(const Rec *a, int64_t na, const Rec *b, int64_t nb, int nv, double *diff, double *scale) {
  for (int c = 0; c < nv; c++) diff[c] = scale[c] = 0;
  if (!a || !b || na != nb) return 0;
  for (int64_t i = 0; i < na; i++) {
    if (a[i].id != b[i].id) return 0;
    for (int c = 0; c < nv; c++) {
      scale[c] = fmax(scale[c], fmax(fabs(a[i].v[c]), fabs(b[i].v[c])));
      diff[c] = fmax(diff[c], fabs(a[i].v[c] - b[i].v[c]));
    }
  }
  return 1;
}

/* For records that start with the position (2 values) and the stress (4):
 * the largest position difference over the largest coordinate, and the
 * largest stress difference over the largest stress component (a component
 * that vanishes, like a plate's shear, is measured against the stress
 * scale, not its own round-off). Returns 0 when the ids differ. */
static int pos_stress_diff(const Rec *a, int64_t na, const Rec *b, int64_t nb, double *dpos, double *dstress) {
  double diff[6], scale[6];
  int same = rec_diff(a, na, b, nb, 6, diff, scale);
  double ps = fmax(scale[0], scale[1]), ss = 0, dp = fmax(diff[0], diff[1]), ds = 0;
  for (int c = 2; c < 6; c++) ss = fmax(ss, scale[c]), ds = fmax(ds, diff[c]);
  *dpos = ps > 0 ? dp / ps : dp;
  *dstress = ss > 0 ? ds / ss : ds;
  return same;
}

#endif
