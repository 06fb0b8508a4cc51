//! Closed-form solutions for validating the axisymmetric mode: Lamé's thick
//! sphere and cylinder under internal pressure, and the elastic contacts of
//! a rigid axisymmetric indenter on a half-space (Sneddon's cone, Hertz's
//! paraboloid, the exact sphere, the flat cylindrical punch).
//!
//! SI units; `E* = E/(1 − ν²)` for a rigid indenter (or the reduced modulus
//! `E_r` for an elastic one, `1/E_r = (1 − ν²)/E + (1 − ν_i²)/E_i`).
//! Contact loads are for the whole body (N); the simulation's per-radian
//! forces are `1/(2π)` of them. Depths `h` are the indenter's approach
//! towards the undeformed surface far away (the half-space's far field);
//! displacements into the body are positive, compressive pressures
//! positive. Sources: Johnson, *Contact Mechanics* (1985), ch. 3 and 5;
//! Sneddon, Int. J. Eng. Sci. 3 (1965); Timoshenko & Goodier, *Theory of
//! Elasticity*, for Lamé. Each formula is checked in the tests against
//! another relation it must satisfy (equilibrium, boundary tractions,
//! Hooke's law, the total load, the punch stiffness `dP/dh = 2 E* a` that
//! every frictionless axisymmetric contact shares, far-field and small-size
//! limits).
//!
//! Half-space caveat for the tests that use them: a finite specimen is
//! more compliant than the half-space (its depth includes the body's own
//! deflection), so compare loads against contact radii and pressures, or
//! measure the depth relative to a surface point, or size the body to
//! make the difference small and say how small.

use std::f64::consts::PI;

/// Stress and displacement of an axisymmetric field in cylindrical
/// components `(r, z, θ)`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AxiField {
    /// Radial displacement (m).
    pub u_r: f64,
    /// Axial displacement (m).
    pub u_z: f64,
    /// σ_rr (Pa).
    pub s_rr: f64,
    /// σ_zz (Pa).
    pub s_zz: f64,
    /// σ_rz (Pa).
    pub s_rz: f64,
    /// σ_θθ, the hoop stress (Pa).
    pub s_tt: f64,
}

/// A hollow sphere (inner radius `a`, outer `b`) under internal pressure
/// `p`, linear elastic (Lamé):
///
/// ```text
/// u_R  = p a³ / (E (b³ − a³)) [(1 − 2ν) R + (1 + ν) b³ / (2R²)]
/// σ_RR = p a³ / (b³ − a³) (1 − b³/R³)
/// σ_tt = p a³ / (b³ − a³) (1 + b³/(2R³))   (both tangential components)
/// ```
///
/// with `R` the distance from the centre. For `a = 1`, `b = 2`, `ν = 0.3`:
/// `σ_tt(a) = 5p/7`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LameSphere {
    /// Inner radius (m).
    pub a: f64,
    /// Outer radius (m), `> a`.
    pub b: f64,
    /// Internal pressure (Pa).
    pub p: f64,
    /// Young's modulus (Pa).
    pub e: f64,
    /// Poisson's ratio.
    pub nu: f64,
}

impl LameSphere {
    /// `(u_R, σ_RR, σ_tt)` at the distance `big_r` from the centre.
    pub fn at(&self, big_r: f64) -> (f64, f64, f64) {
        let (a3, b3) = (self.a.powi(3), self.b.powi(3));
        let k = self.p * a3 / (b3 - a3);
        let r3 = big_r.powi(3);
        let u = k / self.e
            * ((1.0 - 2.0 * self.nu) * big_r + (1.0 + self.nu) * b3 / (2.0 * big_r * big_r));
        (u, k * (1.0 - b3 / r3), k * (1.0 + b3 / (2.0 * r3)))
    }

    /// The field in the cylindrical components of the axisymmetric mode at
    /// `(r, z)` (centre at the origin, z the axis): with `n = (r, z)/R`,
    /// `u = u_R n`, `σ = σ_RR n⊗n + σ_tt (I − n⊗n)` in the meridian plane,
    /// and the hoop stress `σ_θθ = σ_tt`.
    pub fn at_cylindrical(&self, r: f64, z: f64) -> AxiField {
        let big_r = r.hypot(z);
        let (nr, nz) = (r / big_r, z / big_r);
        let (u, srr, stt) = self.at(big_r);
        AxiField {
            u_r: u * nr,
            u_z: u * nz,
            s_rr: srr * nr * nr + stt * (1.0 - nr * nr),
            s_zz: srr * nz * nz + stt * (1.0 - nz * nz),
            s_rz: (srr - stt) * nr * nz,
            s_tt: stt,
        }
    }
}

/// The axial condition of a thick cylinder.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CylinderEnds {
    /// `ε_zz = 0` (a long cylinder between rollers): `σ_zz = 2νA`.
    PlaneStrain,
    /// Free ends, no axial force: `σ_zz = 0`.
    Open,
    /// Capped ends carrying the pressure on the caps: `σ_zz = A`.
    Closed,
}

/// A thick-walled cylinder (inner radius `a`, outer `b`) under internal
/// pressure `p`, linear elastic (Lamé), with
/// `A = p a²/(b² − a²)`, `B = p a² b²/(b² − a²)`:
///
/// ```text
/// σ_rr = A − B/r²     σ_θθ = A + B/r²     σ_zz = E ε_zz + 2νA
/// u_r  = [(1 + ν)(1 − 2ν) A r + (1 + ν) B / r] / E − ν ε_zz r
/// ```
///
/// with the uniform axial strain `ε_zz` of [`CylinderEnds`]. For `a = 1`,
/// `b = 2`: `σ_θθ(a) = 5p/3`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LameCylinder {
    /// Inner radius (m).
    pub a: f64,
    /// Outer radius (m), `> a`.
    pub b: f64,
    /// Internal pressure (Pa).
    pub p: f64,
    /// Young's modulus (Pa).
    pub e: f64,
    /// Poisson's ratio.
    pub nu: f64,
    /// The axial condition.
    pub ends: CylinderEnds,
}

impl LameCylinder {
    fn ab(&self) -> (f64, f64) {
        let (a2, b2) = (self.a * self.a, self.b * self.b);
        (self.p * a2 / (b2 - a2), self.p * a2 * b2 / (b2 - a2))
    }

    /// The uniform axial strain `ε_zz` (`u_z = ε_zz z`).
    pub fn axial_strain(&self) -> f64 {
        let (ca, _) = self.ab();
        match self.ends {
            CylinderEnds::PlaneStrain => 0.0,
            CylinderEnds::Open => -2.0 * self.nu * ca / self.e,
            CylinderEnds::Closed => (1.0 - 2.0 * self.nu) * ca / self.e,
        }
    }

    /// The field at radius `r` and height `z`.
    pub fn at(&self, r: f64, z: f64) -> AxiField {
        let (ca, cb) = self.ab();
        let ez = self.axial_strain();
        let nu = self.nu;
        AxiField {
            u_r: ((1.0 + nu) * (1.0 - 2.0 * nu) * ca * r + (1.0 + nu) * cb / r) / self.e
                - nu * ez * r,
            u_z: ez * z,
            s_rr: ca - cb / (r * r),
            s_zz: self.e * ez + 2.0 * nu * ca,
            s_rz: 0.0,
            s_tt: ca + cb / (r * r),
        }
    }
}

/// A rigid cone of half-angle `ψ` (the angle between the axis and a face;
/// 70.3° for the Berkovich/Vickers-equivalent cone) on an elastic
/// half-space, frictionless (Sneddon 1965):
///
/// ```text
/// P = (2/π) E* tan ψ h²        a = (2/π) h tan ψ       h_c = (2/π) h
/// p(r) = (E* / (2 tan ψ)) arccosh(a/r)   (r < a; mean pressure E*/(2 tan ψ))
/// u_z(r) = h − r / tan ψ                  (r ≤ a)
/// u_z(r) = [√(r² − a²) − r + a arcsin(a/r)] / tan ψ   (r ≥ a)
/// ```
///
/// Finite elements find blunt-cone loads a few per cent above `P` (Hay,
/// Bolshakov & Pharr 1999: Sneddon's solution ignores the surface's radial
/// displacement; their factor is about 1.07 at 70.3° for ν = 0.3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SneddonCone {
    /// Contact modulus `E*` (Pa).
    pub e_star: f64,
    /// Half-angle `ψ` (rad), in `(0, π/2)`.
    pub half_angle: f64,
}

impl SneddonCone {
    /// Load at depth `h` (N).
    pub fn load(&self, h: f64) -> f64 {
        2.0 / PI * self.e_star * self.half_angle.tan() * h * h
    }
    /// Contact radius at depth `h` (m).
    pub fn contact_radius(&self, h: f64) -> f64 {
        2.0 / PI * h * self.half_angle.tan()
    }
    /// Contact depth at depth `h`: the height of the contact edge above the
    /// tip, `a / tan ψ = (2/π) h` (m).
    pub fn contact_depth(&self, h: f64) -> f64 {
        2.0 / PI * h
    }
    /// Pressure at radius `r` under the indenter at depth `h` (Pa; zero
    /// outside the contact; logarithmically infinite at the tip).
    pub fn pressure(&self, h: f64, r: f64) -> f64 {
        let a = self.contact_radius(h);
        if r >= a {
            0.0
        } else {
            self.e_star / (2.0 * self.half_angle.tan()) * (a / r).acosh()
        }
    }
    /// Downward displacement of the surface at radius `r` (m).
    pub fn surface_deflection(&self, h: f64, r: f64) -> f64 {
        let a = self.contact_radius(h);
        let t = self.half_angle.tan();
        if r <= a {
            h - r / t
        } else {
            ((r * r - a * a).sqrt() - r + a * (a / r).asin()) / t
        }
    }
}

/// A rigid sphere of radius `R` on an elastic half-space in the paraboloid
/// (Hertz) approximation, valid for `a ≪ R`:
///
/// ```text
/// a = √(R h)      P = (4/3) E* √R h^{3/2}      p0 = 3P/(2πa²) = 2 E* a/(π R)
/// p(r) = p0 √(1 − r²/a²)
/// u_z(r) = h − r²/(2R)   (r ≤ a)
/// u_z(r) = (p0/(2 a E*)) [(2a² − r²) arcsin(a/r) + a √(r² − a²)]   (r ≥ a)
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hertz {
    /// Contact modulus `E*` (Pa).
    pub e_star: f64,
    /// Sphere radius `R` (m).
    pub radius: f64,
}

impl Hertz {
    /// Contact radius at depth `h` (m).
    pub fn contact_radius(&self, h: f64) -> f64 {
        (self.radius * h).sqrt()
    }
    /// Load at depth `h` (N).
    pub fn load(&self, h: f64) -> f64 {
        4.0 / 3.0 * self.e_star * self.radius.sqrt() * h.powf(1.5)
    }
    /// Depth at load `p` (N), the inverse of [`Hertz::load`].
    pub fn depth_at_load(&self, p: f64) -> f64 {
        (3.0 * p / (4.0 * self.e_star * self.radius.sqrt())).powf(2.0 / 3.0)
    }
    /// Peak pressure at depth `h` (Pa).
    pub fn peak_pressure(&self, h: f64) -> f64 {
        2.0 * self.e_star * self.contact_radius(h) / (PI * self.radius)
    }
    /// Pressure at radius `r` (Pa; zero outside the contact).
    pub fn pressure(&self, h: f64, r: f64) -> f64 {
        let a = self.contact_radius(h);
        if r >= a {
            0.0
        } else {
            self.peak_pressure(h) * (1.0 - (r / a) * (r / a)).sqrt()
        }
    }
    /// Downward displacement of the surface at radius `r` (m).
    pub fn surface_deflection(&self, h: f64, r: f64) -> f64 {
        let a = self.contact_radius(h);
        if r <= a {
            h - r * r / (2.0 * self.radius)
        } else {
            let p0 = self.peak_pressure(h);
            p0 / (2.0 * a * self.e_star)
                * ((2.0 * a * a - r * r) * (a / r).asin() + a * (r * r - a * a).sqrt())
        }
    }
}

/// A rigid sphere of radius `R` on an elastic half-space, without the
/// paraboloid approximation (Sneddon 1965), as functions of the contact
/// radius `a < R`:
///
/// ```text
/// h(a) = (a/2) ln((R + a)/(R − a))
/// P(a) = (E*/2) [(a² + R²) ln((R + a)/(R − a)) − 2 a R]
/// ```
///
/// Both tend to Hertz's as `a/R → 0`: `h = (a²/R)(1 + a²/(3R²) + …)`,
/// `P = (4/3)(E* a³/R)(1 + (2/5) a²/R² + …)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExactSphere {
    /// Contact modulus `E*` (Pa).
    pub e_star: f64,
    /// Sphere radius `R` (m).
    pub radius: f64,
}

impl ExactSphere {
    /// Depth at contact radius `a` (m).
    pub fn depth(&self, a: f64) -> f64 {
        let r = self.radius;
        0.5 * a * ((r + a) / (r - a)).ln()
    }
    /// Load at contact radius `a` (N).
    pub fn load(&self, a: f64) -> f64 {
        let r = self.radius;
        0.5 * self.e_star * ((a * a + r * r) * ((r + a) / (r - a)).ln() - 2.0 * a * r)
    }
}

/// A rigid flat-ended cylindrical punch of radius `a` on an elastic
/// half-space (Boussinesq; Johnson §3.8):
///
/// ```text
/// P = 2 a E* h        p(r) = P / (2π a √(a² − r²))
/// u_z(r) = h (r ≤ a),   (2h/π) arcsin(a/r) (r ≥ a)
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlatPunch {
    /// Contact modulus `E*` (Pa).
    pub e_star: f64,
    /// Punch radius `a` (m).
    pub radius: f64,
}

impl FlatPunch {
    /// Load at depth `h` (N).
    pub fn load(&self, h: f64) -> f64 {
        2.0 * self.radius * self.e_star * h
    }
    /// Pressure at radius `r` (Pa; zero outside, infinite at the edge).
    pub fn pressure(&self, h: f64, r: f64) -> f64 {
        let a = self.radius;
        if r >= a {
            0.0
        } else {
            self.load(h) / (2.0 * PI * a * (a * a - r * r).sqrt())
        }
    }
    /// Downward displacement of the surface at radius `r` (m).
    pub fn surface_deflection(&self, h: f64, r: f64) -> f64 {
        if r <= self.radius {
            h
        } else {
            2.0 * h / PI * (self.radius / r).asin()
        }
    }
}

#[cfg(test)]
mod tests;
