//! A simulation rebuilt from a saved state (a checkpoint): its settings
//! first, then its particles in their patch order and its lost list.

use super::{RunConfig, Simulation};
use crate::comm::Comm;
use crate::error::{Error, Result, Status};
use crate::geom::Hierarchy;
use crate::level::Departure;
use crate::material::Material;
use crate::particles::PackedParticle;

/// The state of a simulation apart from its particles and lost list, as a
/// checkpoint stores it (see [`Simulation::restore`]).
#[derive(Clone, Debug)]
pub struct Restore {
    /// The layout of levels and patches.
    pub hier: Hierarchy,
    /// The plane-strain thickness.
    pub thickness: f64,
    /// Plane strain or axisymmetry.
    pub mode: crate::mode::ModeKind,
    /// The material table.
    pub materials: Vec<Material>,
    /// The run settings.
    pub run: RunConfig,
    /// Simulated time.
    pub time: f64,
    /// Steps taken.
    pub steps: u64,
    /// The next unused global particle id.
    pub next_id: u64,
    /// Whether the layout was frozen (particles had been inserted).
    pub frozen: bool,
    /// Whether the copies that couple levels were current (they are stored
    /// with the other particles).
    pub copies_current: bool,
    /// Particles moved between patches of each level, summed over the
    /// ranks (kept on rank 0, whose counts the sums over ranks report).
    pub crossings: Vec<u64>,
}

impl Simulation {
    /// The saved state `r` on `comm` (which it takes over), with no
    /// particles yet: [`Simulation::restore_particle`] and
    /// [`Simulation::restore_lost`] add them. The thickness, materials and
    /// run settings go through their setters' checks; the layout is frozen
    /// when it was. Local (no communication).
    pub fn restore(comm: Comm, r: Restore) -> Result<Simulation> {
        let Restore {
            hier,
            thickness,
            mode,
            materials,
            run,
            time,
            steps,
            next_id,
            frozen,
            copies_current,
            crossings,
        } = r;
        let mut sim = Simulation::on(comm, hier);
        if mode == crate::mode::ModeKind::PlaneStrain {
            sim.set_thickness(thickness)?;
        }
        sim.set_mode(mode)?;
        for m in materials {
            sim.add_material(m)?;
        }
        sim.set_run(run)?;
        sim.time = time;
        sim.steps = steps;
        sim.synced = copies_current;
        sim.next_id = next_id;
        if frozen {
            sim.freeze();
        }
        if sim.comm.rank() == 0 {
            for (lv, &c) in sim.levels.iter_mut().zip(&crossings) {
                lv.crossings = c;
            }
        }
        Ok(sim)
    }

    /// Appends a restored particle to patch `k` of level `l`, which this
    /// rank must own (particles go in their patch order).
    pub fn restore_particle(&mut self, l: usize, k: usize, p: PackedParticle) -> Result<()> {
        let lp = self
            .levels
            .get_mut(l)
            .and_then(|lv| lv.local_mut(k))
            .ok_or_else(|| {
                Error::new(
                    Status::Internal,
                    "a particle was sent to a rank not owning its patch",
                )
            })?;
        lp.parts.push_packed(p);
        Ok(())
    }

    /// Sets this rank's list of particles that left the domain.
    pub fn restore_lost(&mut self, lost: Vec<Departure>) {
        self.lost = lost;
    }

    /// Replaces the whole simulated state by `other`'s (a simulation
    /// restored from a checkpoint, built on a duplicate of this
    /// communicator), keeping this handle's communicator; caches are
    /// recomputed from the new state. Collective (the duplicate
    /// communicator `other` came with is freed).
    pub fn replace_state(&mut self, mut other: Simulation) {
        let synced = other.synced;
        std::mem::swap(&mut self.comm, &mut other.comm);
        std::mem::swap(self, &mut other);
        self.particles_changed();
        self.synced = synced;
    }
}
