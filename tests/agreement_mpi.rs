//! The collective agreement of `ffi::agree` on any number of ranks: run by
//! `cargo test` (one rank, MPI singleton) and by ctest under `mpiexec -n 2`
//! (`agreement_np2`). MPI can be initialised once per process and the test
//! harness runs tests as threads of one process, so this file holds one
//! `#[test]`.
//!
//! Checked: the outcome of a step that fails differently on different ranks
//! (`PARTICLES_LEFT` on rank 0, `UNSTABLE` on the others) is `UNSTABLE` with
//! the failing rank's message on every rank; a rejection travels with its
//! rank; differing arguments name the first one; agreement on success keeps
//! each rank's value.

use gimlet::comm::Comm;
use gimlet::error::{Error, Status};
use gimlet::ffi::agree::{agree, args, outcome, Args};

#[test]
fn statuses_and_arguments_agree_across_ranks() {
    // SAFETY: MPI is initialised once, here, and finalised at the end.
    unsafe {
        let mut init = 0;
        mpi_sys::MPI_Initialized(&mut init);
        if init == 0 {
            mpi_sys::MPI_Init(std::ptr::null_mut(), std::ptr::null_mut());
        }
    }
    let comm = Comm::world().expect("MPI_COMM_WORLD duplicated");
    let (rank, size) = (comm.rank(), comm.size());

    // A step failing differently: the most severe status wins everywhere.
    let local: gimlet::error::Result<()> = if rank == 0 && size > 1 {
        Err(Error::new(Status::ParticlesLeft, "3 particles left"))
    } else {
        Err(Error::new(
            Status::Unstable,
            format!("particle id {rank} has a non-finite position"),
        ))
    };
    let e = outcome(&comm, "gimlet_step", local).unwrap_err();
    assert_eq!(e.status, Status::Unstable, "{}", e.msg);
    let winner = if size > 1 { 1 } else { 0 };
    assert!(
        e.msg
            .contains(&format!("particle id {winner} has a non-finite position")),
        "{}",
        e.msg
    );

    // A rejection on the last rank only reaches every rank, naming it.
    let dt = 1e-3f64;
    let last = size - 1;
    let local = if rank == last {
        Err(Error::arg("dt = NaN must be finite"))
    } else {
        Ok(7)
    };
    let e = agree(&comm, "gimlet_step", &args!(dt), local).unwrap_err();
    assert_eq!(e.status, Status::InvalidArgument);
    if size > 1 {
        assert_eq!(
            e.msg,
            format!("rejected on rank {last}: dt = NaN must be finite")
        );
    } else {
        assert_eq!(e.msg, "dt = NaN must be finite");
    }

    // Different arguments: every rank fails naming the first that differs.
    let t_end = 1.0 + rank as f64;
    let max_steps = 10i64;
    let r = agree(&comm, "gimlet_advance_to", &args!(max_steps, t_end), Ok(()));
    if size > 1 {
        let e = r.unwrap_err();
        assert_eq!(e.status, Status::InvalidArgument);
        assert!(
            e.msg
                .contains("different values of t_end (for example 1 and"),
            "{}",
            e.msg
        );
    } else {
        assert!(r.is_ok());
    }

    // Success keeps each rank's own value.
    let v = agree(&comm, "gimlet_particle_count", &Args::new(), Ok(rank * 3)).unwrap();
    assert_eq!(v, rank * 3);
    let v = outcome(&comm, "gimlet_particle_count", Ok(rank)).unwrap();
    assert_eq!(v, rank);

    drop(comm);
    // SAFETY: every communicator of this test was freed above.
    unsafe {
        mpi_sys::MPI_Finalize();
    }
}
