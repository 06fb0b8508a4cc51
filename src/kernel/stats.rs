//! What the particle passes report: the stable step they measured and the
//! first particle with each kind of problem ([`PassStats`]), and how those
//! notes become the step's error.

use crate::error::{Error, Result, Status};
use crate::particles::Particles;

/// What a grid-to-particle pass found.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct PassStats {
    /// `min_p h / (c_p + |v_p|)` over the owned particles after the step
    /// (the copies that couple levels are left out: the synchronisation
    /// after the step replaces them): the stable step at CFL 1 (infinite
    /// without particles; set by the last pass only).
    pub dt_cfl1: f64,
    /// First particle (slot) with a non-finite value.
    pub first_nonfinite: Option<usize>,
    /// First particle whose deformation gradient has `J <= 0`.
    pub first_inverted: Option<usize>,
    /// First particle whose stencil is not inside the grid.
    pub first_outside: Option<usize>,
    /// First particle whose strain increment in this step exceeded
    /// [`MAX_STRAIN_INCREMENT`], with the increment.
    pub first_runaway: Option<(usize, f64)>,
    /// First and last particle (slot) that may have left the grid's own
    /// cells (see [`super::Grid::ghost`]): set by the pass that moves the
    /// particles, conservatively (a particle within about 1e-9 cells of the
    /// border counts), so that every particle outside this range is
    /// certainly still in its cell box and a migration need not look at it.
    pub leaving: Option<(usize, usize)>,
}

/// The largest strain increment a particle may take in one step: the norm
/// `|D| dt = dt sqrt(Dxx² + Dyy² + 2 Dxy²)` of the symmetric part of the
/// velocity gradient times the step (rotations do not count). A stable
/// explicit step strains a particle by about `2 cfl |Δv|/c` (the velocity
/// jump across a cell over the wave speed, at most 1 at CFL 0.5 even for
/// an impact at the wave speed); an increment above 1, the particle
/// doubling its length in one step, is a run going unstable (an absurd
/// load, a step far beyond the stable one), caught at the step it happens
/// rather than steps later when the stable step has shrunk.
pub const MAX_STRAIN_INCREMENT: f64 = 1.0;

impl PassStats {
    /// Adds the notes of `o` (a pass before this one, on the same
    /// particles): the first of each problem and the union of the leaving
    /// ranges; `dt_cfl1` stays this pass's.
    pub(super) fn merge(&mut self, o: &PassStats) {
        self.first_nonfinite = self.first_nonfinite.or(o.first_nonfinite);
        self.first_inverted = self.first_inverted.or(o.first_inverted);
        self.first_outside = self.first_outside.or(o.first_outside);
        self.first_runaway = self.first_runaway.or(o.first_runaway);
        self.leaving = union_range(self.leaving, o.leaving);
    }

    /// The error this pass reports, if any: non-finite values, inverted
    /// particles and strain increments above [`MAX_STRAIN_INCREMENT`] are
    /// `Unstable`, particles off the grid `ParticlesLeft`.
    pub fn to_result(&self, parts: &Particles) -> Result<()> {
        if let Some(p) = self.first_nonfinite {
            return Err(Error::new(
                Status::Unstable,
                format!(
                    "particle id {} has a non-finite position, velocity or stress after the step (reduce dt or check the loads)",
                    parts.id.get(p).copied().unwrap_or(0)
                ),
            ));
        }
        if let Some(p) = self.first_inverted {
            return Err(Error::new(
                Status::Unstable,
                format!(
                    "particle id {} has an inverted deformation gradient (det F <= 0) after the step",
                    parts.id[p]
                ),
            ));
        }
        if let Some((p, e)) = self.first_runaway {
            return Err(Error::new(
                Status::Unstable,
                format!(
                    "particle id {} took a strain increment of {e:.3e} in one step (at most {MAX_STRAIN_INCREMENT}): the run is unstable (reduce dt or check the loads)",
                    parts.id[p]
                ),
            ));
        }
        if let Some(p) = self.first_outside {
            return Err(Error::new(
                Status::ParticlesLeft,
                format!(
                    "particle id {} at ({}, {}) has left the patch grid",
                    parts.id[p], parts.x[p], parts.y[p]
                ),
            ));
        }
        Ok(())
    }
}

/// The smallest range holding both ranges (of [`PassStats::leaving`]).
pub fn union_range(a: Option<(usize, usize)>, b: Option<(usize, usize)>) -> Option<(usize, usize)> {
    match (a, b) {
        (Some(a), Some(b)) => Some((a.0.min(b.0), a.1.max(b.1))),
        (a, b) => a.or(b),
    }
}

/// Widens `range` to hold particle `p`.
#[inline(always)]
pub(super) fn note_leaving(range: &mut Option<(usize, usize)>, p: usize) {
    *range = Some(range.map_or((p, p), |(a, b)| (a.min(p), b.max(p))));
}

/// Records `p` in `first` unless a smaller index is there already.
#[inline(always)]
pub(super) fn note_first(first: &mut Option<usize>, p: usize) {
    *first = Some(first.map_or(p, |q| q.min(p)));
}

/// First particle with a non-finite position, velocity, F, stress or
/// affine matrix.
pub(super) fn first_nonfinite(p: &Particles) -> Option<usize> {
    (0..p.len()).find(|&i| {
        ![
            p.x[i], p.y[i], p.vx[i], p.vy[i], p.fxx[i], p.fxy[i], p.fyx[i], p.fyy[i], p.sxx[i],
            p.syy[i], p.sxy[i], p.szz[i], p.cxx[i], p.cxy[i], p.cyx[i], p.cyy[i],
        ]
        .iter()
        .all(|v| v.is_finite())
    })
}
