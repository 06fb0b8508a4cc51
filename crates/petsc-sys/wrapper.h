/* The PETSc headers Gimlet's bindings are generated from (petscksp.h pulls in
 * petscpc.h, petscmat.h, petscvec.h and petscsys.h). */
#include <petscksp.h>
