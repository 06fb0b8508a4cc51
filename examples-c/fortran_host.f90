! A Fortran host of Gimlet: what a Fortran code calling the library looks
! like, and a test of the Fortran interface (include/gimlet.f90) against the
! installed library.
!
!   mpiexec -n 2 ./fortran_host [output directory, default .]
!
! It creates a simulation on MPI_COMM_WORLD (gimlet_create_f with the
! Fortran communicator handle), adds a material, fills a block resting on a
! fixed floor, takes a few steps under gravity, reads the particle count
! and fields into Fortran arrays, checks that rejected calls return a
! status and a message and leave the handle usable, round-trips a
! checkpoint (a string argument and gimlet_create_from_checkpoint_f), and
! destroys the handles. A failed library call stops all ranks
! (MPI_Abort); a failed check makes the exit status non-zero.
program fortran_host
  use, intrinsic :: iso_c_binding, only: c_int, c_int64_t, c_double, c_ptr, c_null_ptr, &
                                         c_null_char, c_associated
  use mpi
  use gimlet
  implicit none

  ! Scene: domain [0, 1] x [0, 0.5], cells of 1/8 (exact in binary), two
  ! level-0 patches of 4 x 4 cells (one per rank on 2 ranks), a block
  ! [0.25, 0.75] x [0, 0.25] of 2 x 2 particles per cell.
  real(c_double), parameter :: h = 0.125_c_double
  real(c_double), parameter :: rho = 1000.0_c_double
  real(c_double), parameter :: block_area = 0.5_c_double * 0.25_c_double
  integer(c_int64_t), parameter :: expected_particles = 32   ! 4 x 2 cells x 4
  integer(c_int64_t), parameter :: nsteps = 10

  type(c_ptr) :: sim = c_null_ptr, restored = c_null_ptr, bad = c_null_ptr
  integer :: ierr, rank, nranks, failures, total, k
  integer(c_int) :: st, mat, ncomp, major, minor, patch, grank, gsize
  integer(c_int64_t) :: added, nlocal, nglobal, nsum, count, steps, steps_r, i
  real(c_double) :: t, t_r, t_before, dt, ke, se, px, py, mass, local_mass, global_mass
  real(c_double), allocatable :: pos(:, :), pos_r(:, :), m(:)
  character(len=4096) :: arg
  character(len=:), allocatable :: outdir, ckpt, msg

  call MPI_Init(ierr)
  call MPI_Comm_rank(MPI_COMM_WORLD, rank, ierr)
  call MPI_Comm_size(MPI_COMM_WORLD, nranks, ierr)
  failures = 0

  outdir = "."
  if (command_argument_count() >= 1) then
    call get_command_argument(1, arg)
    outdir = trim(arg)
  end if

  ! The library and this module agree on the version.
  call ok(gimlet_version(major, minor, patch), "gimlet_version")
  call check(major == GIMLET_VERSION_MAJOR .and. minor == GIMLET_VERSION_MINOR .and. &
             patch == GIMLET_VERSION_PATCH, "library version equals the module's GIMLET_VERSION_*")

  ! Create on MPI_COMM_WORLD (its Fortran handle; the library duplicates it).
  call ok(gimlet_create_f(MPI_COMM_WORLD, 0.0_c_double, 0.0_c_double, 1.0_c_double, 0.5_c_double, &
                          h, sim), "gimlet_create_f")
  call check(c_associated(sim), "gimlet_create_f returned a handle")
  call ok(gimlet_comm_info(sim, grank, gsize), "gimlet_comm_info")
  call check(grank == rank .and. gsize == nranks, "gimlet_comm_info gives the MPI rank and size")

  call ok(gimlet_set_patch_size(sim, 0_c_int, 4_c_int, 4_c_int), "gimlet_set_patch_size")
  call ok(gimlet_add_material_linear_elastic(sim, 1.0e6_c_double, 0.3_c_double, rho, mat), &
          "gimlet_add_material_linear_elastic")
  call ok(gimlet_fill_rectangle(sim, 0.25_c_double, 0.0_c_double, 0.75_c_double, 0.25_c_double, &
                                2_c_int, mat, rho, 0.0_c_double, 0.0_c_double, added), &
          "gimlet_fill_rectangle")
  call check(added == expected_particles, "gimlet_fill_rectangle added 32 particles")
  call ok(gimlet_set_face_bc(sim, GIMLET_FACE_BOTTOM, GIMLET_BC_FIXED), "gimlet_set_face_bc")
  call ok(gimlet_set_gravity(sim, 0.0_c_double, -9.81_c_double), "gimlet_set_gravity")

  do k = 1, int(nsteps)
    call ok(gimlet_step(sim, 0.0_c_double, t, steps), "gimlet_step")
  end do
  call check(steps == nsteps .and. t > 0.0_c_double, "10 steps taken, time advanced")

  ! Counts: global = sum of the local counts = what was added.
  call ok(gimlet_particle_count(sim, nlocal, nglobal), "gimlet_particle_count")
  call MPI_Allreduce(nlocal, nsum, 1, MPI_INTEGER8, MPI_SUM, MPI_COMM_WORLD, ierr)
  call check(nglobal == expected_particles .and. nsum == nglobal, &
             "global particle count 32 = sum of the local counts")

  ! Positions into a Fortran array pos(2, nlocal): all inside the domain,
  ! and the block has not moved sideways by a cell.
  call ok(gimlet_field_components(sim, GIMLET_FIELD_POSITION, ncomp), "gimlet_field_components")
  call check(ncomp == 2, "the position field has 2 components")
  allocate(pos(2, nlocal), m(nlocal))
  call ok(gimlet_get_field(sim, GIMLET_FIELD_POSITION, pos, nlocal, count), "gimlet_get_field(position)")
  call check(count == nlocal, "gimlet_get_field returned the local count")
  do i = 1, nlocal
    call check(pos(1, i) > 0.25_c_double - h .and. pos(1, i) < 0.75_c_double + h .and. &
               pos(2, i) >= 0.0_c_double .and. pos(2, i) <= 0.5_c_double, "particle inside the domain")
  end do

  ! The Fortran way to ask for a count: capacity 0 reports it with
  ! GIMLET_ERR_BUFFER_TOO_SMALL (or succeeds when there is nothing to copy).
  st = gimlet_get_field(sim, GIMLET_FIELD_MASS, m, 0_c_int64_t, count)
  if (nlocal > 0) then
    call check(st == GIMLET_ERR_BUFFER_TOO_SMALL .and. count == nlocal, &
               "capacity 0 reports the needed count with GIMLET_ERR_BUFFER_TOO_SMALL")
  else
    call check(st == GIMLET_OK .and. count == 0, "capacity 0 with no particles succeeds")
  end if

  ! Mass: the particle masses and the diagnostics both give rho x area (per
  ! unit thickness), to round-off.
  call ok(gimlet_get_field(sim, GIMLET_FIELD_MASS, m, nlocal, count), "gimlet_get_field(mass)")
  local_mass = sum(m)
  call MPI_Allreduce(local_mass, global_mass, 1, MPI_DOUBLE_PRECISION, MPI_SUM, MPI_COMM_WORLD, ierr)
  call ok(gimlet_diagnostics(sim, ke, se, px, py, mass), "gimlet_diagnostics")
  call check(abs(global_mass - rho * block_area) <= 1.0e-12_c_double * rho * block_area, &
             "sum of particle masses = rho x block area")
  call check(abs(mass - global_mass) <= 1.0e-12_c_double * global_mass, "diagnostics mass = sum of masses")
  call check(ke >= 0.0_c_double .and. se >= 0.0_c_double, "energies are non-negative")

  ! Rejected calls: a status and a message; the handle keeps working.
  st = gimlet_set_cfl(sim, 2.0_c_double)
  msg = gimlet_error_message()
  call check(st == GIMLET_ERR_INVALID_ARGUMENT, "gimlet_set_cfl(2) returns GIMLET_ERR_INVALID_ARGUMENT")
  call check(len(msg) > 0 .and. index(msg, "cfl") > 0, "the message names the argument cfl")
  if (rank == 0) print '(a, i0, 2a)', "rejected gimlet_set_cfl(2): status ", st, ", message: ", msg

  call ok(gimlet_stable_dt(sim, dt), "gimlet_stable_dt")
  call ok(gimlet_time(sim, t_before, steps), "gimlet_time")
  st = gimlet_step(sim, 10.0_c_double * dt, t, steps)
  msg = gimlet_error_message()
  call check(st == GIMLET_ERR_UNSTABLE .and. len(msg) > 0, &
             "a step of 10 x the stable dt returns GIMLET_ERR_UNSTABLE with a message")
  call ok(gimlet_time(sim, t, steps), "gimlet_time")
  call check(t == t_before .and. steps == nsteps, "the rejected step changed nothing")

  ! The next steps use 0.9 of the stable step: the stable step shrinks as
  ! the block speeds up, so a step of exactly dt may be refused after one.
  dt = 0.9_c_double * dt
  call ok(gimlet_step(sim, dt, t, steps), "gimlet_step after the rejected calls")
  call check(steps == nsteps + 1, "the handle still steps after rejected calls")

  ! Checkpoint round trip (strings: trim(path)//c_null_char). Continuing
  ! both runs on the same ranks gives bitwise the same positions.
  write (arg, '(a, "/fortran_host_np", i0, ".h5")') outdir, nranks
  ckpt = trim(arg)
  call ok(gimlet_write_checkpoint(sim, ckpt // c_null_char), "gimlet_write_checkpoint")
  call ok(gimlet_create_from_checkpoint_f(MPI_COMM_WORLD, ckpt // c_null_char, restored), &
          "gimlet_create_from_checkpoint_f")
  call ok(gimlet_time(restored, t_r, steps_r), "gimlet_time(restored)")
  call check(t_r == t .and. steps_r == steps, "the restored handle has the time and step count")
  call ok(gimlet_step(sim, dt, t, steps), "gimlet_step")
  call ok(gimlet_step(restored, dt, t_r, steps_r), "gimlet_step(restored)")
  call ok(gimlet_particle_count(restored, count, nglobal), "gimlet_particle_count(restored)")
  call check(count == nlocal, "the restored handle has the same local particles")
  allocate(pos_r(2, max(count, 1_c_int64_t)))
  call ok(gimlet_get_field(sim, GIMLET_FIELD_POSITION, pos, nlocal, count), "gimlet_get_field")
  call ok(gimlet_get_field(restored, GIMLET_FIELD_POSITION, pos_r, int(size(pos_r, 2), c_int64_t), count), &
          "gimlet_get_field(restored)")
  call check(count == nlocal, "restored count")
  if (count == nlocal) then
    call check(all(pos(:, 1:nlocal) == pos_r(:, 1:nlocal)), &
               "a step after the restart gives bitwise the positions of the original run")
  end if

  ! A bad path: GIMLET_ERR_IO with a message naming it; nothing created.
  st = gimlet_create_from_checkpoint_f(MPI_COMM_WORLD, outdir // "/no_such_file.h5" // c_null_char, bad)
  msg = gimlet_error_message()
  call check(st == GIMLET_ERR_IO .and. index(msg, "no_such_file.h5") > 0 .and. .not. c_associated(bad), &
             "a missing checkpoint gives GIMLET_ERR_IO naming the path, and no handle")

  call ok(gimlet_destroy(restored), "gimlet_destroy(restored)")
  call ok(gimlet_destroy(sim), "gimlet_destroy")
  call check(.not. c_associated(sim) .and. .not. c_associated(restored), "gimlet_destroy nulls the handles")
  call ok(gimlet_destroy(sim), "gimlet_destroy of a null handle (no-op)")

  call MPI_Allreduce(failures, total, 1, MPI_INTEGER, MPI_SUM, MPI_COMM_WORLD, ierr)
  if (rank == 0) then
    if (total == 0) then
      print '(a, i0, a, i0, a, es12.5)', "fortran_host: ok on ", nranks, " rank(s), ", nglobal, &
            " particles, t = ", t
    else
      print '(a, i0, a)', "fortran_host: FAILED (", total, " failed checks)"
    end if
  end if
  call MPI_Finalize(ierr)
  if (total /= 0) error stop 1

contains

  ! A library call must succeed; otherwise stop every rank (the run cannot
  ! continue consistently after a failed collective call).
  subroutine ok(status, what)
    integer(c_int), intent(in) :: status
    character(len=*), intent(in) :: what
    integer :: ierr2
    if (status /= GIMLET_OK) then
      write (*, '(a, i0, 3a, i0, 2a)') "[rank ", rank, "] ", what, " failed with status ", status, ": ", &
        gimlet_error_message()
      call MPI_Abort(MPI_COMM_WORLD, 1, ierr2)
    end if
  end subroutine ok

  subroutine check(cond, what)
    logical, intent(in) :: cond
    character(len=*), intent(in) :: what
    if (.not. cond) then
      failures = failures + 1
      write (*, '(a, i0, 2a)') "[rank ", rank, "] check failed: ", what
    end if
  end subroutine check

end program fortran_host
