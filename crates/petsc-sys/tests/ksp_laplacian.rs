//! End-to-end check of the generated bindings: PETSc (and with it MPI) is
//! initialised, a 1D Laplacian is assembled as a parallel-capable AIJ matrix,
//! solved with CG + Jacobi, and the answer is compared with a known exact
//! solution.
//!
//! PETSc and MPI can be initialised once per process and the test harness runs
//! tests as threads of one process, so this file holds exactly one `#[test]`.
//! Every step only touches locally owned rows and gathers the solution with a
//! scatter, so the same binary also passes under `mpiexec -n 2`.

use petsc_sys::*;
use std::ptr;

/// Number of unknowns of the test problem.
const N: PetscInt = 10;

fn ok(code: PetscErrorCode, call: &str) {
    assert_eq!(code, 0, "{call} returned PETSc error code {code}");
}

/// Exact solution: x_i = (i+1)^2 for i = 0..N-1.
fn exact(i: PetscInt) -> f64 {
    let k = f64::from(i + 1);
    k * k
}

/// Row `i` of b = A x_exact for A = tridiag(-1, 2, -1) (Dirichlet ends),
/// computed here in Rust, independently of PETSc.
fn rhs(i: PetscInt) -> f64 {
    let left = if i > 0 { exact(i - 1) } else { 0.0 };
    let right = if i + 1 < N { exact(i + 1) } else { 0.0 };
    2.0 * exact(i) - left - right
}

#[test]
fn cg_jacobi_solves_1d_laplacian_to_the_exact_answer() {
    unsafe {
        ok(PetscInitializeNoArguments(), "PetscInitializeNoArguments");
        let mut flag = PetscBool::PETSC_FALSE;
        ok(PetscInitialized(&mut flag), "PetscInitialized");
        assert_eq!(flag, PetscBool::PETSC_TRUE);

        // PETSC_COMM_WORLD is an mpi-sys communicator: MPI calls accept it.
        let comm: mpi_sys::MPI_Comm = PETSC_COMM_WORLD;
        let (mut size, mut world) = (0, 0);
        assert_eq!(mpi_sys::MPI_Comm_size(comm, &mut size), 0);
        assert_eq!(
            mpi_sys::MPI_Comm_size(mpi_sys::RSMPI_COMM_WORLD, &mut world),
            0
        );
        assert_eq!(size, world, "PETSC_COMM_WORLD spans MPI_COMM_WORLD");

        // Errors come back as codes; with the ignore handler nothing prints.
        ok(
            PetscPushErrorHandler(Some(PetscIgnoreErrorHandler), ptr::null_mut()),
            "PetscPushErrorHandler",
        );
        let mut bad: Vec = ptr::null_mut();
        ok(VecCreate(comm, &mut bad), "VecCreate");
        let code = VecSetSizes(bad, N + 1, N); // local size above global size
        assert_ne!(code, 0, "VecSetSizes must reject local size > global size");
        ok(VecDestroy(&mut bad), "VecDestroy");
        assert!(bad.is_null(), "VecDestroy nulls the handle");
        ok(PetscPopErrorHandler(), "PetscPopErrorHandler");

        // A = tridiag(-1, 2, -1), rows split by PETSc.
        let mut a: Mat = ptr::null_mut();
        ok(MatCreate(comm, &mut a), "MatCreate");
        ok(
            MatSetSizes(a, PETSC_DECIDE, PETSC_DECIDE, N, N),
            "MatSetSizes",
        );
        ok(MatSetType(a, MATAIJ.as_ptr().cast()), "MatSetType");
        ok(
            MatSeqAIJSetPreallocation(a, 3, ptr::null()),
            "MatSeqAIJSetPreallocation",
        );
        ok(
            MatMPIAIJSetPreallocation(a, 3, ptr::null(), 1, ptr::null()),
            "MatMPIAIJSetPreallocation",
        );
        ok(
            MatSetOption(
                a,
                MatOption::MAT_NEW_NONZERO_ALLOCATION_ERR,
                PetscBool::PETSC_TRUE,
            ),
            "MatSetOption",
        );
        let (mut lo, mut hi) = (0, 0);
        ok(
            MatGetOwnershipRange(a, &mut lo, &mut hi),
            "MatGetOwnershipRange",
        );
        for i in lo..hi {
            let mut cols = [0 as PetscInt; 3];
            let mut vals = [0.0 as PetscScalar; 3];
            let mut k = 0;
            for (j, v) in [(i - 1, -1.0), (i, 2.0), (i + 1, -1.0)] {
                if (0..N).contains(&j) {
                    cols[k] = j;
                    vals[k] = v;
                    k += 1;
                }
            }
            ok(
                MatSetValues(
                    a,
                    1,
                    &i,
                    k as PetscInt,
                    cols.as_ptr(),
                    vals.as_ptr(),
                    InsertMode::INSERT_VALUES,
                ),
                "MatSetValues",
            );
        }
        ok(
            MatAssemblyBegin(a, MatAssemblyType::MAT_FINAL_ASSEMBLY),
            "MatAssemblyBegin",
        );
        ok(
            MatAssemblyEnd(a, MatAssemblyType::MAT_FINAL_ASSEMBLY),
            "MatAssemblyEnd",
        );
        let (mut rows, mut cols) = (0, 0);
        ok(MatGetSize(a, &mut rows, &mut cols), "MatGetSize");
        assert_eq!((rows, cols), (N, N));

        // b = A x_exact, filled on the owned rows.
        let mut b: Vec = ptr::null_mut();
        ok(VecCreateMPI(comm, PETSC_DECIDE, N, &mut b), "VecCreateMPI");
        let (mut vlo, mut vhi) = (0, 0);
        ok(
            VecGetOwnershipRange(b, &mut vlo, &mut vhi),
            "VecGetOwnershipRange",
        );
        assert_eq!((vlo, vhi), (lo, hi), "Vec and Mat rows split alike");
        let (mut global, mut local) = (0, 0);
        ok(VecGetSize(b, &mut global), "VecGetSize");
        ok(VecGetLocalSize(b, &mut local), "VecGetLocalSize");
        assert_eq!((global, local), (N, hi - lo));
        for i in lo..hi {
            let v = rhs(i);
            ok(
                VecSetValues(b, 1, &i, &v, InsertMode::INSERT_VALUES),
                "VecSetValues",
            );
        }
        ok(VecAssemblyBegin(b), "VecAssemblyBegin");
        ok(VecAssemblyEnd(b), "VecAssemblyEnd");

        let mut x: Vec = ptr::null_mut();
        ok(VecDuplicate(b, &mut x), "VecDuplicate");
        ok(VecSet(x, 0.0), "VecSet");

        // CG + Jacobi to a relative tolerance of 1e-12.
        let mut ksp: KSP = ptr::null_mut();
        ok(KSPCreate(comm, &mut ksp), "KSPCreate");
        ok(KSPSetOperators(ksp, a, a), "KSPSetOperators");
        ok(KSPSetType(ksp, KSPCG.as_ptr().cast()), "KSPSetType");
        let mut pc: PC = ptr::null_mut();
        ok(KSPGetPC(ksp, &mut pc), "KSPGetPC");
        ok(PCSetType(pc, PCJACOBI.as_ptr().cast()), "PCSetType");
        ok(
            KSPSetTolerances(ksp, 1e-12, 1e-50, PETSC_DEFAULT_REAL, 100),
            "KSPSetTolerances",
        );
        ok(KSPSetFromOptions(ksp), "KSPSetFromOptions");
        ok(KSPSolve(ksp, b, x), "KSPSolve");

        let mut reason = KSPConvergedReason::KSP_CONVERGED_ITERATING;
        ok(
            KSPGetConvergedReason(ksp, &mut reason),
            "KSPGetConvergedReason",
        );
        assert!(reason.0 > 0, "KSP did not converge: reason {}", reason.0);
        let mut its = 0;
        ok(
            KSPGetIterationNumber(ksp, &mut its),
            "KSPGetIterationNumber",
        );
        // CG ends in at most N steps in exact arithmetic (A has N distinct
        // eigenvalues); allow one more for rounding.
        assert!(
            (1..=N + 1).contains(&its),
            "CG took {its} iterations on an {N}x{N} SPD system"
        );

        // True residual ||b - A x|| / ||b||, computed apart from the KSP.
        let mut r: Vec = ptr::null_mut();
        ok(VecDuplicate(b, &mut r), "VecDuplicate");
        ok(MatMult(a, x, r), "MatMult");
        ok(VecAXPY(r, -1.0, b), "VecAXPY");
        let (mut rnorm, mut bnorm) = (0.0, 0.0);
        ok(VecNorm(r, NormType::NORM_2, &mut rnorm), "VecNorm");
        ok(VecNorm(b, NormType::NORM_2, &mut bnorm), "VecNorm");
        assert!(bnorm > 0.0);
        assert!(
            rnorm <= 1e-10 * bnorm,
            "relative residual {} above 1e-10",
            rnorm / bnorm
        );

        // Sum of the solution = sum of (i+1)^2 = N(N+1)(2N+1)/6.
        let mut sum = 0.0;
        ok(VecSum(x, &mut sum), "VecSum");
        let n = f64::from(N);
        let sum_exact = n * (n + 1.0) * (2.0 * n + 1.0) / 6.0;
        assert!(
            (sum - sum_exact).abs() <= 1e-9 * sum_exact,
            "sum of solution {sum} vs exact {sum_exact}"
        );

        // Every rank gathers the whole solution and checks it entrywise:
        // cond(A) < 50, so a 1e-12 residual means an error well below 1e-9.
        let mut scatter: VecScatter = ptr::null_mut();
        let mut all: Vec = ptr::null_mut();
        ok(
            VecScatterCreateToAll(x, &mut scatter, &mut all),
            "VecScatterCreateToAll",
        );
        ok(
            VecScatterBegin(
                scatter,
                x,
                all,
                InsertMode::INSERT_VALUES,
                ScatterMode::SCATTER_FORWARD,
            ),
            "VecScatterBegin",
        );
        ok(
            VecScatterEnd(
                scatter,
                x,
                all,
                InsertMode::INSERT_VALUES,
                ScatterMode::SCATTER_FORWARD,
            ),
            "VecScatterEnd",
        );
        let mut p: *const PetscScalar = ptr::null();
        ok(VecGetArrayRead(all, &mut p), "VecGetArrayRead");
        let xs = std::slice::from_raw_parts(p, N as usize);
        let scale = exact(N - 1);
        for (i, &xi) in (0..N).zip(xs) {
            assert!(
                (xi - exact(i)).abs() <= 1e-9 * scale,
                "x[{i}] = {xi}, exact {}",
                exact(i)
            );
        }
        ok(VecRestoreArrayRead(all, &mut p), "VecRestoreArrayRead");

        // Writable access round-trips through VecGetArray/VecRestoreArray.
        let mut w: *mut PetscScalar = ptr::null_mut();
        ok(VecGetArray(r, &mut w), "VecGetArray");
        std::slice::from_raw_parts_mut(w, (hi - lo) as usize).fill(1.0);
        ok(VecRestoreArray(r, &mut w), "VecRestoreArray");
        let mut ones = 0.0;
        ok(VecSum(r, &mut ones), "VecSum");
        assert_eq!(ones, n, "sum of N ones");

        ok(VecScatterDestroy(&mut scatter), "VecScatterDestroy");
        ok(VecDestroy(&mut all), "VecDestroy");
        ok(VecDestroy(&mut r), "VecDestroy");
        ok(KSPDestroy(&mut ksp), "KSPDestroy");
        ok(VecDestroy(&mut x), "VecDestroy");
        ok(VecDestroy(&mut b), "VecDestroy");
        ok(MatDestroy(&mut a), "MatDestroy");
        assert!(a.is_null() && ksp.is_null());

        ok(PetscFinalize(), "PetscFinalize");
        let mut done = PetscBool::PETSC_FALSE;
        ok(PetscFinalized(&mut done), "PetscFinalized");
        assert_eq!(done, PetscBool::PETSC_TRUE);
    }
}
