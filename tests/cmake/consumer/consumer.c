/* A minimal host program: initialises MPI, checks the library's version
 * against the header it was compiled with, creates a simulation on
 * MPI_COMM_WORLD, checks that a bad argument comes back as an error with a
 * message (not an abort), and destroys the simulation.
 * Exit status 0 on success on every rank. */
#include <gimlet.h>
#include <mpi.h>
#include <stdio.h>
#include <string.h>

static int fail(int rank, const char *what, int status)
{
    char msg[512];
    size_t needed = 0;
    msg[0] = '\0';
    gimlet_last_error(msg, sizeof msg, &needed);
    fprintf(stderr, "[rank %d] %s failed with status %d: %s\n", rank, what, status, msg);
    return 1;
}

int main(int argc, char **argv)
{
    int rank = 0, size = 0, st;
    int major = -1, minor = -1, patch = -1;
    GimletSim *sim = NULL;
    int errors = 0, total = 0;

    MPI_Init(&argc, &argv);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &size);

    st = gimlet_version(&major, &minor, &patch);
    if (st != 0) {
        errors += fail(rank, "gimlet_version", st);
    } else if (major != GIMLET_VERSION_MAJOR || minor != GIMLET_VERSION_MINOR ||
               patch != GIMLET_VERSION_PATCH) {
        fprintf(stderr, "[rank %d] library is %d.%d.%d, header is %d.%d.%d\n", rank, major,
                minor, patch, GIMLET_VERSION_MAJOR, GIMLET_VERSION_MINOR, GIMLET_VERSION_PATCH);
        errors++;
    }

    /* A 1 x 0.5 domain with cells of 1/8 (exact in binary). */
    st = gimlet_create(MPI_COMM_WORLD, 0.0, 0.0, 1.0, 0.5, 0.125, &sim);
    if (st != 0) {
        errors += fail(rank, "gimlet_create", st);
    } else if (sim == NULL) {
        fprintf(stderr, "[rank %d] gimlet_create returned 0 but no handle\n", rank);
        errors++;
    }

    /* A negative cell size must be refused with a status and a message. */
    {
        GimletSim *bad = NULL;
        char msg[512];
        size_t needed = 0;
        st = gimlet_create(MPI_COMM_WORLD, 0.0, 0.0, 1.0, 0.5, -0.125, &bad);
        msg[0] = '\0';
        if (st == 0 || bad != NULL) {
            fprintf(stderr, "[rank %d] gimlet_create accepted h = -0.125\n", rank);
            errors++;
            if (bad != NULL)
                gimlet_destroy(&bad);
        } else if (gimlet_last_error(msg, sizeof msg, &needed) != 0 || needed == 0 ||
                   strlen(msg) == 0) {
            fprintf(stderr, "[rank %d] no last-error message after a refused call\n", rank);
            errors++;
        }
    }

    if (sim != NULL) {
        st = gimlet_destroy(&sim);
        if (st != 0)
            errors += fail(rank, "gimlet_destroy", st);
        else if (sim != NULL) {
            fprintf(stderr, "[rank %d] gimlet_destroy left the handle set\n", rank);
            errors++;
        }
    }

    MPI_Allreduce(&errors, &total, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
    if (rank == 0)
        printf("gimlet %d.%d.%d on %d rank(s): %s\n", major, minor, patch, size,
               total == 0 ? "ok" : "FAILED");
    MPI_Finalize();
    return total == 0 ? 0 : 1;
}
