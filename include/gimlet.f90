! Gimlet's Fortran interface: `use gimlet` in a Fortran 2008 host.
!
! The module declares, with bind(C) interfaces (iso_c_binding), every C
! function of gimlet.h that a Fortran program can call, and the constants of
! gimlet.h as named constants. Each function returns an integer(c_int) status,
! GIMLET_OK (0) on success; after a failure gimlet_error_message() returns the
! library's one-sentence explanation as a Fortran string. The C header's
! documentation (gimlet.h) is the reference for what each call does; the
! conventions below are what changes on the Fortran side.
!
! Building: compile this file with your program (find_package(Gimlet CONFIG)
! sets Gimlet_FORTRAN_MODULE to the installed copy) and link the Gimlet
! library (Gimlet::gimlet) and your MPI's Fortran library. A gimlet.mod
! installed next to this file is not enough on its own: the code of
! gimlet_error_message() is compiled from this file.
!
! Conventions
! - Communicators: call gimlet_create_f and gimlet_create_from_checkpoint_f
!   with the Fortran handle (`use mpi`: an integer such as MPI_COMM_WORLD;
!   `use mpi_f08`: comm%MPI_VAL). The library duplicates the communicator;
!   the caller keeps and frees its own. The C functions gimlet_create and
!   gimlet_create_from_checkpoint take a C MPI_Comm, which Fortran cannot
!   name portably; they are deliberately not declared here.
! - MPI must be initialised by the caller (MPI_Init) and the handle destroyed
!   (gimlet_destroy) before MPI_Finalize.
! - Handles: `type(c_ptr) :: sim`. Creating calls receive it by reference and
!   leave it unchanged on failure (initialise it to c_null_ptr);
!   gimlet_destroy(sim) sets it back to c_null_ptr.
! - Strings to C (paths, names) must be NUL-terminated: pass
!   `trim(path)//c_null_char`.
! - Integers: int is integer(c_int); int64_t is integer(c_int64_t); the
!   uint64_t particle ids are also received as integer(c_int64_t) (the same
!   bits; ids stay below 2**63, so they read as non-negative numbers);
!   size_t is integer(c_size_t). Reals are real(c_double).
! - Outputs are passed by reference and are written only on success (the
!   count of a call failing with GIMLET_ERR_BUFFER_TOO_SMALL is the
!   exception: it receives the needed count). Where the C documentation says
!   an output "may be NULL", Fortran passes a variable anyway.
! - Arrays are caller-owned, with the capacity (in records: particles,
!   boxes, patches) passed explicitly. The C convention "pass NULL to ask for
!   the count only" becomes: pass a buffer with capacity 0; the call returns
!   GIMLET_ERR_BUFFER_TOO_SMALL and sets count (or get the count from
!   gimlet_particle_count, gimlet_level_info and friends first). Records are
!   interleaved, so a field of ncomp components fits a Fortran array
!   real(c_double) :: out(ncomp, capacity).
! - gimlet_insert_particles takes exactly one of mass and density: these two
!   are type(c_ptr), value; pass c_loc(array) (the array needs the target
!   attribute) for the one given and c_null_ptr for the other.
!
! This file is kept in sync with gimlet.h by a test (the names, argument
! lists and constants are compared: tests/cmake/hosts/check_fortran_interfaces.cmake).

module gimlet
  use, intrinsic :: iso_c_binding, only: c_int, c_int64_t, c_size_t, c_double, &
                                         c_char, c_ptr, c_null_ptr, c_null_char
  implicit none

  ! Version of the interface (the GIMLET_VERSION_* macros of gimlet.h).
  integer(c_int), parameter :: GIMLET_VERSION_MAJOR = 0
  integer(c_int), parameter :: GIMLET_VERSION_MINOR = 1
  integer(c_int), parameter :: GIMLET_VERSION_PATCH = 0
  character(len=*), parameter :: GIMLET_VERSION_STRING = "0.1.0"

  ! Status codes.
  integer(c_int), parameter :: GIMLET_OK = 0
  integer(c_int), parameter :: GIMLET_ERR_NULL_POINTER = 1
  integer(c_int), parameter :: GIMLET_ERR_INVALID_ARGUMENT = 2
  integer(c_int), parameter :: GIMLET_ERR_INVALID_STATE = 3
  integer(c_int), parameter :: GIMLET_ERR_MPI = 4
  integer(c_int), parameter :: GIMLET_ERR_PETSC = 5
  integer(c_int), parameter :: GIMLET_ERR_IO = 6
  integer(c_int), parameter :: GIMLET_ERR_BUFFER_TOO_SMALL = 7
  integer(c_int), parameter :: GIMLET_ERR_UNSTABLE = 8
  integer(c_int), parameter :: GIMLET_ERR_PARTICLES_LEFT = 9
  integer(c_int), parameter :: GIMLET_ERR_INTERNAL = 10

  ! Particle fields (number of components in parentheses).
  integer(c_int), parameter :: GIMLET_FIELD_POSITION = 0     ! x, y (2)
  integer(c_int), parameter :: GIMLET_FIELD_VELOCITY = 1     ! vx, vy (2)
  integer(c_int), parameter :: GIMLET_FIELD_STRESS = 2       ! Cauchy xx, yy, xy, zz (4)
  integer(c_int), parameter :: GIMLET_FIELD_STRAIN = 3       ! Green-Lagrange xx, yy, xy (3)
  integer(c_int), parameter :: GIMLET_FIELD_DEFGRAD = 4      ! F xx, xy, yx, yy (4)
  integer(c_int), parameter :: GIMLET_FIELD_HALF_LENGTH = 5  ! lpx, lpy (2)
  integer(c_int), parameter :: GIMLET_FIELD_MASS = 6         ! (1)
  integer(c_int), parameter :: GIMLET_FIELD_LEVEL = 7        ! (1, as a double)
  integer(c_int), parameter :: GIMLET_FIELD_VOLUME0 = 8      ! reference volume (1)
  integer(c_int), parameter :: GIMLET_FIELD_REFERENCE = 9    ! x0, y0 (2)
  integer(c_int), parameter :: GIMLET_FIELD_PLASTIC_STRAIN = 10 ! equivalent plastic strain (1)
  integer(c_int), parameter :: GIMLET_FIELD_CONTACT_PRESSURE = 11 ! contact pressure (1)
  integer(c_int), parameter :: GIMLET_FIELD_AFFINE = 12 ! APIC affine matrix C xx, xy, yx, yy (4)
  integer(c_int), parameter :: GIMLET_FIELD_HOOP_STRETCH = 13 ! F_theta_theta in axisymmetry, 1 in plane strain (1)

  ! Indenter motion kinds and contact options.
  integer(c_int), parameter :: GIMLET_MOTION_VELOCITY = 0
  integer(c_int), parameter :: GIMLET_MOTION_DEPTH = 1
  integer(c_int), parameter :: GIMLET_CONTACT_REGULARIZATION = 0
  integer(c_int), parameter :: GIMLET_CONTACT_KSP_RTOL = 1
  integer(c_int), parameter :: GIMLET_CONTACT_DENSE_MAX = 2
  integer(c_int), parameter :: GIMLET_CONTACT_BAND = 3
  integer(c_int), parameter :: GIMLET_CONTACT_GAP = 4
  integer(c_int), parameter :: GIMLET_CONTACT_FRICTION_TOL = 5
  integer(c_int), parameter :: GIMLET_CONTACT_FRICTION_MAX_ITER = 6

  ! Indices into the results of gimlet_indentation_analysis (add 1 for a
  ! Fortran array declared results(GIMLET_INDENTATION_RESULTS)).
  integer(c_int), parameter :: GIMLET_INDENTATION_MAX_LOAD = 0
  integer(c_int), parameter :: GIMLET_INDENTATION_DEPTH_AT_MAX_LOAD = 1
  integer(c_int), parameter :: GIMLET_INDENTATION_MAX_DEPTH = 2
  integer(c_int), parameter :: GIMLET_INDENTATION_UNLOAD_LOAD = 3
  integer(c_int), parameter :: GIMLET_INDENTATION_CONTACT_HALF_WIDTH = 4
  integer(c_int), parameter :: GIMLET_INDENTATION_FIT_ALPHA = 5
  integer(c_int), parameter :: GIMLET_INDENTATION_FIT_M = 6
  integer(c_int), parameter :: GIMLET_INDENTATION_FIT_H_F = 7
  integer(c_int), parameter :: GIMLET_INDENTATION_FIT_RMS = 8
  integer(c_int), parameter :: GIMLET_INDENTATION_FIT_POINTS = 9
  integer(c_int), parameter :: GIMLET_INDENTATION_STIFFNESS = 10
  integer(c_int), parameter :: GIMLET_INDENTATION_RESIDUAL_DEPTH = 11
  integer(c_int), parameter :: GIMLET_INDENTATION_HARDNESS = 12
  integer(c_int), parameter :: GIMLET_INDENTATION_REDUCED_MODULUS = 13
  integer(c_int), parameter :: GIMLET_INDENTATION_RESULTS = 14

  ! gimlet_indentation_analysis_axisym: tips, and indices into its results
  ! (add 1 for a Fortran array declared results(GIMLET_OP_RESULTS)).
  integer(c_int), parameter :: GIMLET_TIP_CONE = 0
  integer(c_int), parameter :: GIMLET_TIP_SPHERE = 1
  integer(c_int), parameter :: GIMLET_TIP_PARABOLOID = 2
  integer(c_int), parameter :: GIMLET_TIP_FLAT_PUNCH = 3
  integer(c_int), parameter :: GIMLET_OP_MAX_LOAD = 0
  integer(c_int), parameter :: GIMLET_OP_UNLOAD_LOAD = 1
  integer(c_int), parameter :: GIMLET_OP_UNLOAD_DEPTH = 2
  integer(c_int), parameter :: GIMLET_OP_FIT_B = 3
  integer(c_int), parameter :: GIMLET_OP_FIT_M = 4
  integer(c_int), parameter :: GIMLET_OP_FIT_H_F = 5
  integer(c_int), parameter :: GIMLET_OP_FIT_RMS = 6
  integer(c_int), parameter :: GIMLET_OP_FIT_POINTS = 7
  integer(c_int), parameter :: GIMLET_OP_STIFFNESS = 8
  integer(c_int), parameter :: GIMLET_OP_EPSILON = 9
  integer(c_int), parameter :: GIMLET_OP_BETA = 10
  integer(c_int), parameter :: GIMLET_OP_CONTACT_DEPTH = 11
  integer(c_int), parameter :: GIMLET_OP_AREA = 12
  integer(c_int), parameter :: GIMLET_OP_HARDNESS = 13
  integer(c_int), parameter :: GIMLET_OP_REDUCED_MODULUS = 14
  integer(c_int), parameter :: GIMLET_OP_RESIDUAL_DEPTH = 15
  integer(c_int), parameter :: GIMLET_OP_TRUE_CONTACT_RADIUS = 16
  integer(c_int), parameter :: GIMLET_OP_TRUE_AREA = 17
  integer(c_int), parameter :: GIMLET_OP_TRUE_HARDNESS = 18
  integer(c_int), parameter :: GIMLET_OP_TRUE_REDUCED_MODULUS = 19
  integer(c_int), parameter :: GIMLET_OP_AREA_RATIO = 20
  integer(c_int), parameter :: GIMLET_OP_TRUE_CONTACT_DEPTH = 21
  integer(c_int), parameter :: GIMLET_OP_RESULTS = 22

  ! gimlet_propose_levels: indenters, responses and indices into its results
  ! (add 1 for a Fortran array declared results(GIMLET_PROPOSAL_RESULTS)).
  integer(c_int), parameter :: GIMLET_PLANE_STRAIN = 0
  integer(c_int), parameter :: GIMLET_AXISYMMETRIC = 1
  integer(c_int), parameter :: GIMLET_INDENTER_WEDGE = 0
  integer(c_int), parameter :: GIMLET_INDENTER_CYLINDER = 1
  integer(c_int), parameter :: GIMLET_INDENTER_FLAT_PUNCH = 2
  integer(c_int), parameter :: GIMLET_INDENTER_CONE = 3
  integer(c_int), parameter :: GIMLET_INDENTER_SPHERE = 4
  integer(c_int), parameter :: GIMLET_INDENTER_CYLINDRICAL_PUNCH = 5
  integer(c_int), parameter :: GIMLET_RESPONSE_ELASTIC = 0
  integer(c_int), parameter :: GIMLET_RESPONSE_PLASTIC = 1
  integer(c_int), parameter :: GIMLET_PROPOSAL_CONTACT_HALF_WIDTH = 0
  integer(c_int), parameter :: GIMLET_PROPOSAL_FINEST_CELL = 1
  integer(c_int), parameter :: GIMLET_PROPOSAL_PARTICLES_ACROSS = 2
  integer(c_int), parameter :: GIMLET_PROPOSAL_RESULTS = 3

  ! Weight functions.
  integer(c_int), parameter :: GIMLET_SHAPE_MPM = 0
  integer(c_int), parameter :: GIMLET_SHAPE_UGIMP = 1
  integer(c_int), parameter :: GIMLET_SHAPE_CPGIMP = 2

  ! Update schemes.
  integer(c_int), parameter :: GIMLET_SCHEME_USF = 0
  integer(c_int), parameter :: GIMLET_SCHEME_USL = 1
  integer(c_int), parameter :: GIMLET_SCHEME_MUSL = 2
  ! Velocity transfer (gimlet_set_transfer)
  integer(c_int), parameter :: GIMLET_TRANSFER_FLIP = 0
  integer(c_int), parameter :: GIMLET_TRANSFER_APIC = 1
  integer(c_int), parameter :: GIMLET_TRANSFER_XPIC = 2

  ! Domain faces.
  integer(c_int), parameter :: GIMLET_FACE_LEFT = 0
  integer(c_int), parameter :: GIMLET_FACE_RIGHT = 1
  integer(c_int), parameter :: GIMLET_FACE_BOTTOM = 2
  integer(c_int), parameter :: GIMLET_FACE_TOP = 3

  ! Face conditions.
  integer(c_int), parameter :: GIMLET_BC_FREE = 0
  integer(c_int), parameter :: GIMLET_BC_FIXED = 1
  integer(c_int), parameter :: GIMLET_BC_ROLLER = 2

  ! Outflow policies.
  integer(c_int), parameter :: GIMLET_OUTFLOW_FAIL = 0
  integer(c_int), parameter :: GIMLET_OUTFLOW_REMOVE = 1

  ! Follower tractions (gimlet_apply_follower_traction).
  integer(c_int), parameter :: GIMLET_FOLLOW_AREA = 0
  integer(c_int), parameter :: GIMLET_FOLLOW_FACE = 1

  interface

    ! ----------------------------------------------------------- errors, version

    ! Copies the last error message of this thread into buf (NUL-terminated,
    ! at most len bytes with the NUL); needed receives the length needed
    ! (with the NUL). len = 0 only asks for needed. Local. Fortran callers
    ! usually want gimlet_error_message() instead.
    integer(c_int) function gimlet_last_error(buf, len, needed) bind(C, name="gimlet_last_error")
      import :: c_int, c_char, c_size_t
      character(kind=c_char), intent(inout) :: buf(*)
      integer(c_size_t), value :: len
      integer(c_size_t), intent(out) :: needed
    end function

    ! The library version. Local.
    integer(c_int) function gimlet_version(major, minor, patch) bind(C, name="gimlet_version")
      import :: c_int
      integer(c_int), intent(out) :: major, minor, patch
    end function

    ! ------------------------------------------------------- handle, materials

    ! Creates a simulation on a duplicate of the communicator with Fortran
    ! handle fcomm over [x0, x0+lx] x [y0, y0+ly], level-0 cells of size h.
    ! out receives the handle. Collective over fcomm.
    integer(c_int) function gimlet_create_f(fcomm, x0, y0, lx, ly, h, out) &
        bind(C, name="gimlet_create_f")
      import :: c_int, c_double, c_ptr
      integer(c_int), value :: fcomm
      real(c_double), value :: x0, y0, lx, ly, h
      type(c_ptr), intent(inout) :: out
    end function

    ! Destroys the handle and sets sim to c_null_ptr (c_null_ptr: no-op).
    ! Collective. Call it before MPI_Finalize.
    integer(c_int) function gimlet_destroy(sim) bind(C, name="gimlet_destroy")
      import :: c_int, c_ptr
      type(c_ptr), intent(inout) :: sim
    end function

    ! This rank and the communicator size. Local.
    integer(c_int) function gimlet_comm_info(sim, rank, size) bind(C, name="gimlet_comm_info")
      import :: c_int, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), intent(out) :: rank, size
    end function

    ! Plane-strain thickness (default 1); before the first insertion.
    integer(c_int) function gimlet_set_thickness(sim, thickness) bind(C, name="gimlet_set_thickness")
      import :: c_int, c_double, c_ptr
      type(c_ptr), value :: sim
      real(c_double), value :: thickness
    end function

    ! Geometry: GIMLET_PLANE_STRAIN (default) or GIMLET_AXISYMMETRIC (x is the
    ! radius, quantities per radian); before the first insertion.
    integer(c_int) function gimlet_set_geometry(sim, geometry) bind(C, name="gimlet_set_geometry")
      import :: c_int, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: geometry
    end function

    ! The geometry (GIMLET_PLANE_STRAIN or GIMLET_AXISYMMETRIC).
    integer(c_int) function gimlet_get_geometry(sim, geometry) bind(C, name="gimlet_get_geometry")
      import :: c_int, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), intent(out) :: geometry
    end function

    ! Linear elastic material (plane strain, Jaumann rate); id receives its index.
    integer(c_int) function gimlet_add_material_linear_elastic(sim, e, nu, rho, id) &
        bind(C, name="gimlet_add_material_linear_elastic")
      import :: c_int, c_double, c_ptr
      type(c_ptr), value :: sim
      real(c_double), value :: e, nu, rho
      integer(c_int), intent(out) :: id
    end function

    ! Compressible Neo-Hookean material (plane strain); id receives its index.
    integer(c_int) function gimlet_add_material_neo_hookean(sim, e, nu, rho, id) &
        bind(C, name="gimlet_add_material_neo_hookean")
      import :: c_int, c_double, c_ptr
      type(c_ptr), value :: sim
      real(c_double), value :: e, nu, rho
      integer(c_int), intent(out) :: id
    end function

    ! J2 (von Mises) plasticity, linear hardening sigma_y + h eps_p (plane
    ! strain); id receives its index.
    integer(c_int) function gimlet_add_material_j2_linear(sim, e, nu, rho, sigma_y, h, id) &
        bind(C, name="gimlet_add_material_j2_linear")
      import :: c_int, c_double, c_ptr
      type(c_ptr), value :: sim
      real(c_double), value :: e, nu, rho, sigma_y, h
      integer(c_int), intent(out) :: id
    end function

    ! J2 (von Mises) plasticity, power-law hardening
    ! sigma_0 (1 + eps_p/eps_0)**n (plane strain); id receives its index.
    integer(c_int) function gimlet_add_material_j2_power(sim, e, nu, rho, sigma_0, n, eps_0, id) &
        bind(C, name="gimlet_add_material_j2_power")
      import :: c_int, c_double, c_ptr
      type(c_ptr), value :: sim
      real(c_double), value :: e, nu, rho, sigma_0, n, eps_0
      integer(c_int), intent(out) :: id
    end function

    ! ------------------------------------------------ output, checkpoint, restart

    ! Opens the HDF5 + XDMF output series <dir>/<basename>_<step>.h5 and
    ! <dir>/<basename>.xdmf. Both strings NUL-terminated. Collective.
    integer(c_int) function gimlet_output_open(sim, dir, basename) bind(C, name="gimlet_output_open")
      import :: c_int, c_char, c_ptr
      type(c_ptr), value :: sim
      character(kind=c_char), intent(in) :: dir(*), basename(*)
    end function

    ! Writes one output of the current state (needs gimlet_output_open). Collective.
    integer(c_int) function gimlet_write_output(sim) bind(C, name="gimlet_write_output")
      import :: c_int, c_ptr
      type(c_ptr), value :: sim
    end function

    ! Opens the CSV time series at path (NUL-terminated). Collective.
    integer(c_int) function gimlet_csv_open(sim, path) bind(C, name="gimlet_csv_open")
      import :: c_int, c_char, c_ptr
      type(c_ptr), value :: sim
      character(kind=c_char), intent(in) :: path(*)
    end function

    ! Appends one row to the CSV series. Collective.
    integer(c_int) function gimlet_csv_append(sim) bind(C, name="gimlet_csv_append")
      import :: c_int, c_ptr
      type(c_ptr), value :: sim
    end function

    ! Writes a checkpoint of the whole state to path (NUL-terminated). Collective.
    integer(c_int) function gimlet_write_checkpoint(sim, path) bind(C, name="gimlet_write_checkpoint")
      import :: c_int, c_char, c_ptr
      type(c_ptr), value :: sim
      character(kind=c_char), intent(in) :: path(*)
    end function

    ! Replaces the state of the handle by the checkpoint at path. Collective.
    integer(c_int) function gimlet_read_checkpoint(sim, path) bind(C, name="gimlet_read_checkpoint")
      import :: c_int, c_char, c_ptr
      type(c_ptr), value :: sim
      character(kind=c_char), intent(in) :: path(*)
    end function

    ! Creates a simulation on a duplicate of the communicator with Fortran
    ! handle fcomm from the checkpoint at path. Collective over fcomm.
    integer(c_int) function gimlet_create_from_checkpoint_f(fcomm, path, out) &
        bind(C, name="gimlet_create_from_checkpoint_f")
      import :: c_int, c_char, c_ptr
      integer(c_int), value :: fcomm
      character(kind=c_char), intent(in) :: path(*)
      type(c_ptr), intent(inout) :: out
    end function

    ! Checks an XDMF file against the HDF5 files it names; items receives
    ! the number of datasets checked. Collective.
    integer(c_int) function gimlet_check_xdmf(sim, path, items) bind(C, name="gimlet_check_xdmf")
      import :: c_int, c_int64_t, c_char, c_ptr
      type(c_ptr), value :: sim
      character(kind=c_char), intent(in) :: path(*)
      integer(c_int64_t), intent(out) :: items
    end function

    ! ------------------------------------------------------------- hierarchy

    ! Proposes the levels and boxes of an indentation (pure, no handle):
    ! domain = x0, y0, lx, ly, h0; boxes(1:4, l) for level l = 1 .. nlevels-1.
    integer(c_int) function gimlet_propose_levels(domain, axis_x, surface_y, indenter, size, depth, response, &
                                                  particles_per_cell, particles_across, box_factor, max_levels, &
                                                  nlevels, boxes, results) bind(C, name="gimlet_propose_levels")
      import :: c_int, c_double, c_ptr
      real(c_double), intent(in) :: domain(*)
      real(c_double), value :: axis_x, surface_y
      integer(c_int), value :: indenter
      real(c_double), value :: size, depth
      integer(c_int), value :: response, particles_per_cell
      real(c_double), value :: particles_across, box_factor
      integer(c_int), value :: max_levels
      integer(c_int), intent(out) :: nlevels
      real(c_double), intent(out) :: boxes(*)
      type(c_ptr), value :: results
    end function

    ! Proper-nesting buffer in coarse cells (default 4); before gimlet_add_level.
    integer(c_int) function gimlet_set_nesting_buffer(sim, cells) bind(C, name="gimlet_set_nesting_buffer")
      import :: c_int, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: cells
    end function

    ! Adds a finer level of nboxes boxes, boxes(1:4, k) = xlo, ylo, xhi, yhi.
    integer(c_int) function gimlet_add_level(sim, boxes, nboxes) bind(C, name="gimlet_add_level")
      import :: c_int, c_double, c_ptr
      type(c_ptr), value :: sim
      real(c_double), intent(in) :: boxes(*)
      integer(c_int), value :: nboxes
    end function

    ! Largest patch of a level, px x py cells.
    integer(c_int) function gimlet_set_patch_size(sim, level, px, py) bind(C, name="gimlet_set_patch_size")
      import :: c_int, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: level, px, py
    end function

    ! Number of levels. Local.
    integer(c_int) function gimlet_num_levels(sim, nlevels) bind(C, name="gimlet_num_levels")
      import :: c_int, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), intent(out) :: nlevels
    end function

    ! Cell size, number of boxes and patches of a level. Local.
    integer(c_int) function gimlet_level_info(sim, level, h, nboxes, npatches) bind(C, name="gimlet_level_info")
      import :: c_int, c_double, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: level
      real(c_double), intent(out) :: h
      integer(c_int), intent(out) :: nboxes, npatches
    end function

    ! Boxes of a level, boxes(1:4, k) = xlo, ylo, xhi, yhi, room for
    ! capacity boxes; count receives the number. Local.
    integer(c_int) function gimlet_level_boxes(sim, level, boxes, capacity, count) &
        bind(C, name="gimlet_level_boxes")
      import :: c_int, c_int64_t, c_double, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: level
      real(c_double), intent(out) :: boxes(*)
      integer(c_int64_t), value :: capacity
      integer(c_int64_t), intent(out) :: count
    end function

    ! Patches of a level: cells(1:4, k) = ilo, jlo, ihi, jhi (hi exclusive)
    ! and owner(k), room for capacity patches; count receives the number. Local.
    integer(c_int) function gimlet_level_patches(sim, level, cells, owner, capacity, count) &
        bind(C, name="gimlet_level_patches")
      import :: c_int, c_int64_t, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: level
      integer(c_int64_t), intent(out) :: cells(*)
      integer(c_int), intent(out) :: owner(*)
      integer(c_int64_t), value :: capacity
      integer(c_int64_t), intent(out) :: count
    end function

    ! ------------------------------------------------------------- particles

    ! Inserts n particles from this rank's arrays. Exactly one of mass and
    ! density is given, as c_loc(array); the other is c_null_ptr.
    ! Collective.
    integer(c_int) function gimlet_insert_particles(sim, n, x, y, lpx, lpy, vx, vy, mass, density, material) &
        bind(C, name="gimlet_insert_particles")
      import :: c_int, c_int64_t, c_double, c_ptr
      type(c_ptr), value :: sim
      integer(c_int64_t), value :: n
      real(c_double), intent(in) :: x(*), y(*), lpx(*), lpy(*), vx(*), vy(*)
      type(c_ptr), value :: mass, density
      integer(c_int), intent(in) :: material(*)
    end function

    ! Fills [xlo, xhi] x [ylo, yhi] with n_per_cell**2 particles per cell;
    ! added receives the global number added. Collective.
    integer(c_int) function gimlet_fill_rectangle(sim, xlo, ylo, xhi, yhi, n_per_cell, material, density, &
                                                  vx, vy, added) bind(C, name="gimlet_fill_rectangle")
      import :: c_int, c_int64_t, c_double, c_ptr
      type(c_ptr), value :: sim
      real(c_double), value :: xlo, ylo, xhi, yhi
      integer(c_int), value :: n_per_cell, material
      real(c_double), value :: density, vx, vy
      integer(c_int64_t), intent(out) :: added
    end function

    ! Particles on this rank and on all ranks. Collective.
    integer(c_int) function gimlet_particle_count(sim, local, global) bind(C, name="gimlet_particle_count")
      import :: c_int, c_int64_t, c_ptr
      type(c_ptr), value :: sim
      integer(c_int64_t), intent(out) :: local, global
    end function

    ! Particles of a level on this rank. Local.
    integer(c_int) function gimlet_level_particle_count(sim, level, local) &
        bind(C, name="gimlet_level_particle_count")
      import :: c_int, c_int64_t, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: level
      integer(c_int64_t), intent(out) :: local
    end function

    ! Number of components of a field (GIMLET_FIELD_*). Local.
    integer(c_int) function gimlet_field_components(sim, fld, ncomp) bind(C, name="gimlet_field_components")
      import :: c_int, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: fld
      integer(c_int), intent(out) :: ncomp
    end function

    ! Copies a field of this rank's particles into out(ncomp, capacity);
    ! count receives the number of particles. Local.
    integer(c_int) function gimlet_get_field(sim, fld, out, capacity, count) bind(C, name="gimlet_get_field")
      import :: c_int, c_int64_t, c_double, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: fld
      real(c_double), intent(out) :: out(*)
      integer(c_int64_t), value :: capacity
      integer(c_int64_t), intent(out) :: count
    end function

    ! Sets the velocity or stress field of this rank's n particles from
    ! values(ncomp, n), in the order of gimlet_get_field.
    integer(c_int) function gimlet_set_field(sim, fld, values, n) bind(C, name="gimlet_set_field")
      import :: c_int, c_int64_t, c_double, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: fld
      real(c_double), intent(in) :: values(*)
      integer(c_int64_t), value :: n
    end function

    ! Global ids (uint64_t in C, received as integer(c_int64_t)) of this
    ! rank's particles, in the order of gimlet_get_field. Local.
    integer(c_int) function gimlet_get_ids(sim, ids, capacity, count) bind(C, name="gimlet_get_ids")
      import :: c_int, c_int64_t, c_ptr
      type(c_ptr), value :: sim
      integer(c_int64_t), intent(out) :: ids(*)
      integer(c_int64_t), value :: capacity
      integer(c_int64_t), intent(out) :: count
    end function

    ! Global kinetic and strain energy, momentum and mass. Collective.
    integer(c_int) function gimlet_diagnostics(sim, kinetic, strain, momentum_x, momentum_y, mass) &
        bind(C, name="gimlet_diagnostics")
      import :: c_int, c_double, c_ptr
      type(c_ptr), value :: sim
      real(c_double), intent(out) :: kinetic, strain, momentum_x, momentum_y, mass
    end function

    ! Particles this rank removed because they left the domain: ids(k) and
    ! xy(1:2, k), room for capacity; count receives the number. Local.
    integer(c_int) function gimlet_lost_particles(sim, ids, xy, capacity, count) &
        bind(C, name="gimlet_lost_particles")
      import :: c_int, c_int64_t, c_double, c_ptr
      type(c_ptr), value :: sim
      integer(c_int64_t), intent(out) :: ids(*)
      real(c_double), intent(out) :: xy(*)
      integer(c_int64_t), value :: capacity
      integer(c_int64_t), intent(out) :: count
    end function

    ! Patch-to-patch particle moves since creation. Collective.
    integer(c_int) function gimlet_patch_crossings(sim, crossings) bind(C, name="gimlet_patch_crossings")
      import :: c_int, c_int64_t, c_ptr
      type(c_ptr), value :: sim
      integer(c_int64_t), intent(out) :: crossings
    end function

    ! ------------------------------------------------------------ run settings

    ! Weight function GIMLET_SHAPE_* (default GIMLET_SHAPE_CPGIMP). Collective.
    integer(c_int) function gimlet_set_shape(sim, shape) bind(C, name="gimlet_set_shape")
      import :: c_int, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: shape
    end function

    ! Update scheme GIMLET_SCHEME_*.
    integer(c_int) function gimlet_set_scheme(sim, scheme) bind(C, name="gimlet_set_scheme")
      import :: c_int, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: scheme
    end function

    ! FLIP fraction in [0, 1].
    integer(c_int) function gimlet_set_flip(sim, flip) bind(C, name="gimlet_set_flip")
      import :: c_int, c_double, c_ptr
      type(c_ptr), value :: sim
      real(c_double), value :: flip
    end function

    ! Velocity transfer: GIMLET_TRANSFER_FLIP, _APIC (default) or _XPIC.
    integer(c_int) function gimlet_set_transfer(sim, transfer) bind(C, name="gimlet_set_transfer")
      import :: c_int, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: transfer
    end function

    ! Order in [1, 16] of GIMLET_TRANSFER_XPIC (default 5).
    integer(c_int) function gimlet_set_xpic_order(sim, order) bind(C, name="gimlet_set_xpic_order")
      import :: c_int, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: order
    end function

    ! Courant number in (0, 1].
    integer(c_int) function gimlet_set_cfl(sim, cfl) bind(C, name="gimlet_set_cfl")
      import :: c_int, c_double, c_ptr
      type(c_ptr), value :: sim
      real(c_double), value :: cfl
    end function

    ! Gravity (body force per unit mass).
    integer(c_int) function gimlet_set_gravity(sim, gx, gy) bind(C, name="gimlet_set_gravity")
      import :: c_int, c_double, c_ptr
      type(c_ptr), value :: sim
      real(c_double), value :: gx, gy
    end function

    ! Condition GIMLET_BC_* of a domain face GIMLET_FACE_*.
    integer(c_int) function gimlet_set_face_bc(sim, face, bc) bind(C, name="gimlet_set_face_bc")
      import :: c_int, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: face, bc
    end function

    ! Load ramp time (0: full load from the start).
    integer(c_int) function gimlet_set_load_ramp(sim, t_ramp) bind(C, name="gimlet_set_load_ramp")
      import :: c_int, c_double, c_ptr
      type(c_ptr), value :: sim
      real(c_double), value :: t_ramp
    end function

    ! Outflow policy GIMLET_OUTFLOW_*.
    integer(c_int) function gimlet_set_outflow(sim, policy) bind(C, name="gimlet_set_outflow")
      import :: c_int, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: policy
    end function

    ! Traction (tx, ty) on the particle faces on side face lying on the line
    ! at, overlapping [lo, hi]; loaded receives the global number loaded.
    ! Collective.
    integer(c_int) function gimlet_apply_traction(sim, face, at, lo, hi, tx, ty, loaded) &
        bind(C, name="gimlet_apply_traction")
      import :: c_int, c_int64_t, c_double, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: face
      real(c_double), value :: at, lo, hi, tx, ty
      integer(c_int64_t), intent(out) :: loaded
    end function

    ! A follower traction (tx, ty) on the same particles: a Cauchy traction
    ! (per current face area), in fixed axes (follow = GIMLET_FOLLOW_AREA)
    ! or turning with the face (GIMLET_FOLLOW_FACE); see the C header. A
    ! particle's loads are all of one kind. Collective.
    integer(c_int) function gimlet_apply_follower_traction(sim, face, at, lo, hi, tx, ty, follow, loaded) &
        bind(C, name="gimlet_apply_follower_traction")
      import :: c_int, c_int64_t, c_double, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: face
      real(c_double), value :: at, lo, hi, tx, ty
      integer(c_int), value :: follow
      integer(c_int64_t), intent(out) :: loaded
    end function

    ! ---------------------------------------------------------------- stepping

    ! Stable time step of the current state. Collective.
    integer(c_int) function gimlet_stable_dt(sim, dt) bind(C, name="gimlet_stable_dt")
      import :: c_int, c_double, c_ptr
      type(c_ptr), value :: sim
      real(c_double), intent(out) :: dt
    end function

    ! One step of dt (dt <= 0: the stable step); time and steps receive the
    ! time and step count reached. Collective.
    integer(c_int) function gimlet_step(sim, dt, time, steps) bind(C, name="gimlet_step")
      import :: c_int, c_int64_t, c_double, c_ptr
      type(c_ptr), value :: sim
      real(c_double), value :: dt
      real(c_double), intent(out) :: time
      integer(c_int64_t), intent(out) :: steps
    end function

    ! Advances to t_end with at most max_steps stable steps. Collective.
    integer(c_int) function gimlet_advance_to(sim, t_end, max_steps, time, steps) bind(C, name="gimlet_advance_to")
      import :: c_int, c_int64_t, c_double, c_ptr
      type(c_ptr), value :: sim
      real(c_double), value :: t_end
      integer(c_int64_t), value :: max_steps
      real(c_double), intent(out) :: time
      integer(c_int64_t), intent(out) :: steps
    end function

    ! Current time and step count. Local.
    integer(c_int) function gimlet_time(sim, time, steps) bind(C, name="gimlet_time")
      import :: c_int, c_int64_t, c_double, c_ptr
      type(c_ptr), value :: sim
      real(c_double), intent(out) :: time
      integer(c_int64_t), intent(out) :: steps
    end function

    ! -------------------------------------------------------- indenters
    ! Rigid indenters pointing down (-y), tip at (x_tip, y_tip) at time 0;
    ! indenter receives the index. Collective.
    integer(c_int) function gimlet_add_indenter_wedge(sim, half_angle_deg, height, x_tip, y_tip, indenter) &
        bind(C, name="gimlet_add_indenter_wedge")
      import :: c_int, c_double, c_ptr
      type(c_ptr), value :: sim
      real(c_double), value :: half_angle_deg, height, x_tip, y_tip
      integer(c_int), intent(out) :: indenter
    end function

    integer(c_int) function gimlet_add_indenter_cylinder(sim, radius, x_tip, y_tip, indenter) &
        bind(C, name="gimlet_add_indenter_cylinder")
      import :: c_int, c_double, c_ptr
      type(c_ptr), value :: sim
      real(c_double), value :: radius, x_tip, y_tip
      integer(c_int), intent(out) :: indenter
    end function

    integer(c_int) function gimlet_add_indenter_flat_punch(sim, half_width, corner_radius, height, x_tip, y_tip, &
                                                           indenter) bind(C, name="gimlet_add_indenter_flat_punch")
      import :: c_int, c_double, c_ptr
      type(c_ptr), value :: sim
      real(c_double), value :: half_width, corner_radius, height, x_tip, y_tip
      integer(c_int), intent(out) :: indenter
    end function

    ! A convex polygon of n vertices xy(1:2, n) relative to (x_ref, y_ref).
    integer(c_int) function gimlet_add_indenter_polygon(sim, n, xy, x_ref, y_ref, indenter) &
        bind(C, name="gimlet_add_indenter_polygon")
      import :: c_int, c_int64_t, c_double, c_ptr
      type(c_ptr), value :: sim
      integer(c_int64_t), value :: n
      real(c_double), intent(in) :: xy(*)
      real(c_double), value :: x_ref, y_ref
      integer(c_int), intent(out) :: indenter
    end function

    ! Motion history (GIMLET_MOTION_VELOCITY or _DEPTH) at n increasing
    ! times. Collective.
    integer(c_int) function gimlet_set_indenter_motion(sim, indenter, kind, n, times, values) &
        bind(C, name="gimlet_set_indenter_motion")
      import :: c_int, c_int64_t, c_double, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: indenter, kind
      integer(c_int64_t), value :: n
      real(c_double), intent(in) :: times(*), values(*)
    end function

    ! Depth, downward speed, force(1:2) per metre of thickness and number of
    ! particles in contact. Local.
    integer(c_int) function gimlet_indenter_state(sim, indenter, depth, speed, force, contacts) &
        bind(C, name="gimlet_indenter_state")
      import :: c_int, c_int64_t, c_double, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: indenter
      real(c_double), intent(out) :: depth, speed, force(2)
      integer(c_int64_t), intent(out) :: contacts
    end function

    ! The particles in contact (indenter -1: any): position(2, k),
    ! normal(2, k), pressure(k), length(k), ids(k), level(k), rank(k), room
    ! for capacity; count receives the number. Local.
    integer(c_int) function gimlet_get_contacts(sim, indenter, capacity, count, position, normal, pressure, length, &
                                                ids, level, rank) bind(C, name="gimlet_get_contacts")
      import :: c_int, c_int64_t, c_double, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: indenter
      integer(c_int64_t), value :: capacity
      integer(c_int64_t), intent(out) :: count
      real(c_double), intent(out) :: position(*), normal(*), pressure(*), length(*)
      integer(c_int64_t), intent(out) :: ids(*)
      integer(c_int), intent(out) :: level(*), rank(*)
    end function

    ! Sets a contact option (GIMLET_CONTACT_*). Collective.
    integer(c_int) function gimlet_set_contact_option(sim, option, value) bind(C, name="gimlet_set_contact_option")
      import :: c_int, c_double, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: option
      real(c_double), value :: value
    end function

    ! PETSc options for the contact solve (NUL-terminated). Collective.
    integer(c_int) function gimlet_set_petsc_options(sim, options) bind(C, name="gimlet_set_petsc_options")
      import :: c_int, c_char, c_ptr
      type(c_ptr), value :: sim
      character(kind=c_char), intent(in) :: options(*)
    end function

    ! Contact phase times(5) and counts(6) on this rank. Local.
    integer(c_int) function gimlet_contact_stats(sim, times, counts) bind(C, name="gimlet_contact_stats")
      import :: c_int, c_int64_t, c_double, c_ptr
      type(c_ptr), value :: sim
      real(c_double), intent(out) :: times(5)
      integer(c_int64_t), intent(out) :: counts(6)
    end function

    ! Coulomb friction coefficient of an indenter (>= 0; ieee infinity:
    ! stick only; 0: frictionless). Collective.
    integer(c_int) function gimlet_set_indenter_friction(sim, indenter, mu) &
        bind(C, name="gimlet_set_indenter_friction")
      import :: c_int, c_double, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: indenter
      real(c_double), value :: mu
    end function

    ! Sideways tip displacement x (m) at n increasing times (n = 0: none).
    ! Collective.
    integer(c_int) function gimlet_set_indenter_lateral(sim, indenter, n, times, x) &
        bind(C, name="gimlet_set_indenter_lateral")
      import :: c_int, c_int64_t, c_double, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: indenter
      integer(c_int64_t), value :: n
      real(c_double), intent(in) :: times(*), x(*)
    end function

    ! Tangential traction(k), slip(k) and stick(k) of the particles of
    ! gimlet_get_contacts, in its order. Local.
    integer(c_int) function gimlet_get_contact_friction(sim, indenter, capacity, count, traction, slip, stick) &
        bind(C, name="gimlet_get_contact_friction")
      import :: c_int, c_int64_t, c_double, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: indenter
      integer(c_int64_t), value :: capacity
      integer(c_int64_t), intent(out) :: count
      real(c_double), intent(out) :: traction(*), slip(*)
      integer(c_int), intent(out) :: stick(*)
    end function

    ! Friction dissipation (J/m) at an indenter since creation, and
    ! counts(3): frictional solves, staggered iterations, most of one. Local.
    integer(c_int) function gimlet_friction_stats(sim, indenter, dissipation, counts) &
        bind(C, name="gimlet_friction_stats")
      import :: c_int, c_int64_t, c_double, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: indenter
      real(c_double), intent(out) :: dissipation
      integer(c_int64_t), intent(out) :: counts(3)
    end function

    ! Where the steps of `level` spent their time on this rank (kernel,
    ! contact, exchange, migration, coupling: times(1:5)); steps and bytes
    ! sent (counts(1:2)). Local.
    integer(c_int) function gimlet_level_stats(sim, level, times, counts) bind(C, name="gimlet_level_stats")
      import :: c_int, c_int64_t, c_double, c_ptr
      type(c_ptr), value :: sim
      integer(c_int), value :: level
      real(c_double), intent(out) :: times(5)
      integer(c_int64_t), intent(out) :: counts(2)
    end function

    ! Hardness, unloading stiffness, reduced modulus and residual depth of a
    ! plane-strain load-depth series depth(n), load(n) with unloading; sink
    ! (c_loc of an array of n, or c_null_ptr) is the surface's sink at r0.
    ! results(GIMLET_INDENTATION_RESULTS). Local, pure, no handle.
    integer(c_int) function gimlet_indentation_analysis(n, depth, load, sink, r0, contact_half_width, fit_lower, &
                                                        fit_upper, results) bind(C, name="gimlet_indentation_analysis")
      import :: c_int, c_int64_t, c_double, c_ptr
      integer(c_int64_t), value :: n
      real(c_double), intent(in) :: depth(*), load(*)
      type(c_ptr), value :: sink
      real(c_double), value :: r0, contact_half_width, fit_lower, fit_upper
      real(c_double), intent(out) :: results(*)
    end function

    ! gimlet_indentation_analysis for a wedge, the contact half-width from
    ! Oliver-Pharr's contact depth (plane-strain elastic sink-in).
    integer(c_int) function gimlet_indentation_analysis_wedge(n, depth, load, sink, r0, half_angle_deg, fit_lower, &
                                                             fit_upper, results) &
        bind(C, name="gimlet_indentation_analysis_wedge")
      import :: c_int, c_int64_t, c_double, c_ptr
      integer(c_int64_t), value :: n
      real(c_double), intent(in) :: depth(*), load(*)
      type(c_ptr), value :: sink
      real(c_double), value :: r0, half_angle_deg, fit_lower, fit_upper
      real(c_double), intent(out) :: results(*)
    end function

    ! Oliver-Pharr analysis of an axisymmetric load-depth series (whole-body
    ! load, N): tip GIMLET_TIP_* of size (cone half-angle in degrees, or a
    ! radius); epsilon NaN for the tip's own; contact_radius NaN for none.
    integer(c_int) function gimlet_indentation_analysis_axisym(n, depth, load, tip, size, epsilon, beta, &
                                                              fit_lower, fit_upper, frame_compliance, &
                                                              contact_radius, results) &
        bind(C, name="gimlet_indentation_analysis_axisym")
      import :: c_int, c_int64_t, c_double
      integer(c_int64_t), value :: n
      real(c_double), intent(in) :: depth(*), load(*)
      integer(c_int), value :: tip
      real(c_double), value :: size, epsilon, beta, fit_lower, fit_upper, frame_compliance, contact_radius
      real(c_double), intent(out) :: results(*)
    end function

  end interface

contains

  ! The last error message of this thread (gimlet_last_error) as a Fortran
  ! string without the NUL; empty when no call has failed yet.
  function gimlet_error_message() result(msg)
    character(len=:), allocatable :: msg
    character(kind=c_char) :: probe(1)
    character(kind=c_char), allocatable :: buf(:)
    integer(c_size_t) :: needed
    integer(c_int) :: st
    integer :: i, n

    needed = 0
    st = gimlet_last_error(probe, 0_c_size_t, needed)
    allocate(buf(max(needed, 1_c_size_t)))
    st = gimlet_last_error(buf, int(size(buf), c_size_t), needed)
    n = 0
    if (st == GIMLET_OK) then
      do while (n < size(buf))
        if (buf(n + 1) == c_null_char) exit
        n = n + 1
      end do
    end if
    allocate(character(len=n) :: msg)
    do i = 1, n
      msg(i:i) = buf(i)
    end do
  end function gimlet_error_message

end module gimlet
