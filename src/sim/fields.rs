//! Particle fields as the C API reads and sets them: gather and scatter
//! over a rank's owned particles, in the order of the queries.

use super::Simulation;
use crate::error::{Error, Result};
use crate::limits;
use crate::particles::Particles;

/// Number of components of each particle field (see [`Simulation::gather`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Field {
    /// x, y.
    Position,
    /// vx, vy.
    Velocity,
    /// Cauchy stress xx, yy, xy, zz.
    Stress,
    /// Green–Lagrange strain xx, yy, xy from F.
    Strain,
    /// Deformation gradient xx, xy, yx, yy.
    DefGrad,
    /// Current half-lengths lpx, lpy.
    HalfLength,
    /// Mass.
    Mass,
    /// Level of the particle (as a number).
    Level,
    /// Reference volume.
    Volume0,
    /// Reference (initial) position x0, y0.
    Reference,
    /// Contact pressure after the particle's level's last step (0 when the
    /// particle is not in contact with an indenter).
    ContactPressure,
    /// Equivalent plastic strain (0 for the elastic laws).
    PlasticStrain,
    /// The APIC affine velocity matrix C xx, xy, yx, yy.
    Affine,
    /// The out-of-plane stretch: the hoop stretch `F_θθ` in axisymmetry,
    /// 1 in plane strain.
    HoopStretch,
}

impl Field {
    /// Components per particle.
    pub fn ncomp(self) -> usize {
        match self {
            Field::Position | Field::Velocity | Field::HalfLength | Field::Reference => 2,
            Field::Stress | Field::DefGrad | Field::Affine => 4,
            Field::Strain => 3,
            Field::Mass
            | Field::Level
            | Field::Volume0
            | Field::ContactPressure
            | Field::PlasticStrain
            | Field::HoopStretch => 1,
        }
    }
}

impl Simulation {
    /// Number of local particles (owned ones: copies that couple levels
    /// are not counted).
    pub fn num_local(&self) -> usize {
        self.local_sets()
            .map(|(_, p)| {
                p.copy
                    .iter()
                    .filter(|&&c| c == crate::particles::OWNED)
                    .count()
            })
            .sum()
    }

    /// Every local particle set with its level, in the order queries use
    /// (levels, then patches, then slots).
    pub fn local_sets(&self) -> impl Iterator<Item = (usize, &Particles)> {
        self.levels
            .iter()
            .flat_map(|l| l.particle_sets().map(move |p| (l.l, p)))
    }

    /// Sets `field` (velocity or stress only) of every local owned particle
    /// from `values` (`ncomp` per particle, the order of
    /// [`Simulation::gather`]). Copies are refreshed before the next step.
    pub fn scatter(&mut self, field: Field, values: &[f64]) -> Result<()> {
        self.check_scatter(field, values)?;
        self.scatter_checked(field, values);
        Ok(())
    }

    /// Checks the arguments of [`Simulation::scatter`] (local): a settable
    /// field, one value set per local particle, every value within the
    /// magnitude window of [`crate::limits`].
    pub fn check_scatter(&self, field: Field, values: &[f64]) -> Result<()> {
        if !matches!(field, Field::Velocity | Field::Stress | Field::Affine) {
            return Err(Error::arg(
                "field must be GIMLET_FIELD_VELOCITY, GIMLET_FIELD_STRESS or GIMLET_FIELD_AFFINE (the others follow from the motion)",
            ));
        }
        let nc = field.ncomp();
        let n = self.num_local();
        if values.len() != n * nc {
            return Err(Error::arg(format!(
                "n = {} values must equal the {n} local particles times {nc} components",
                values.len() / nc.max(1)
            )));
        }
        if let Some(k) = values
            .iter()
            .position(|v| !(v.is_finite() && v.abs() <= limits::MAG_MAX))
        {
            return Err(Error::arg(format!(
                "values[{k}] = {} must be finite with magnitude <= {:e}",
                values[k],
                limits::MAG_MAX
            )));
        }
        Ok(())
    }

    /// [`Simulation::scatter`] of checked values.
    pub fn scatter_checked(&mut self, field: Field, values: &[f64]) {
        let nc = field.ncomp();
        let mut k = 0;
        for l in &mut self.levels {
            for lp in &mut l.local {
                let p = &mut lp.parts;
                for i in 0..p.len() {
                    if p.copy[i] != crate::particles::OWNED {
                        continue;
                    }
                    let v = &values[k * nc..(k + 1) * nc];
                    match field {
                        Field::Velocity => {
                            p.vx[i] = v[0];
                            p.vy[i] = v[1];
                        }
                        Field::Affine => {
                            p.cxx[i] = v[0];
                            p.cxy[i] = v[1];
                            p.cyx[i] = v[2];
                            p.cyy[i] = v[3];
                        }
                        _ => {
                            p.sxx[i] = v[0];
                            p.syy[i] = v[1];
                            p.sxy[i] = v[2];
                            p.szz[i] = v[3];
                        }
                    }
                    k += 1;
                }
            }
        }
        self.dt_cfl1 = None;
        self.synced = false;
        self.invalidate_snapshot();
    }

    /// The values of `field` of every local particle, `ncomp` per particle,
    /// in the order of [`Simulation::local_sets`].
    pub fn gather(&self, field: Field, out: &mut Vec<f64>) {
        out.clear();
        if field == Field::ContactPressure {
            // Owned particles in contact, by (level, id); several indenters
            // on one particle add up.
            let mut by_id: std::collections::HashMap<(usize, u64), f64> = Default::default();
            for c in self.contact.points().filter(|c| c.owned) {
                *by_id.entry((c.level as usize, c.id)).or_insert(0.0) += c.pressure;
            }
            for (l, p) in self.local_sets() {
                for i in 0..p.len() {
                    if p.copy[i] == crate::particles::OWNED {
                        out.push(by_id.get(&(l, p.id[i])).copied().unwrap_or(0.0));
                    }
                }
            }
            return;
        }
        for (l, p) in self.local_sets() {
            for i in 0..p.len() {
                if p.copy[i] != crate::particles::OWNED {
                    continue;
                }
                match field {
                    Field::Position => out.extend_from_slice(&[p.x[i], p.y[i]]),
                    Field::Velocity => out.extend_from_slice(&[p.vx[i], p.vy[i]]),
                    Field::Stress => {
                        out.extend_from_slice(&[p.sxx[i], p.syy[i], p.sxy[i], p.szz[i]])
                    }
                    Field::Strain => {
                        let (a, b, c, d) = (p.fxx[i], p.fxy[i], p.fyx[i], p.fyy[i]);
                        // E = (F^T F - I)/2
                        out.extend_from_slice(&[
                            0.5 * (a * a + c * c - 1.0),
                            0.5 * (b * b + d * d - 1.0),
                            0.5 * (a * b + c * d),
                        ]);
                    }
                    Field::DefGrad => {
                        out.extend_from_slice(&[p.fxx[i], p.fxy[i], p.fyx[i], p.fyy[i]])
                    }
                    Field::HalfLength => out.extend_from_slice(&[p.lpx[i], p.lpy[i]]),
                    Field::Mass => out.push(p.mass[i]),
                    Field::Level => out.push(l as f64),
                    Field::Volume0 => out.push(p.vol0[i]),
                    Field::Reference => out.extend_from_slice(&[p.x0[i], p.y0[i]]),
                    Field::ContactPressure => unreachable!("handled above"),
                    Field::PlasticStrain => out.push(p.eps_p[i]),
                    Field::Affine => {
                        out.extend_from_slice(&[p.cxx[i], p.cxy[i], p.cyx[i], p.cyy[i]])
                    }
                    Field::HoopStretch => out.push(p.fzz[i]),
                }
            }
        }
    }
}
