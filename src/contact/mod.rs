//! Contact with rigid indenters (the paper's section 2.1, eqs. 8–11),
//! frictionless or with Coulomb friction: the indenters' geometry and
//! prescribed motion ([`indenter`]), the contact boundary of a particle and
//! its face integrals ([`face`]), the complementarity problem of a level
//! step ([`system`]) and its tangential part ([`friction`]), and the phase
//! of the level step that detects, solves and applies contact
//! ([`resolve`]).
//!
//! Contact acts inside every level step, between the grid update (which
//! gives the nodal velocities without contact, eq. 9) and the
//! grid-to-particle passes, on whichever level holds the particles under
//! an indenter; the pressures are solved through [`crate::linsolve`].

pub mod face;
pub mod face_axi;
pub mod friction;
pub mod indenter;
pub mod resolve;
pub mod system;

pub use indenter::{Indenter, Motion, Shape};
pub use resolve::{ContactPoint, ContactStats, LevelContact, LevelStepContact};
pub use system::ContactOptions;

use crate::linsolve::{LcpOptions, Linsolve};

/// Most indenters a simulation holds.
pub const MAX_INDENTERS: usize = 1024;

/// The contact state of a simulation: its indenters, the options, the
/// solver (created at the first contact solve), and each level's contact
/// after its last step.
#[derive(Default)]
pub struct Contact {
    /// The indenters, in the order they were added (their ids).
    pub indenters: Vec<Indenter>,
    /// Options of the contact algorithm.
    pub options: ContactOptions,
    /// Options of the complementarity solve.
    pub lcp: LcpOptions,
    /// The solver, once a contact problem has been solved.
    pub solver: Option<Linsolve>,
    /// Per level: the contact after its last step.
    pub levels: Vec<LevelContact>,
    /// The current (or last) coarse step.
    pub coarse_dt: f64,
}

impl std::fmt::Debug for Contact {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Contact")
            .field("indenters", &self.indenters.len())
            .field("options", &self.options)
            .field("levels", &self.levels.len())
            .finish()
    }
}

impl Contact {
    /// The total force on indenter `k` per metre of thickness (N/m) over
    /// the last coarse step: the impulse of every level's owned
    /// particles in contact during the step (the finer levels' substeps
    /// included) over the step's length. A single substep's force
    /// fluctuates from step to step as particles start and stop touching;
    /// the impulse over a step does not double count, as every particle is
    /// owned by one level.
    pub fn force(&self, k: usize) -> [f64; 2] {
        let mut f = [0.0; 2];
        if self.coarse_dt.is_nan() || self.coarse_dt <= 0.0 {
            return f;
        }
        for l in &self.levels {
            if let Some(g) = l.impulse.get(k) {
                f[0] += g[0] / self.coarse_dt;
                f[1] += g[1] / self.coarse_dt;
            }
        }
        f
    }

    /// Starts a coarse step of `dt`: the impulses of the last one are
    /// cleared.
    pub fn begin_step(&mut self, dt: f64) {
        self.coarse_dt = dt;
        for l in &mut self.levels {
            for i in &mut l.impulse {
                *i = [0.0; 2];
            }
        }
    }

    /// Adds an indenter (validated) and returns its index.
    pub fn add_indenter(&mut self, shape: Shape, tip: [f64; 2]) -> crate::error::Result<u32> {
        if self.indenters.len() >= MAX_INDENTERS {
            return Err(crate::error::Error::arg(format!(
                "the indenter table is full ({MAX_INDENTERS} indenters)"
            )));
        }
        let ind = Indenter::new(shape, tip)?;
        self.indenters.push(ind);
        for l in &mut self.levels {
            l.force.resize(self.indenters.len(), [0.0; 2]);
        }
        Ok(self.indenters.len() as u32 - 1)
    }

    /// The indenter with index `k`, or an error naming the bound.
    pub fn indenter_mut(&mut self, k: i64) -> crate::error::Result<&mut Indenter> {
        let n = self.indenters.len();
        if k < 0 || k as usize >= n {
            return Err(crate::error::Error::arg(format!(
                "indenter = {k} must be in [0, {n}) (the indenters added so far)"
            )));
        }
        Ok(&mut self.indenters[k as usize])
    }

    /// The contact context of a step of level `l` ending at `t_end`, or
    /// `None` without indenters (creates the solver and the level's state
    /// when needed).
    pub fn level_step(
        &mut self,
        l: usize,
        t_end: f64,
        thickness: f64,
    ) -> Option<LevelStepContact<'_>> {
        if self.indenters.is_empty() {
            return None;
        }
        if self.levels.len() <= l {
            self.levels.resize_with(l + 1, LevelContact::default);
        }
        let lcp = &self.lcp;
        let solver = self
            .solver
            .get_or_insert_with(|| Linsolve::new(lcp.clone()));
        Some(LevelStepContact {
            indenters: &self.indenters,
            opts: &self.options,
            solver,
            out: &mut self.levels[l],
            t_end,
            thickness,
        })
    }

    /// Every level's contact points (levels in order).
    pub fn points(&self) -> impl Iterator<Item = &ContactPoint> {
        self.levels.iter().flat_map(|l| l.points.iter())
    }

    /// Contact statistics summed over levels.
    pub fn stats(&self) -> ContactStats {
        let mut s = ContactStats::default();
        for l in &self.levels {
            let o = &l.stats;
            s.detect += o.detect;
            s.gather += o.gather;
            s.assemble += o.assemble;
            s.solve += o.solve;
            s.apply += o.apply;
            s.solves += o.solves;
            s.max_unknowns = s.max_unknowns.max(o.max_unknowns);
            s.max_contacts = s.max_contacts.max(o.max_contacts);
            s.pivots += o.pivots;
            s.linear_solves += o.linear_solves;
            s.petsc_solves += o.petsc_solves;
            s.ksp_iterations += o.ksp_iterations;
            s.ksp_iterations_max = s.ksp_iterations_max.max(o.ksp_iterations_max);
            s.friction_solves += o.friction_solves;
            s.friction_iterations += o.friction_iterations;
            s.friction_iterations_max = s.friction_iterations_max.max(o.friction_iterations_max);
        }
        s
    }

    /// The energy dissipated by friction at indenter `k` since creation,
    /// per metre of thickness (J/m), summed over the levels.
    pub fn dissipation(&self, k: usize) -> f64 {
        self.levels
            .iter()
            .filter_map(|l| l.dissipation.get(k))
            .sum()
    }
}
