// A C++17 host of Gimlet, the way a C++ (FEM, SAMRAI) code would embed it:
// the handle lives in a RAII class (std::unique_ptr whose deleter calls
// gimlet_destroy), and a failed call throws an exception carrying the
// library's message.
//
//   mpiexec -n 2 ./cpp_host
//
// The scene: an elastic block dropped under gravity onto a fixed floor,
// run for a few hundred steps (free fall, impact, bouncing). Checks, on the
// global (all-rank) quantities, so that every rank decides alike:
//  - the total mass equals rho x area and never changes (particles carry a
//    fixed mass; only the summation order may change, so to 1e-14);
//  - in free fall (until a particle's support first nears the fixed nodes
//    of the floor) the momentum change equals the gravity impulse M g t to
//    round-off (1e-12 relative) and the horizontal momentum stays at
//    round-off;
//  - after the impact, kinetic + strain energy never exceed the work done by
//    gravity, M g (ycm0 - ycm), by more than 2% (the floor only absorbs
//    energy; the margin is for the explicit scheme's own error);
//  - no particle is lost and none ends below the floor.
// Exit status 0 when every check holds.
#include <gimlet.h>
#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace gimlet {

/// The calling thread's last error message of the library.
std::string last_error()
{
    std::size_t needed = 0;
    gimlet_last_error(nullptr, 0, &needed);
    std::string msg(needed, '\0');
    if (needed > 0)
        gimlet_last_error(msg.data(), msg.size(), &needed);
    msg.resize(std::strlen(msg.c_str()));
    return msg;
}

/// A failed library call: the status and the library's message.
class Error : public std::runtime_error {
public:
    Error(int status, const std::string &what)
        : std::runtime_error(what + " failed with status " + std::to_string(status) + ": " +
                             last_error()),
          status_(status)
    {
    }
    int status() const noexcept { return status_; }

private:
    int status_;
};

inline void check(int status, const char *what)
{
    if (status != GIMLET_OK)
        throw Error(status, what);
}

/// Global diagnostics (per unit thickness).
struct Diagnostics {
    double kinetic = 0, strain = 0, momentum_x = 0, momentum_y = 0, mass = 0;
};

/// A simulation handle. Destroying it calls gimlet_destroy, which is
/// collective: every rank must destroy its handle at the same point, before
/// MPI_Finalize.
class Simulation {
public:
    Simulation(MPI_Comm comm, double x0, double y0, double lx, double ly, double h)
    {
        GimletSim *p = nullptr;
        check(gimlet_create(comm, x0, y0, lx, ly, h, &p), "gimlet_create");
        handle_.reset(p);
    }

    GimletSim *get() const noexcept { return handle_.get(); }

    int add_linear_elastic(double e, double nu, double rho)
    {
        int id = -1;
        check(gimlet_add_material_linear_elastic(get(), e, nu, rho, &id),
              "gimlet_add_material_linear_elastic");
        return id;
    }

    std::int64_t fill_rectangle(double xlo, double ylo, double xhi, double yhi, int n_per_cell,
                                int material, double density, double vx = 0, double vy = 0)
    {
        std::int64_t added = 0;
        check(gimlet_fill_rectangle(get(), xlo, ylo, xhi, yhi, n_per_cell, material, density, vx,
                                    vy, &added),
              "gimlet_fill_rectangle");
        return added;
    }

    void set_patch_size(int level, int px, int py)
    {
        check(gimlet_set_patch_size(get(), level, px, py), "gimlet_set_patch_size");
    }
    void set_face_bc(int face, int bc)
    {
        check(gimlet_set_face_bc(get(), face, bc), "gimlet_set_face_bc");
    }
    void set_gravity(double gx, double gy)
    {
        check(gimlet_set_gravity(get(), gx, gy), "gimlet_set_gravity");
    }

    /// One stable step; returns the time reached.
    double step()
    {
        double t = 0;
        std::int64_t steps = 0;
        check(gimlet_step(get(), 0.0, &t, &steps), "gimlet_step");
        return t;
    }

    std::int64_t global_count() const
    {
        std::int64_t local = 0, global = 0;
        check(gimlet_particle_count(get(), &local, &global), "gimlet_particle_count");
        return global;
    }

    /// A field of this rank's particles, `ncomp` values per particle.
    std::vector<double> field(int fld) const
    {
        int ncomp = 0;
        std::int64_t count = 0;
        check(gimlet_field_components(get(), fld, &ncomp), "gimlet_field_components");
        check(gimlet_get_field(get(), fld, nullptr, 0, &count), "gimlet_get_field (count)");
        std::vector<double> out(static_cast<std::size_t>(count) * static_cast<std::size_t>(ncomp));
        check(gimlet_get_field(get(), fld, out.data(), count, &count), "gimlet_get_field");
        return out;
    }

    Diagnostics diagnostics() const
    {
        Diagnostics d;
        check(gimlet_diagnostics(get(), &d.kinetic, &d.strain, &d.momentum_x, &d.momentum_y,
                                 &d.mass),
              "gimlet_diagnostics");
        return d;
    }

    std::int64_t lost_particles() const
    {
        std::int64_t count = 0;
        check(gimlet_lost_particles(get(), nullptr, nullptr, 0, &count), "gimlet_lost_particles");
        return count;
    }

private:
    struct Destroy {
        void operator()(GimletSim *p) const noexcept { gimlet_destroy(&p); }
    };
    std::unique_ptr<GimletSim, Destroy> handle_;
};

} // namespace gimlet

namespace {

void require(bool cond, const std::string &what)
{
    if (!cond)
        throw std::runtime_error("check failed: " + what);
}

/// Global mass-weighted centre height and lowest particle centre.
struct Geometry {
    double ycm = 0, ymin = 0;
};

Geometry geometry(const gimlet::Simulation &sim, MPI_Comm comm)
{
    const std::vector<double> pos = sim.field(GIMLET_FIELD_POSITION);
    const std::vector<double> mass = sim.field(GIMLET_FIELD_MASS);
    double local[2] = {0, 0}; // sum m y, sum m
    double ymin = INFINITY;
    for (std::size_t p = 0; p < mass.size(); ++p) {
        local[0] += mass[p] * pos[2 * p + 1];
        local[1] += mass[p];
        ymin = std::min(ymin, pos[2 * p + 1]);
    }
    double global[2];
    Geometry g;
    MPI_Allreduce(local, global, 2, MPI_DOUBLE, MPI_SUM, comm);
    MPI_Allreduce(&ymin, &g.ymin, 1, MPI_DOUBLE, MPI_MIN, comm);
    g.ycm = global[0] / global[1];
    return g;
}

int run(MPI_Comm comm, int rank)
{
    // Domain [0, 1]^2, cells of 1/16, four level-0 patches of 8 x 8 cells
    // (spread over the ranks). Block [0.375, 0.625] x [0.25, 0.5] of 2 x 2
    // particles per cell (half-length h/4), density 1000: mass 62.5.
    const double h = 1.0 / 16, rho = 1000, g = 9.81, t_end = 0.6;
    const double lp = h / 4;
    const double mass0 = rho * 0.25 * 0.25;

    gimlet::Simulation sim(comm, 0.0, 0.0, 1.0, 1.0, h);
    sim.set_patch_size(0, 8, 8);
    const int mat = sim.add_linear_elastic(5.0e5, 0.3, rho);
    const std::int64_t n = sim.fill_rectangle(0.375, 0.25, 0.625, 0.5, 2, mat, rho);
    require(n == 4 * 4 * 4, "fill_rectangle added 64 particles (got " + std::to_string(n) + ")");
    sim.set_face_bc(GIMLET_FACE_BOTTOM, GIMLET_BC_FIXED);
    sim.set_gravity(0.0, -g);

    // A rejected call throws with the library's message; the handle stays usable.
    try {
        sim.set_face_bc(7, GIMLET_BC_FIXED);
        throw std::runtime_error("check failed: gimlet_set_face_bc accepted face 7");
    } catch (const gimlet::Error &e) {
        require(e.status() == GIMLET_ERR_INVALID_ARGUMENT && std::strstr(e.what(), "face"),
                "a bad face gives GIMLET_ERR_INVALID_ARGUMENT naming `face`");
    }

    const gimlet::Diagnostics d0 = sim.diagnostics();
    const Geometry geo0 = geometry(sim, comm);
    require(std::abs(d0.mass - mass0) <= 1e-12 * mass0, "initial mass = rho x area");
    require(d0.momentum_y == 0.0 && d0.kinetic == 0.0, "the block starts at rest");

    double t = 0, worst_free_fall = 0, worst_px = 0, worst_energy = 0;
    int steps = 0, free_steps = 0, contact_steps = 0;
    while (t < t_end && steps < 5000) {
        t = sim.step();
        ++steps;
        const gimlet::Diagnostics d = sim.diagnostics();
        const Geometry geo = geometry(sim, comm);
        require(std::abs(d.mass - mass0) <= 1e-14 * mass0,
                "mass conserved at step " + std::to_string(steps));
        const double impulse = mass0 * g * t;
        // Free fall: until a particle's support (h + lp from its centre)
        // first comes within a cell of the fixed nodes at y = 0.
        if (contact_steps == 0 && geo.ymin > 2 * h + lp) {
            ++free_steps;
            worst_free_fall = std::max(worst_free_fall, std::abs(d.momentum_y + impulse) / impulse);
            worst_px = std::max(worst_px, std::abs(d.momentum_x) / impulse);
        } else {
            ++contact_steps;
        }
        // Energy: what the block holds never exceeds what gravity gave it.
        const double work = mass0 * g * (geo0.ycm - geo.ycm);
        const double energy = d.kinetic + d.strain;
        if (work > 0)
            worst_energy = std::max(worst_energy, energy / work);
        require(energy <= 1.02 * work + 1e-12 * mass0 * g,
                "kinetic + strain energy " + std::to_string(energy) +
                    " exceeds the work of gravity " + std::to_string(work) + " by > 2% at step " +
                    std::to_string(steps));
        require(geo.ymin > 0, "no particle centre below the floor");
    }
    const Geometry geo = geometry(sim, comm);
    if (rank == 0) {
        std::printf("cpp_host: %d steps to t = %.4f (%d in free fall, %d in contact)\n", steps, t,
                    free_steps, contact_steps);
        std::printf("  free fall: max |dp_y - M g t| / (M g t) = %.3e, max |p_x| / (M g t) = %.3e\n",
                    worst_free_fall, worst_px);
        std::printf("  max (KE + SE) / (M g drop) = %.4f; centre height %.4f -> %.4f\n",
                    worst_energy, geo0.ycm, geo.ycm);
    }
    require(free_steps >= 50, "at least 50 free-fall steps were checked");
    require(contact_steps >= 50, "at least 50 steps after contact were checked");
    require(worst_free_fall <= 1e-12, "free-fall momentum change = M g t to 1e-12");
    require(worst_px <= 1e-12, "free-fall horizontal momentum at round-off");
    require(sim.global_count() == n, "particle count unchanged");
    std::int64_t lost = sim.lost_particles(), lost_all = 0;
    MPI_Allreduce(&lost, &lost_all, 1, MPI_INT64_T, MPI_SUM, comm);
    require(lost_all == 0, "no particle lost");
    return 0;
}

} // namespace

int main(int argc, char **argv)
{
    MPI_Init(&argc, &argv);
    int rank = 0, size = 1;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    MPI_Comm_size(MPI_COMM_WORLD, &size);
    int rc = 0;
    // Every check above is on global values and every library failure here
    // is collective, so all ranks throw (or not) together and the handle's
    // destructor (a collective gimlet_destroy) runs on all of them.
    try {
        rc = run(MPI_COMM_WORLD, rank);
    } catch (const std::exception &e) {
        std::fprintf(stderr, "[rank %d] %s\n", rank, e.what());
        rc = 1;
    }
    int worst = 0;
    MPI_Allreduce(&rc, &worst, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    if (rank == 0)
        std::printf("cpp_host on %d rank(s): %s\n", size, worst == 0 ? "ok" : "FAILED");
    MPI_Finalize();
    return worst == 0 ? 0 : 1;
}
