/* Gimlet quickstart: a rigid flat punch presses into an elastic block that sits on
 * rollers (uniaxial strain), with a finer level under the punch. */
#include <mpi.h>
#include <stdio.h>
#include "gimlet.h"

#define CHECK(call) do { if ((call) != GIMLET_OK) { char m_[512];                   \
    gimlet_last_error(m_, sizeof m_, NULL); fprintf(stderr, "%s\n", m_);            \
    MPI_Abort(MPI_COMM_WORLD, 1); } } while (0)

int main(int argc, char **argv) {
  MPI_Init(&argc, &argv);
  GimletSim *sim = NULL;
  int mat, punch, rank;
  double E = 1e7, nu = 0.3, rho = 1000, d = 0.005; /* Pa, -, kg/m^3, final depth (m) */
  CHECK(gimlet_create(MPI_COMM_WORLD, 0, 0, 1, 1.25, 1.0 / 16, &sim)); /* 16 x 20 cells */
  double top[4] = {0, 0.75, 1, 1.25}; /* level 1 (cells of 1/32) over the top */
  CHECK(gimlet_add_level(sim, top, 1));
  CHECK(gimlet_set_face_bc(sim, GIMLET_FACE_LEFT, GIMLET_BC_ROLLER));
  CHECK(gimlet_set_face_bc(sim, GIMLET_FACE_RIGHT, GIMLET_BC_ROLLER));
  CHECK(gimlet_set_face_bc(sim, GIMLET_FACE_BOTTOM, GIMLET_BC_ROLLER));
  CHECK(gimlet_add_material_linear_elastic(sim, E, nu, rho, &mat));
  CHECK(gimlet_fill_rectangle(sim, 0, 0, 1, 1, 2, mat, rho, 0, 0, NULL)); /* 1 m x 1 m */
  CHECK(gimlet_add_indenter_flat_punch(sim, 1, 0, 0.25, 0.5, 1, &punch)); /* 2 m wide */
  double t[4] = {0, 0.05, 0.1, 0.15}, v[4] = {0, d / 0.1, d / 0.1, 0}; /* speed ramps */
  CHECK(gimlet_set_indenter_motion(sim, punch, GIMLET_MOTION_VELOCITY, 4, t, v));
  CHECK(gimlet_advance_to(sim, 0.15, 100000, NULL, NULL));
  double depth, force[2];
  CHECK(gimlet_indenter_state(sim, punch, &depth, NULL, force, NULL));
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  if (rank == 0) /* closed form: P-wave modulus x strain x width */
    printf("depth %.6e m, load %.9e N/m, uniaxial strain %.9e N/m\n", depth, force[1],
           E * (1 - nu) / ((1 + nu) * (1 - 2 * nu)) * depth);
  CHECK(gimlet_destroy(&sim));
  MPI_Finalize();
  return 0;
}
