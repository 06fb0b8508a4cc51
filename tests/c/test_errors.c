/* Calls every entry point with bad input (NULL handles and buffers, zero or
 * negative sizes, non-nested and misaligned level boxes, particles outside
 * the domain) and checks that each returns a non-zero status with a message
 * naming the argument, that the process does not abort, and that the handle
 * is still usable after each rejected call. Run on 1 and 2 ranks. */
#include <math.h>
#include <mpi.h>
#include "check.h"

static void still_usable(GimletSim *sim) {
  int n = -1;
  EXPECT_OK(gimlet_num_levels(sim, &n));
  EXPECT_TRUE(n >= 1);
  int64_t local = -1, global = -1;
  EXPECT_OK(gimlet_particle_count(sim, &local, &global));
  EXPECT_TRUE(local >= 0 && global >= local);
}

int main(int argc, char **argv) {
  check_begin(&argc, &argv);
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);

  /* Version and last-error conventions. */
  int ma = -1, mi = -1, pa = -1;
  EXPECT_OK(gimlet_version(&ma, &mi, &pa));
  EXPECT_TRUE(ma == GIMLET_VERSION_MAJOR && mi == GIMLET_VERSION_MINOR && pa == GIMLET_VERSION_PATCH);
  EXPECT_OK(gimlet_version(NULL, NULL, NULL));

  /* Creation: NULL out, bad domain, MPI_COMM_NULL. */
  GimletSim *sim = NULL;
  EXPECT_STATUS(gimlet_create(MPI_COMM_WORLD, 0, 0, 1, 1, 0.1, NULL), GIMLET_ERR_NULL_POINTER, "out");
  EXPECT_STATUS(gimlet_create(MPI_COMM_WORLD, 0, 0, -1, 1, 0.1, &sim), GIMLET_ERR_INVALID_ARGUMENT, "lx");
  EXPECT_STATUS(gimlet_create(MPI_COMM_WORLD, 0, 0, 1, 1, 0.0, &sim), GIMLET_ERR_INVALID_ARGUMENT, "h");
  EXPECT_STATUS(gimlet_create(MPI_COMM_WORLD, 0, 0, 1, 1, 0.3, &sim), GIMLET_ERR_INVALID_ARGUMENT, "lx/h");
  EXPECT_STATUS(gimlet_create(MPI_COMM_NULL, 0, 0, 1, 1, 0.1, &sim), GIMLET_ERR_INVALID_ARGUMENT, "comm");
  EXPECT_TRUE(sim == NULL); /* outputs untouched on failure */

  /* The last-error getter: length query, truncation. */
  size_t needed = 0;
  EXPECT_OK(gimlet_last_error(NULL, 0, &needed));
  EXPECT_TRUE(needed > 5);
  char tiny[4] = {'x', 'x', 'x', 'x'};
  EXPECT_OK(gimlet_last_error(tiny, sizeof tiny, NULL));
  EXPECT_TRUE(tiny[3] == 0 && strlen(tiny) == 3);
  EXPECT_STATUS(gimlet_last_error(NULL, 10, NULL), GIMLET_ERR_NULL_POINTER, NULL);

  /* A 60 x 40 domain, cells of 1; the caller's communicator is duplicated. */
  EXPECT_OK(gimlet_create(MPI_COMM_WORLD, 0, 0, 60, 40, 1.0, &sim));
  EXPECT_TRUE(sim != NULL);
  if (!sim) { MPI_Abort(MPI_COMM_WORLD, 1); }

  /* NULL handle on every entry point. */
  int iv = 0; double dv = 0; int64_t cnt = 0;
  const char *nul = "sim is NULL";
  EXPECT_STATUS(gimlet_comm_info(NULL, &iv, &iv), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_set_thickness(NULL, 1.0), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_add_material_linear_elastic(NULL, 1, 0.3, 1, &iv), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_add_material_neo_hookean(NULL, 1, 0.3, 1, &iv), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_add_material_j2_linear(NULL, 1, 0.3, 1, 1e-3, 0, &iv), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_add_material_j2_power(NULL, 1, 0.3, 1, 1e-3, 0.1, 1e-3, &iv), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_set_nesting_buffer(NULL, 2), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_add_level(NULL, NULL, 1), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_set_patch_size(NULL, 0, 8, 8), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_num_levels(NULL, &iv), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_level_info(NULL, 0, &dv, &iv, &iv), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_level_boxes(NULL, 0, NULL, 0, &cnt), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_level_patches(NULL, 0, NULL, NULL, 0, &cnt), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_insert_particles(NULL, 0, NULL, NULL, NULL, NULL, NULL, NULL, NULL, NULL, NULL), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_fill_rectangle(NULL, 0, 0, 1, 1, 2, 0, 1, 0, 0, NULL), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_particle_count(NULL, &cnt, &cnt), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_level_particle_count(NULL, 0, &cnt), GIMLET_ERR_NULL_POINTER, nul);
  double buf8[8];
  uint64_t ids8[8];
  EXPECT_STATUS(gimlet_field_components(NULL, 0, &iv), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_get_field(NULL, 0, buf8, 4, &cnt), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_set_field(NULL, 1, buf8, 0), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_get_ids(NULL, ids8, 8, &cnt), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_diagnostics(NULL, &dv, &dv, &dv, &dv, &dv), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_lost_particles(NULL, ids8, buf8, 4, &cnt), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_patch_crossings(NULL, &cnt), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_set_shape(NULL, GIMLET_SHAPE_UGIMP), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_set_scheme(NULL, GIMLET_SCHEME_USL), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_set_flip(NULL, 1.0), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_set_transfer(NULL, GIMLET_TRANSFER_APIC), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_set_xpic_order(NULL, 5), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_set_cfl(NULL, 0.5), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_set_gravity(NULL, 0, -9.8), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_set_face_bc(NULL, GIMLET_FACE_LEFT, GIMLET_BC_ROLLER), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_set_load_ramp(NULL, 1.0), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_set_outflow(NULL, GIMLET_OUTFLOW_REMOVE), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_apply_traction(NULL, GIMLET_FACE_TOP, 1, 0, 1, 0, -1, &cnt), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_stable_dt(NULL, &dv), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_step(NULL, 0.0, &dv, &cnt), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_advance_to(NULL, 1.0, 10, &dv, &cnt), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_time(NULL, &dv, &cnt), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_add_indenter_wedge(NULL, 65, 1, 0, 0, &iv), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_add_indenter_cylinder(NULL, 1, 0, 0, &iv), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_add_indenter_flat_punch(NULL, 1, 0, 1, 0, 0, &iv), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_add_indenter_polygon(NULL, 0, NULL, 0, 0, &iv), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_set_indenter_motion(NULL, 0, 0, 0, NULL, NULL), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_indenter_state(NULL, 0, NULL, NULL, NULL, NULL), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_get_contacts(NULL, -1, 0, &cnt, NULL, NULL, NULL, NULL, NULL, NULL, NULL),
                GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_set_contact_option(NULL, 0, 0.1), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_set_petsc_options(NULL, ""), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_contact_stats(NULL, NULL, NULL), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_level_stats(NULL, 0, NULL, NULL), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_output_open(NULL, "out", "x"), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_write_output(NULL), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_csv_open(NULL, "x.csv"), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_csv_append(NULL), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_write_checkpoint(NULL, "x.h5"), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_read_checkpoint(NULL, "x.h5"), GIMLET_ERR_NULL_POINTER, nul);
  EXPECT_STATUS(gimlet_check_xdmf(NULL, "x.xdmf", &cnt), GIMLET_ERR_NULL_POINTER, nul);

  /* NULL outputs. */
  EXPECT_STATUS(gimlet_comm_info(sim, NULL, &iv), GIMLET_ERR_NULL_POINTER, "rank");
  EXPECT_STATUS(gimlet_num_levels(sim, NULL), GIMLET_ERR_NULL_POINTER, "nlevels");
  EXPECT_STATUS(gimlet_level_boxes(sim, 0, NULL, 0, NULL), GIMLET_ERR_NULL_POINTER, "count");
  EXPECT_STATUS(gimlet_level_particle_count(sim, 0, NULL), GIMLET_ERR_NULL_POINTER, "local");
  EXPECT_STATUS(gimlet_add_material_linear_elastic(sim, 1, 0.3, 1, NULL), GIMLET_ERR_NULL_POINTER, "id");
  EXPECT_STATUS(gimlet_add_material_j2_linear(sim, 1, 0.3, 1, 1e-3, 0, NULL), GIMLET_ERR_NULL_POINTER, "id");
  EXPECT_STATUS(gimlet_add_material_j2_power(sim, 1, 0.3, 1, 1e-3, 0.1, 1e-3, NULL), GIMLET_ERR_NULL_POINTER, "id");
  EXPECT_STATUS(gimlet_get_field(sim, 0, buf8, 4, NULL), GIMLET_ERR_NULL_POINTER, "count");
  EXPECT_STATUS(gimlet_write_checkpoint(sim, NULL), GIMLET_ERR_NULL_POINTER, "path");
  EXPECT_STATUS(gimlet_create_from_checkpoint(MPI_COMM_WORLD, "/nonexistent/gimlet.h5", NULL), GIMLET_ERR_NULL_POINTER, "out");
  still_usable(sim);

  /* Settings out of bounds: the message names the argument. */
  EXPECT_STATUS(gimlet_set_shape(sim, 7), GIMLET_ERR_INVALID_ARGUMENT, "shape");
  EXPECT_STATUS(gimlet_set_scheme(sim, -1), GIMLET_ERR_INVALID_ARGUMENT, "scheme");
  EXPECT_STATUS(gimlet_set_flip(sim, 1.5), GIMLET_ERR_INVALID_ARGUMENT, "flip");
  EXPECT_STATUS(gimlet_set_transfer(sim, 3), GIMLET_ERR_INVALID_ARGUMENT, "transfer");
  EXPECT_STATUS(gimlet_set_xpic_order(sim, 0), GIMLET_ERR_INVALID_ARGUMENT, "xpic order");
  EXPECT_STATUS(gimlet_set_xpic_order(sim, 17), GIMLET_ERR_INVALID_ARGUMENT, "xpic order");
  EXPECT_STATUS(gimlet_set_cfl(sim, 0.0), GIMLET_ERR_INVALID_ARGUMENT, "cfl");
  EXPECT_STATUS(gimlet_set_cfl(sim, 1.5), GIMLET_ERR_INVALID_ARGUMENT, "cfl");
  EXPECT_STATUS(gimlet_set_gravity(sim, 0.0 / 0.0, 0), GIMLET_ERR_INVALID_ARGUMENT, "gravity");
  EXPECT_STATUS(gimlet_set_face_bc(sim, 4, GIMLET_BC_FIXED), GIMLET_ERR_INVALID_ARGUMENT, "face");
  EXPECT_STATUS(gimlet_set_face_bc(sim, GIMLET_FACE_TOP, 9), GIMLET_ERR_INVALID_ARGUMENT, "bc");
  EXPECT_STATUS(gimlet_set_load_ramp(sim, -1.0), GIMLET_ERR_INVALID_ARGUMENT, "t_ramp");
  EXPECT_STATUS(gimlet_set_outflow(sim, 3), GIMLET_ERR_INVALID_ARGUMENT, "policy");
  EXPECT_STATUS(gimlet_apply_traction(sim, GIMLET_FACE_TOP, 40, 5, 1, 0, -1, NULL), GIMLET_ERR_INVALID_ARGUMENT, "lo");
  EXPECT_STATUS(gimlet_field_components(sim, 42, &iv), GIMLET_ERR_INVALID_ARGUMENT, "field");
  EXPECT_STATUS(gimlet_get_field(sim, -1, buf8, 4, &cnt), GIMLET_ERR_INVALID_ARGUMENT, "field");
  EXPECT_STATUS(gimlet_set_field(sim, GIMLET_FIELD_POSITION, buf8, 0), GIMLET_ERR_INVALID_ARGUMENT, "field");
  EXPECT_STATUS(gimlet_set_field(sim, GIMLET_FIELD_VELOCITY, buf8, -2), GIMLET_ERR_INVALID_ARGUMENT, "n = -2");
  EXPECT_STATUS(gimlet_advance_to(sim, 1.0, 0, &dv, &cnt), GIMLET_ERR_INVALID_ARGUMENT, "max_steps");
  EXPECT_STATUS(gimlet_step(sim, 1e-3, NULL, NULL), GIMLET_ERR_INVALID_STATE, "material");
  EXPECT_STATUS(gimlet_read_checkpoint(sim, "/nonexistent/gimlet.h5"), GIMLET_ERR_IO, "/nonexistent/gimlet.h5");
  still_usable(sim);

  /* Materials out of bounds. */
  EXPECT_STATUS(gimlet_add_material_linear_elastic(sim, -1, 0.3, 1, &iv), GIMLET_ERR_INVALID_ARGUMENT, "e = -1");
  EXPECT_STATUS(gimlet_add_material_linear_elastic(sim, 1, 0.5, 1, &iv), GIMLET_ERR_INVALID_ARGUMENT, "nu");
  EXPECT_STATUS(gimlet_add_material_neo_hookean(sim, 1, 0.3, 0, &iv), GIMLET_ERR_INVALID_ARGUMENT, "rho");
  /* J2: the elastic constants as above, then each hardening parameter and
   * its bound (sigma_y > 0, h >= 0; sigma_0 > 0, 0 <= n < 1, eps_0 > 0). */
  const double inf = 1.0 / 0.0, nan = 0.0 / 0.0;
  EXPECT_STATUS(gimlet_add_material_j2_linear(sim, 0, 0.3, 1, 1e-3, 0, &iv), GIMLET_ERR_INVALID_ARGUMENT, "e = 0");
  EXPECT_STATUS(gimlet_add_material_j2_linear(sim, inf, 0.3, 1, 1e-3, 0, &iv), GIMLET_ERR_INVALID_ARGUMENT, "e = inf");
  EXPECT_STATUS(gimlet_add_material_j2_linear(sim, 1, -1, 1, 1e-3, 0, &iv), GIMLET_ERR_INVALID_ARGUMENT, "nu = -1");
  EXPECT_STATUS(gimlet_add_material_j2_power(sim, 1, 0.5, 1, 1e-3, 0.1, 1e-3, &iv), GIMLET_ERR_INVALID_ARGUMENT, "nu = 0.5");
  EXPECT_STATUS(gimlet_add_material_j2_power(sim, 1, 0.3, -1, 1e-3, 0.1, 1e-3, &iv), GIMLET_ERR_INVALID_ARGUMENT, "rho = -1");
  EXPECT_STATUS(gimlet_add_material_j2_linear(sim, 1, 0.3, 1, 0, 0, &iv), GIMLET_ERR_INVALID_ARGUMENT, "sigma_y = 0 must be finite and > 0");
  EXPECT_STATUS(gimlet_add_material_j2_linear(sim, 1, 0.3, 1, nan, 0, &iv), GIMLET_ERR_INVALID_ARGUMENT, "sigma_y = NaN");
  EXPECT_STATUS(gimlet_add_material_j2_linear(sim, 1, 0.3, 1, 1e-3, -1, &iv), GIMLET_ERR_INVALID_ARGUMENT, "h = -1 must be finite and >= 0");
  EXPECT_STATUS(gimlet_add_material_j2_linear(sim, 1, 0.3, 1, 1e-3, inf, &iv), GIMLET_ERR_INVALID_ARGUMENT, "h = inf");
  EXPECT_STATUS(gimlet_add_material_j2_power(sim, 1, 0.3, 1, -1e-3, 0.1, 1e-3, &iv), GIMLET_ERR_INVALID_ARGUMENT, "sigma_0 = -0.001 must be finite and > 0");
  EXPECT_STATUS(gimlet_add_material_j2_power(sim, 1, 0.3, 1, 1e-3, 1.0, 1e-3, &iv), GIMLET_ERR_INVALID_ARGUMENT, "n = 1 must lie in [0, 1)");
  EXPECT_STATUS(gimlet_add_material_j2_power(sim, 1, 0.3, 1, 1e-3, -0.5, 1e-3, &iv), GIMLET_ERR_INVALID_ARGUMENT, "n = -0.5");
  EXPECT_STATUS(gimlet_add_material_j2_power(sim, 1, 0.3, 1, 1e-3, nan, 1e-3, &iv), GIMLET_ERR_INVALID_ARGUMENT, "n = NaN");
  EXPECT_STATUS(gimlet_add_material_j2_power(sim, 1, 0.3, 1, 1e-3, 0.1, 0, &iv), GIMLET_ERR_INVALID_ARGUMENT, "eps_0 = 0 must be finite and > 0");
  EXPECT_STATUS(gimlet_add_material_j2_power(sim, 1, 0.3, 1, 1e-3, 0.1, inf, &iv), GIMLET_ERR_INVALID_ARGUMENT, "eps_0 = inf");
  /* The plastic strain is queried, not set. */
  EXPECT_OK(gimlet_field_components(sim, GIMLET_FIELD_PLASTIC_STRAIN, &iv));
  EXPECT_TRUE(iv == 1);
  EXPECT_STATUS(gimlet_set_field(sim, GIMLET_FIELD_PLASTIC_STRAIN, buf8, 0), GIMLET_ERR_INVALID_ARGUMENT, "field");
  EXPECT_STATUS(gimlet_set_thickness(sim, -2.0), GIMLET_ERR_INVALID_ARGUMENT, "thickness");
  still_usable(sim);

  /* Level boxes: zero and negative counts, NULL boxes, empty, misaligned,
   * outside the domain, overlapping, and not nested. */
  double good1[4] = {0, 20, 20, 40};
  EXPECT_STATUS(gimlet_add_level(sim, good1, 0), GIMLET_ERR_INVALID_ARGUMENT, "nboxes");
  EXPECT_STATUS(gimlet_add_level(sim, good1, -3), GIMLET_ERR_INVALID_ARGUMENT, "nboxes");
  EXPECT_STATUS(gimlet_add_level(sim, NULL, 1), GIMLET_ERR_NULL_POINTER, "boxes");
  double empty[4] = {5, 5, 5, 10};
  EXPECT_STATUS(gimlet_add_level(sim, empty, 1), GIMLET_ERR_INVALID_ARGUMENT, "empty");
  double misaligned[4] = {0.5, 20, 20, 40};
  EXPECT_STATUS(gimlet_add_level(sim, misaligned, 1), GIMLET_ERR_INVALID_ARGUMENT, "aligned");
  double outside[4] = {50, 20, 70, 40};
  EXPECT_STATUS(gimlet_add_level(sim, outside, 1), GIMLET_ERR_INVALID_ARGUMENT, "domain");
  double overlap[8] = {0, 20, 20, 40, 10, 10, 30, 30};
  EXPECT_STATUS(gimlet_add_level(sim, overlap, 2), GIMLET_ERR_INVALID_ARGUMENT, "overlaps");
  int nl = 0;
  EXPECT_OK(gimlet_num_levels(sim, &nl));
  EXPECT_TRUE(nl == 1); /* nothing was added by the rejected calls */
  EXPECT_OK(gimlet_add_level(sim, good1, 1));
  double not_nested[4] = {0, 30, 19, 40}; /* grown by 4 level-1 cells it leaves level 1 */
  EXPECT_STATUS(gimlet_add_level(sim, not_nested, 1), GIMLET_ERR_INVALID_ARGUMENT, "not nested");
  double misaligned2[4] = {0, 30, 10.25, 40}; /* level-1 cells are 0.5 */
  EXPECT_STATUS(gimlet_add_level(sim, misaligned2, 1), GIMLET_ERR_INVALID_ARGUMENT, "aligned");
  double good2[4] = {0, 30, 10, 40};
  EXPECT_OK(gimlet_add_level(sim, good2, 1));
  EXPECT_OK(gimlet_num_levels(sim, &nl));
  EXPECT_TRUE(nl == 3);
  still_usable(sim);

  /* Patch sizes and level indices. */
  EXPECT_STATUS(gimlet_set_patch_size(sim, 0, 0, 8), GIMLET_ERR_INVALID_ARGUMENT, "px");
  EXPECT_STATUS(gimlet_set_patch_size(sim, 0, 8, -1), GIMLET_ERR_INVALID_ARGUMENT, "py");
  EXPECT_STATUS(gimlet_set_patch_size(sim, 3, 8, 8), GIMLET_ERR_INVALID_ARGUMENT, "level");
  EXPECT_STATUS(gimlet_set_patch_size(sim, -1, 8, 8), GIMLET_ERR_INVALID_ARGUMENT, "level");
  EXPECT_STATUS(gimlet_level_info(sim, 7, &dv, &iv, &iv), GIMLET_ERR_INVALID_ARGUMENT, "level");
  EXPECT_STATUS(gimlet_level_stats(sim, -1, NULL, NULL), GIMLET_ERR_INVALID_ARGUMENT, "level");
  EXPECT_OK(gimlet_set_patch_size(sim, 0, 30, 20));
  EXPECT_OK(gimlet_set_patch_size(sim, 1, 20, 20));

  /* Caller buffers: count query, too small, negative capacity. */
  int64_t np = 0;
  EXPECT_OK(gimlet_level_patches(sim, 0, NULL, NULL, 0, &np));
  EXPECT_TRUE(np == 4);
  int64_t cells[16]; int owner[4];
  int64_t got = -7;
  EXPECT_STATUS(gimlet_level_patches(sim, 0, cells, owner, 2, &got), GIMLET_ERR_BUFFER_TOO_SMALL, "capacity");
  EXPECT_TRUE(got == 4);
  EXPECT_STATUS(gimlet_level_patches(sim, 0, cells, owner, -1, &got), GIMLET_ERR_INVALID_ARGUMENT, "capacity");
  EXPECT_OK(gimlet_level_patches(sim, 0, cells, owner, 4, &got));
  EXPECT_TRUE(got == 4 && owner[0] == -1); /* owners are decided at freeze */
  double bx[4];
  EXPECT_OK(gimlet_level_boxes(sim, 2, bx, 1, &got));
  EXPECT_TRUE(got == 1 && bx[0] == 0 && bx[1] == 30 && bx[2] == 10 && bx[3] == 40);

  /* Particles: before any material, NULL arrays, negative n, outside the
   * domain, too large, both mass and density. */
  double x[3] = {10, 30, 50}, y[3] = {10, 10, 10}, lp[3] = {0.25, 0.25, 0.25};
  double v[3] = {0, 0, 0}, rho[3] = {2700, 2700, 2700};
  int mat[3] = {0, 0, 0};
  EXPECT_STATUS(gimlet_insert_particles(sim, 3, x, y, lp, lp, v, v, NULL, rho, mat), GIMLET_ERR_INVALID_STATE, "material");
  int m0 = -1;
  EXPECT_OK(gimlet_add_material_linear_elastic(sim, 70e9, 0.33, 2700, &m0));
  EXPECT_TRUE(m0 == 0);
  EXPECT_STATUS(gimlet_insert_particles(sim, -1, x, y, lp, lp, v, v, NULL, rho, mat), GIMLET_ERR_INVALID_ARGUMENT, "n = -1");
  EXPECT_STATUS(gimlet_insert_particles(sim, 3, NULL, y, lp, lp, v, v, NULL, rho, mat), GIMLET_ERR_NULL_POINTER, "x is NULL");
  EXPECT_STATUS(gimlet_insert_particles(sim, 3, x, y, lp, lp, v, v, NULL, NULL, mat), GIMLET_ERR_NULL_POINTER, "density");
  EXPECT_STATUS(gimlet_insert_particles(sim, 3, x, y, lp, lp, v, v, rho, rho, mat), GIMLET_ERR_INVALID_ARGUMENT, "exactly one");
  double xbad[3] = {10, 30, 61}; /* the last one is outside [0, 60] */
  EXPECT_STATUS(gimlet_insert_particles(sim, 3, xbad, y, lp, lp, v, v, NULL, rho, mat), GIMLET_ERR_INVALID_ARGUMENT, "outside the domain");
  double lpbad[3] = {0.25, 0.75, 0.25}; /* > h/2 = 0.5 of level 0 */
  EXPECT_STATUS(gimlet_insert_particles(sim, 3, x, y, lpbad, lp, v, v, NULL, rho, mat), GIMLET_ERR_INVALID_ARGUMENT, "lpx");
  int matbad[3] = {0, 3, 0};
  EXPECT_STATUS(gimlet_insert_particles(sim, 3, x, y, lp, lp, v, v, NULL, rho, matbad), GIMLET_ERR_INVALID_ARGUMENT, "material");
  /* A bad particle on the last rank only: every rank fails, none inserts. */
  double *xr = (rank == size - 1) ? xbad : x;
  int rc = gimlet_insert_particles(sim, 3, xr, y, lp, lp, v, v, NULL, rho, mat);
  EXPECT_TRUE(rc == GIMLET_ERR_INVALID_ARGUMENT);
  int64_t local = -1, global = -1;
  EXPECT_OK(gimlet_particle_count(sim, &local, &global));
  EXPECT_TRUE(global == 0);
  EXPECT_STATUS(gimlet_fill_rectangle(sim, 10, 10, 70, 20, 2, 0, 2700, 0, 0, NULL), GIMLET_ERR_INVALID_ARGUMENT, "rect");
  EXPECT_STATUS(gimlet_fill_rectangle(sim, 10, 10, 20, 20, 0, 0, 2700, 0, 0, NULL), GIMLET_ERR_INVALID_ARGUMENT, "n_per_cell");
  EXPECT_STATUS(gimlet_fill_rectangle(sim, 10, 10, 20, 20, -2, 0, 2700, 0, 0, NULL), GIMLET_ERR_INVALID_ARGUMENT, "n_per_cell");
  EXPECT_STATUS(gimlet_fill_rectangle(sim, 10, 10, 20, 20, 2, 5, 2700, 0, 0, NULL), GIMLET_ERR_INVALID_ARGUMENT, "material");
  EXPECT_STATUS(gimlet_fill_rectangle(sim, 10, 10, 20, 20, 2, 0, -1, 0, 0, NULL), GIMLET_ERR_INVALID_ARGUMENT, "density");
  still_usable(sim);

  /* Valid insertion: every rank inserts 3, then the layout is frozen. */
  EXPECT_OK(gimlet_insert_particles(sim, 3, x, y, lp, lp, v, v, NULL, rho, mat));
  EXPECT_OK(gimlet_particle_count(sim, &local, &global));
  EXPECT_TRUE(global == 3 * size);
  EXPECT_STATUS(gimlet_add_level(sim, good2, 1), GIMLET_ERR_INVALID_STATE, "frozen");
  EXPECT_STATUS(gimlet_set_patch_size(sim, 0, 10, 10), GIMLET_ERR_INVALID_STATE, "frozen");
  EXPECT_STATUS(gimlet_set_thickness(sim, 2.0), GIMLET_ERR_INVALID_STATE, "frozen");
  int64_t added = 0;
  EXPECT_OK(gimlet_fill_rectangle(sim, 0, 0, 60, 40, 2, 0, 2700, 0, 0, &added));
  /* 2x2 particles per cell of the owning level, except in the band of 4
   * coarse cells around each refined region, where the coarse level holds
   * fine-sized particles (4x4 per cell). Level 0: 60x40 cells, 20x20 under
   * level 1, band 24x24 - 20x20 = 176 cells (clipped by the domain edges).
   * Level 1: 40x40 cells, 20x20 under level 2, band 176 cells. Level 2:
   * 40x40 cells. */
  int64_t expect = 4 * (60 * 40 - 400 - 176) + 16 * 176 + 4 * (40 * 40 - 400 - 176) + 16 * 176 + 4 * (40 * 40);
  EXPECT_TRUE(added == expect);
  EXPECT_OK(gimlet_particle_count(sim, &local, &global));
  EXPECT_TRUE(global == expect + 3 * size);
  EXPECT_OK(gimlet_level_patches(sim, 0, cells, owner, 4, &got));
  EXPECT_TRUE(owner[0] >= 0 && owner[0] < size);
  double sdt = 0;
  EXPECT_OK(gimlet_stable_dt(sim, &sdt));
  EXPECT_TRUE(sdt > 0);
  EXPECT_STATUS(gimlet_step(sim, 2.0 * sdt, NULL, NULL), GIMLET_ERR_UNSTABLE, "stable step");
  EXPECT_STATUS(gimlet_step(sim, 0.0 / 0.0, NULL, NULL), GIMLET_ERR_INVALID_ARGUMENT, "dt");
  double t_now = -1;
  int64_t nsteps = -1;
  EXPECT_OK(gimlet_time(sim, &t_now, &nsteps));
  EXPECT_TRUE(t_now == 0.0 && nsteps == 0); /* rejected steps change nothing */
  EXPECT_OK(gimlet_step(sim, 0.0, &t_now, &nsteps)); /* dt <= 0: the stable step */
  EXPECT_TRUE(nsteps == 1 && t_now > 0);
  EXPECT_STATUS(gimlet_advance_to(sim, 0.5 * t_now, 10, NULL, NULL), GIMLET_ERR_INVALID_ARGUMENT, "t_end");
  int64_t nloc = 0;
  EXPECT_OK(gimlet_get_field(sim, GIMLET_FIELD_VELOCITY, NULL, 0, &nloc));
  double *vbig = calloc((size_t)(2 * (nloc + 1)), sizeof(double));
  EXPECT_STATUS(gimlet_set_field(sim, GIMLET_FIELD_VELOCITY, vbig, nloc + 1), GIMLET_ERR_INVALID_ARGUMENT, "local particles");
  free(vbig);
  still_usable(sim);

  /* Indenters: bad geometry and motion are rejected, naming the argument. */
  int ind = -1;
  EXPECT_STATUS(gimlet_add_indenter_wedge(sim, 95, 1, 0, 0, &ind), GIMLET_ERR_INVALID_ARGUMENT, "half_angle_deg");
  EXPECT_STATUS(gimlet_add_indenter_wedge(sim, 65, 0, 0, 0, &ind), GIMLET_ERR_INVALID_ARGUMENT, "height");
  EXPECT_STATUS(gimlet_add_indenter_wedge(sim, 65, 1, NAN, 0, &ind), GIMLET_ERR_INVALID_ARGUMENT, "x_tip");
  EXPECT_STATUS(gimlet_add_indenter_wedge(sim, 65, 1, 0, 0, NULL), GIMLET_ERR_NULL_POINTER, "indenter");
  EXPECT_STATUS(gimlet_add_indenter_cylinder(sim, 0, 0, 0, &ind), GIMLET_ERR_INVALID_ARGUMENT, "radius");
  EXPECT_STATUS(gimlet_add_indenter_cylinder(sim, NAN, 0, 0, &ind), GIMLET_ERR_INVALID_ARGUMENT, "radius");
  EXPECT_STATUS(gimlet_add_indenter_flat_punch(sim, 1, -0.5, 1, 0, 0, &ind), GIMLET_ERR_INVALID_ARGUMENT,
                "corner_radius");
  EXPECT_STATUS(gimlet_add_indenter_flat_punch(sim, 0, 0, 1, 0, 0, &ind), GIMLET_ERR_INVALID_ARGUMENT, "half_width");
  double bow[8] = {0, 0, 2, 1, 0, 2, 1, 1}, tri[6] = {0, 0, 1, 1, -1, 1};
  EXPECT_STATUS(gimlet_add_indenter_polygon(sim, 4, bow, 0, 0, &ind), GIMLET_ERR_INVALID_ARGUMENT, "convex");
  EXPECT_STATUS(gimlet_add_indenter_polygon(sim, 2, tri, 0, 0, &ind), GIMLET_ERR_INVALID_ARGUMENT, "n = 2");
  EXPECT_STATUS(gimlet_add_indenter_polygon(sim, 3, NULL, 0, 0, &ind), GIMLET_ERR_NULL_POINTER, "xy");
  EXPECT_TRUE(ind == -1); /* outputs untouched on failure */
  EXPECT_STATUS(gimlet_set_indenter_motion(sim, 0, GIMLET_MOTION_DEPTH, 1, &t_now, &t_now),
                GIMLET_ERR_INVALID_ARGUMENT, "indenter = 0");
  EXPECT_OK(gimlet_add_indenter_polygon(sim, 3, tri, 30, 45, &ind));
  EXPECT_TRUE(ind == 0);
  double tt[3] = {0, 1, 0.5}, vv[3] = {0, 1, NAN};
  EXPECT_STATUS(gimlet_set_indenter_motion(sim, ind, GIMLET_MOTION_DEPTH, 3, tt, vv), GIMLET_ERR_INVALID_ARGUMENT,
                "times");
  tt[2] = 2;
  EXPECT_STATUS(gimlet_set_indenter_motion(sim, ind, GIMLET_MOTION_VELOCITY, 3, tt, vv), GIMLET_ERR_INVALID_ARGUMENT,
                "speed[2]");
  EXPECT_STATUS(gimlet_set_indenter_motion(sim, ind, 5, 3, tt, vv), GIMLET_ERR_INVALID_ARGUMENT, "kind");
  EXPECT_STATUS(gimlet_set_indenter_motion(sim, ind, GIMLET_MOTION_DEPTH, 0, tt, vv), GIMLET_ERR_INVALID_ARGUMENT, "n = 0");
  EXPECT_STATUS(gimlet_set_indenter_motion(sim, ind, GIMLET_MOTION_DEPTH, -1, tt, vv), GIMLET_ERR_INVALID_ARGUMENT, "n");
  EXPECT_STATUS(gimlet_indenter_state(sim, 3, NULL, NULL, NULL, NULL), GIMLET_ERR_INVALID_ARGUMENT, "indenter = 3");
  EXPECT_STATUS(gimlet_get_contacts(sim, 7, 0, &cnt, NULL, NULL, NULL, NULL, NULL, NULL, NULL),
                GIMLET_ERR_INVALID_ARGUMENT, "indenter = 7");
  EXPECT_STATUS(gimlet_get_contacts(sim, -1, 0, NULL, NULL, NULL, NULL, NULL, NULL, NULL, NULL),
                GIMLET_ERR_NULL_POINTER, "count");
  EXPECT_OK(gimlet_get_contacts(sim, -1, 0, &cnt, NULL, NULL, NULL, NULL, NULL, NULL, NULL));
  EXPECT_TRUE(cnt == 0);
  EXPECT_STATUS(gimlet_set_contact_option(sim, GIMLET_CONTACT_REGULARIZATION, 2.0), GIMLET_ERR_INVALID_ARGUMENT,
                "value = 2");
  EXPECT_STATUS(gimlet_set_contact_option(sim, GIMLET_CONTACT_DENSE_MAX, 1.5), GIMLET_ERR_INVALID_ARGUMENT,
                "integer");
  EXPECT_STATUS(gimlet_set_contact_option(sim, 17, 0.5), GIMLET_ERR_INVALID_ARGUMENT, "option = 17");
  EXPECT_STATUS(gimlet_set_petsc_options(sim, NULL), GIMLET_ERR_NULL_POINTER, "options");
  still_usable(sim);

  /* Destroy: sets the pointer to NULL; NULL and pointer-to-NULL are no-ops. */
  EXPECT_OK(gimlet_destroy(&sim));
  EXPECT_TRUE(sim == NULL);
  EXPECT_OK(gimlet_destroy(&sim));
  EXPECT_OK(gimlet_destroy(NULL));

  /* The Fortran-handle variant. */
  EXPECT_OK(gimlet_create_f(MPI_Comm_c2f(MPI_COMM_WORLD), 0, 0, 1, 1, 0.25, &sim));
  EXPECT_OK(gimlet_comm_info(sim, &iv, &ma));
  EXPECT_TRUE(iv == rank && ma == size);
  EXPECT_OK(gimlet_destroy(&sim));

  return check_end("test_errors");
}
