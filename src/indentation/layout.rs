//! A proposed level layout for an indentation: from the indenter, the final
//! depth and a target number of finest particles across the expected
//! contact half-width, the number of levels and one box per refined level
//! (`gimlet_propose_levels`). Pure: no handle, no communication.
//!
//! # The expected contact half-width `a`
//!
//! * **Elastic** response, plane strain, a rigid indenter on a body whose
//!   depth `d` below the surface is held at its bottom (the depth is the
//!   tip's approach measured from the undeformed surface, so the body's
//!   depth is the length that the plane-strain displacement's logarithm
//!   needs). With the displacement of a half-space under the contact
//!   pressure taken relative to the point at distance `r0 = d`:
//!   - wedge of half-angle `ψ` (flank slope `tan β = cot ψ`):
//!     `h = (2 tan β / π) (a arccosh(r0/a) + r0 arcsin(a/r0))`;
//!   - cylinder of radius `R` (Hertz, `P = π a² E* / (4R)`):
//!     `h = (a² / (2R)) (ln(2 r0/a) + 1/2)`;
//!   - flat punch: `a` is its half-width.
//!
//!   Both depth relations grow with `a`; they are inverted by bisection.
//!   On the main job (65° wedge, 450 nm, a 40 µm deep block) this gives
//!   222 nm where the converged simulation gives 231–239 nm.
//! * **Elastic** response, axisymmetric (the indenters of the
//!   axisymmetric mode, on the axis `r = 0`; the surface displacement of a
//!   half-space is finite, so the body's depth does not enter):
//!   - cone of half-angle `α` (Sneddon): `a = 2 h tan α / π`;
//!   - sphere of radius `R` (Hertz): `a = √(R h)` (for `h < R`);
//!   - flat cylindrical punch: `a` is its radius.
//!
//!   The closed-form test of the axisymmetric mode (`axisym_closed_forms`,
//!   `docs/validation.md`) measures the contact radius within 3.6 % of
//!   Sneddon's (cone) and 0.8 % of Hertz's (sphere).
//! * **Plastic** response: the indenter's intersection with the undeformed
//!   surface (`h tan ψ` for a wedge or a cone, `√(h (2R − h))` for a
//!   cylinder or a sphere, the punch's half-width or radius). Pile-up
//!   makes the true contact larger (the J2 wedge of `docs/validation.md`:
//!   1.15 times), elastic sink-in smaller.
//!
//! # The layout
//!
//! The finest cell is the largest `h0 / 2^k` with at most `a / across`
//! per particle (`n` particles per cell and axis: the particle is `h / n`
//! wide). The finest box reaches `W = max(box_factor · a, 32 h_finest)`
//! from the axis along the surface and below it, and up to the domain's
//! top; each coarser refined level's box reaches twice as far as the next
//! finer one's, so every level is about as many cells wide. Boxes are
//! rounded outwards to the cells of the coarser level and clipped to the
//! domain; the doubling leaves at least 16 coarse cells between a box and
//! its coarser level's box, so they nest with any nesting buffer up to 15
//! (the default is 4). The proposal is checked with the same rules as
//! `gimlet_add_level` before it is returned. For an axisymmetric indenter
//! the domain starts at the axis (`x0 = 0`) and so does the indenter
//! (`axis_x = 0`): the boxes then run from the axis outwards.

use crate::error::{Error, Result};
use crate::geom::{Hierarchy, MAX_LEVELS};

/// The indenter a layout is proposed for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Indenter {
    /// A wedge of the given tip half-angle (degrees, in (0, 90)).
    Wedge {
        /// Tip half-angle `ψ` (degrees).
        half_angle_deg: f64,
    },
    /// A cylinder (a circle in the plane) of the given radius (m).
    Cylinder {
        /// Radius `R` (m).
        radius: f64,
    },
    /// A flat punch of the given half-width (m).
    FlatPunch {
        /// Half-width (m).
        half_width: f64,
    },
    /// A cone of the given half-angle (degrees, in (0, 90)), axisymmetric
    /// (70.3° has the area function of a Berkovich or Vickers tip).
    Cone {
        /// Half-angle `α` (degrees).
        half_angle_deg: f64,
    },
    /// A sphere of the given radius (m), axisymmetric.
    Sphere {
        /// Radius `R` (m).
        radius: f64,
    },
    /// A flat cylindrical punch of the given radius (m), axisymmetric.
    CylindricalPunch {
        /// Radius (m).
        radius: f64,
    },
}

impl Indenter {
    /// True for the indenters of the axisymmetric mode (on the axis).
    pub fn is_axisymmetric(self) -> bool {
        matches!(
            self,
            Indenter::Cone { .. } | Indenter::Sphere { .. } | Indenter::CylindricalPunch { .. }
        )
    }
}

/// `tan` of a half-angle in degrees, checked to lie in (0, 90).
fn tan_half_angle(what: &str, deg: f64) -> Result<f64> {
    if !(deg > 0.0 && deg < 90.0) {
        return Err(Error::arg(format!(
            "size = {deg}: a {what}'s half-angle must lie in (0, 90) degrees"
        )));
    }
    Ok(deg.to_radians().tan())
}

/// The intersection of a circle of radius `radius` with the surface at
/// depth `depth` (the whole radius from `depth >= radius` on).
fn circle_chord_half(radius: f64, depth: f64) -> f64 {
    if depth < radius {
        (depth * (2.0 * radius - depth)).sqrt()
    } else {
        radius
    }
}

/// How the body is expected to respond (see the module notes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Response {
    /// Elastic: the half-space closed forms (sink-in).
    Elastic,
    /// Plastic: the intersection with the undeformed surface.
    Plastic,
}

/// What a layout is asked for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Request {
    /// The domain `[x0, y0, lx, ly]` of `gimlet_create`.
    pub domain: [f64; 4],
    /// The coarse cell size of `gimlet_create`.
    pub h0: f64,
    /// The indenter's axis, `x` (inside the domain).
    pub axis_x: f64,
    /// The undeformed top surface, `y` (above `y0`, at most the domain's top).
    pub surface_y: f64,
    /// The indenter.
    pub indenter: Indenter,
    /// The final depth (m, > 0).
    pub depth: f64,
    /// The expected response.
    pub response: Response,
    /// Particles per cell along each axis (1 to 8, as `gimlet_fill_rectangle`).
    pub particles_per_cell: u32,
    /// Target number of finest particles across the contact half-width (> 0).
    pub particles_across: f64,
    /// The finest box's reach from the axis in contact half-widths (>= 1).
    pub box_factor: f64,
    /// The most levels the layout may have (1 to [`MAX_LEVELS`]).
    pub max_levels: usize,
}

/// A proposed layout.
#[derive(Clone, Debug, PartialEq)]
pub struct Proposal {
    /// The expected contact half-width `a` at the final depth (m).
    pub contact_half_width: f64,
    /// The number of levels (level 0 included).
    pub levels: usize,
    /// One box `[xlo, ylo, xhi, yhi]` per refined level, level 1 first
    /// (`levels − 1` of them), for `gimlet_add_level`.
    pub boxes: Vec<[f64; 4]>,
    /// The finest level's cell size (m).
    pub finest_cell: f64,
    /// The finest particles across `a`: `a / (finest_cell / n)`.
    pub particles_across: f64,
}

/// Solves `f(a) = target` for `a` in `(0, hi)` by bisection, `f` growing.
fn invert(f: impl Fn(f64) -> f64, target: f64, hi: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, hi);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if f(mid) < target {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-14 * hi {
            break;
        }
    }
    0.5 * (lo + hi)
}

fn positive(name: &str, v: f64) -> Result<()> {
    if !(v.is_finite() && v > 0.0) {
        return Err(Error::arg(format!("{name} = {v} must be finite and > 0")));
    }
    Ok(())
}

/// The expected contact half-width at `depth` for a body `body_depth` deep
/// (see the module notes).
pub fn expected_contact_half_width(
    indenter: Indenter,
    depth: f64,
    response: Response,
    body_depth: f64,
) -> Result<f64> {
    positive("depth", depth)?;
    positive("body depth (surface_y - y0)", body_depth)?;
    match indenter {
        Indenter::Wedge { half_angle_deg } => {
            let tan_psi = tan_half_angle("wedge", half_angle_deg)?;
            match response {
                Response::Plastic => Ok(depth * tan_psi),
                Response::Elastic => {
                    let r0 = body_depth;
                    let k = 2.0 / (std::f64::consts::PI * tan_psi);
                    let h = |a: f64| k * (a * (r0 / a).acosh() + r0 * (a / r0).asin());
                    // h(r0) = r0 tan β: a deeper push has no half-space answer.
                    if depth >= 0.5 * h(r0) {
                        return Err(Error::arg(format!(
                            "depth = {depth} is too deep for an elastic estimate in a body {r0} deep: it must be below {} (half the depth at which the contact would span the body)",
                            0.5 * h(r0)
                        )));
                    }
                    Ok(invert(h, depth, r0))
                }
            }
        }
        Indenter::Cylinder { radius } => {
            positive("size (the cylinder's radius)", radius)?;
            match response {
                Response::Plastic => Ok(circle_chord_half(radius, depth)),
                Response::Elastic => {
                    let r0 = body_depth;
                    let top = radius.min(r0);
                    let h = |a: f64| a * a / (2.0 * radius) * ((2.0 * r0 / a).ln() + 0.5);
                    if depth >= h(top) {
                        return Err(Error::arg(format!(
                            "depth = {depth} is too deep for Hertz's estimate with radius {radius} in a body {r0} deep: it must be below {} (the contact would reach min(R, body depth))",
                            h(top)
                        )));
                    }
                    Ok(invert(h, depth, top))
                }
            }
        }
        Indenter::FlatPunch { half_width } => {
            positive("size (the punch's half-width)", half_width)?;
            Ok(half_width)
        }
        Indenter::Cone { half_angle_deg } => {
            let tan_a = tan_half_angle("cone", half_angle_deg)?;
            Ok(match response {
                Response::Plastic => depth * tan_a,
                // Sneddon: h = (π/2) a cot α.
                Response::Elastic => 2.0 * depth * tan_a / std::f64::consts::PI,
            })
        }
        Indenter::Sphere { radius } => {
            positive("size (the sphere's radius)", radius)?;
            match response {
                Response::Plastic => Ok(circle_chord_half(radius, depth)),
                Response::Elastic => {
                    // Hertz: h = a² / R, for a contact smaller than the sphere.
                    if depth >= radius {
                        return Err(Error::arg(format!(
                            "depth = {depth} is too deep for Hertz's estimate with radius {radius}: it must be below the radius (a = sqrt(R h) < R)"
                        )));
                    }
                    Ok((radius * depth).sqrt())
                }
            }
        }
        Indenter::CylindricalPunch { radius } => {
            positive("size (the punch's radius)", radius)?;
            Ok(radius)
        }
    }
}

/// Proposes the levels and boxes for `req` (see the module notes).
pub fn propose(req: &Request) -> Result<Proposal> {
    let [x0, y0, lx, ly] = req.domain;
    // The same checks as gimlet_create's (and a hierarchy to check against).
    let mut hier = Hierarchy::new(x0, y0, lx, ly, req.h0)?;
    let up = hier.upper();
    if !(req.axis_x >= x0 && req.axis_x <= up[0]) {
        return Err(Error::arg(format!(
            "axis_x = {} must lie in the domain's [{x0}, {}]",
            req.axis_x, up[0]
        )));
    }
    if !(req.surface_y > y0 && req.surface_y <= up[1]) {
        return Err(Error::arg(format!(
            "surface_y = {} must lie in the domain's ({y0}, {}]",
            req.surface_y, up[1]
        )));
    }
    if req.indenter.is_axisymmetric() && !(x0 == 0.0 && req.axis_x == 0.0) {
        return Err(Error::arg(format!(
            "an axisymmetric indenter sits on the axis: the domain must start at x0 = 0 (it starts at {x0}) and axis_x must be 0 (it is {})",
            req.axis_x
        )));
    }
    let n = req.particles_per_cell;
    if !(1..=8).contains(&n) {
        return Err(Error::arg(format!(
            "particles_per_cell = {n} must be between 1 and 8"
        )));
    }
    if !(req.particles_across.is_finite()
        && req.particles_across > 0.0
        && req.particles_across <= 1e6)
    {
        return Err(Error::arg(format!(
            "particles_across = {} must be finite, > 0 and at most 1e6",
            req.particles_across
        )));
    }
    if !(req.box_factor.is_finite() && req.box_factor >= 1.0 && req.box_factor <= 1e6) {
        return Err(Error::arg(format!(
            "box_factor = {} must be between 1 (the finest box covers the contact) and 1e6",
            req.box_factor
        )));
    }
    if !(1..=MAX_LEVELS).contains(&req.max_levels) {
        return Err(Error::arg(format!(
            "max_levels = {} must be between 1 and {MAX_LEVELS}",
            req.max_levels
        )));
    }
    let a = expected_contact_half_width(req.indenter, req.depth, req.response, req.surface_y - y0)?;
    let nf = f64::from(n);
    let h_max = nf * a / req.particles_across;
    let mut levels = 1;
    let mut hf = req.h0;
    while hf > h_max * (1.0 + 1e-12) {
        hf *= 0.5;
        levels += 1;
        if levels > req.max_levels {
            return Err(Error::arg(format!(
                "particles_across = {} needs cells of at most {h_max:e} (a = {a:e}, {n} particles per cell and axis), more than max_levels = {} levels below h0 = {} reach (the finest would give {:.2} particles across a)",
                req.particles_across,
                req.max_levels,
                req.h0,
                nf * a / (2.0 * hf)
            )));
        }
    }
    let reach_f = (req.box_factor * a).max(32.0 * hf);
    let mut boxes = Vec::with_capacity(levels - 1);
    for l in 1..levels {
        let reach = reach_f * (1u64 << (levels - 1 - l)) as f64;
        let hc = req.h0 / (1u64 << (l - 1)) as f64;
        let down = |v: f64, o: f64| o + ((v - o) / hc).floor() * hc;
        let upr = |v: f64, o: f64| o + ((v - o) / hc).ceil() * hc;
        let b = [
            down((req.axis_x - reach).max(x0), x0),
            down((req.surface_y - reach).max(y0), y0),
            upr((req.axis_x + reach).min(up[0]), x0).min(up[0]),
            up[1],
        ];
        hier.add_level(&[b]).map_err(|e| {
            Error::arg(format!(
                "the proposed box of level {l} does not fit the domain: {}",
                e.msg
            ))
        })?;
        boxes.push(b);
    }
    Ok(Proposal {
        contact_half_width: a,
        levels,
        boxes,
        finest_cell: hf,
        particles_across: nf * a / hf,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// The main job's set-up: a 31 × 41 µm domain, surface at 40 µm, axis
    /// at x = 0, 500 nm coarse cells, 2 particles per cell and axis.
    fn main_job(across: f64) -> Request {
        Request {
            domain: [0.0, 0.0, 31e-6, 41e-6],
            h0: 5e-7,
            axis_x: 0.0,
            surface_y: 40e-6,
            indenter: Indenter::Wedge {
                half_angle_deg: 65.0,
            },
            depth: 4.5e-7,
            response: Response::Elastic,
            particles_per_cell: 2,
            particles_across: across,
            box_factor: 20.0,
            max_levels: 8,
        }
    }

    #[test]
    fn elastic_wedge_half_width_satisfies_its_depth_relation_and_the_load_balance() {
        let (psi, h, r0) = (65.0f64, 4.5e-7, 40e-6);
        let a = expected_contact_half_width(
            Indenter::Wedge {
                half_angle_deg: psi,
            },
            h,
            Response::Elastic,
            r0,
        )
        .unwrap();
        let tb = 1.0 / psi.to_radians().tan();
        let back = 2.0 * tb / PI * (a * (r0 / a).acosh() + r0 * (a / r0).asin());
        assert!((back / h - 1.0).abs() < 1e-10, "{back} against {h}");
        // The main job's converged simulation: P = 8525.9 N/m, and the
        // half-space's P = E* a cot ψ gives a = 233 nm; the depth relation
        // (the body's depth as r0) must agree within 10 %.
        let e_star = 70e9 / (1.0 - 0.33 * 0.33);
        let a_sim = 8525.9 / (e_star * tb);
        assert!(
            (a / a_sim - 1.0).abs() < 0.1,
            "a = {a:e}, from the load {a_sim:e}"
        );
    }

    #[test]
    fn elastic_cylinder_half_width_inverts_hertz_with_the_log_depth() {
        let (rr, r0) = (10e-6, 40e-6);
        for h in [1e-8, 5e-8, 2e-7] {
            let a = expected_contact_half_width(
                Indenter::Cylinder { radius: rr },
                h,
                Response::Elastic,
                r0,
            )
            .unwrap();
            let back = a * a / (2.0 * rr) * ((2.0 * r0 / a).ln() + 0.5);
            assert!((back / h - 1.0).abs() < 1e-10);
            // Smaller than the geometric chord √(2Rh): sink-in.
            assert!(a < (2.0 * rr * h).sqrt());
        }
    }

    /// The log term of the cylinder's depth: the surface displacement of a
    /// half-space under the Hertz pressure `p0 √(1 − s²/a²)`, relative to
    /// the point at `r0`, is `(2/(πE*)) ∫ p(s) (ln|r0 − s| − ln|s|) ds`;
    /// by quadrature it must equal `(2P/(πE*)) (ln(2 r0/a) + 1/2)` to
    /// `O((a/r0)²)`.
    #[test]
    fn cylinder_depth_relation_matches_quadrature_of_the_line_load_kernel() {
        let (a, r0) = (1.0, 200.0);
        let n = 400_000;
        let mut s = 0.0;
        for i in 0..n {
            // t = sin θ spreads the points towards the edges.
            let th = -0.5 * PI + PI * (i as f64 + 0.5) / n as f64;
            let x = a * th.sin();
            let p = th.cos(); // p0 = 1
            let dx = a * th.cos() * PI / n as f64;
            s += p * ((r0 - x).abs().ln() - x.abs().ln()) * dx;
        }
        let load = PI * a / 2.0;
        let closed = load * ((2.0 * r0 / a).ln() + 0.5);
        assert!((s / closed - 1.0).abs() < 1e-4, "{s} against {closed}");
    }

    #[test]
    fn plastic_half_width_is_the_intersection_with_the_surface() {
        let a = expected_contact_half_width(
            Indenter::Wedge {
                half_angle_deg: 45.0,
            },
            1e-7,
            Response::Plastic,
            1e-5,
        )
        .unwrap();
        assert!((a / 1e-7 - 1.0).abs() < 1e-12);
        let c = expected_contact_half_width(
            Indenter::Cylinder { radius: 1e-5 },
            1e-7,
            Response::Plastic,
            1e-5,
        )
        .unwrap();
        assert!((c / (1e-7f64 * (2e-5 - 1e-7)).sqrt() - 1.0).abs() < 1e-12);
        let p = expected_contact_half_width(
            Indenter::FlatPunch { half_width: 2e-6 },
            1e-7,
            Response::Elastic,
            1e-5,
        )
        .unwrap();
        assert_eq!(p, 2e-6);
    }

    /// `dP/dh` by central differences of the load that the half-space
    /// pressure of contact radius `a(h)` carries (`load(a)`, by
    /// quadrature), against `2 E* a`: the stiffness of every axisymmetric
    /// contact (Sneddon), which only the consistent radius–depth relation
    /// gives. `E* = 1`.
    fn stiffness_check(a_of_h: impl Fn(f64) -> f64, load: impl Fn(f64) -> f64, h: f64) {
        let dh = 1e-4 * h;
        let s = (load(a_of_h(h + dh)) - load(a_of_h(h - dh))) / (2.0 * dh);
        let a = a_of_h(h);
        assert!(
            (s / (2.0 * a) - 1.0).abs() < 1e-5,
            "S {s} against 2 a = {}",
            2.0 * a
        );
    }

    /// `∫_0^a 2π r p(r) dr` by the midpoint rule in `r = a (1 − u²)` (the
    /// pressures' singularities are at `r = a` or integrable at 0).
    fn ring_integral(a: f64, p: impl Fn(f64) -> f64) -> f64 {
        let n = 200_000;
        (0..n)
            .map(|k| {
                let u = (k as f64 + 0.5) / n as f64;
                let r = a * (1.0 - u * u);
                2.0 * std::f64::consts::PI * r * p(r) * 2.0 * a * u / n as f64
            })
            .sum()
    }

    #[test]
    fn axisymmetric_radii_are_sneddons_cone_and_hertzs_sphere() {
        let pi = std::f64::consts::PI;
        // A 70.3° cone: the pressure (cot α / 2) arccosh(a/r).
        let cone = Indenter::Cone {
            half_angle_deg: 70.3,
        };
        let cot = 1.0 / 70.3f64.to_radians().tan();
        let a_cone = |h: f64| expected_contact_half_width(cone, h, Response::Elastic, 1.0).unwrap();
        let p_cone = |a: f64| ring_integral(a, |r: f64| 0.5 * cot * (a / r).acosh());
        stiffness_check(a_cone, p_cone, 1e-7);
        // And the load itself, (π/2) a² cot α.
        let a = a_cone(1e-7);
        assert!((p_cone(a) / (0.5 * pi * a * a * cot) - 1.0).abs() < 1e-5);
        // A sphere: the pressure (2 / (π R)) sqrt(a² − r²).
        let rr = 1e-5;
        let sphere = Indenter::Sphere { radius: rr };
        let a_sph =
            |h: f64| expected_contact_half_width(sphere, h, Response::Elastic, 1.0).unwrap();
        let p_sph = |a: f64| {
            ring_integral(a, |r: f64| {
                2.0 / (pi * rr) * (a * a - r * r).max(0.0).sqrt()
            })
        };
        stiffness_check(a_sph, p_sph, 1e-7);
        // Plastic: the intersections; the punch: its radius either way.
        let plastic = |i| expected_contact_half_width(i, 1e-7, Response::Plastic, 1.0).unwrap();
        assert!((plastic(cone) / (1e-7 * 70.3f64.to_radians().tan()) - 1.0).abs() < 1e-12);
        assert!((plastic(sphere) / (1e-7f64 * (2e-5 - 1e-7)).sqrt() - 1.0).abs() < 1e-12);
        let punch = Indenter::CylindricalPunch { radius: 2e-6 };
        assert_eq!(plastic(punch), 2e-6);
        // Bad sizes and depths name the bound.
        let err = |i, h| {
            expected_contact_half_width(i, h, Response::Elastic, 1.0)
                .unwrap_err()
                .msg
        };
        assert!(err(
            Indenter::Cone {
                half_angle_deg: 90.0
            },
            1e-7
        )
        .contains("cone's half-angle"));
        assert!(err(sphere, 2e-5).contains("below the radius"));
        assert!(err(Indenter::Sphere { radius: -1.0 }, 1e-7).contains("sphere's radius"));
    }

    #[test]
    fn axisymmetric_layout_runs_from_the_axis() {
        // The cone example's body: 300 nm deep into a block of 40 coarse
        // cells, the indenter on the axis.
        let (h0, big) = (5e-7, 2e-5);
        let mut r = Request {
            domain: [0.0, 0.0, big + 2.0 * h0, big + 2.0 * h0],
            h0,
            axis_x: 0.0,
            surface_y: big,
            indenter: Indenter::Cone {
                half_angle_deg: 70.3,
            },
            depth: 3e-7,
            response: Response::Elastic,
            particles_per_cell: 2,
            particles_across: 4.0,
            box_factor: 20.0,
            max_levels: 8,
        };
        let p = propose(&r).unwrap();
        let a = 2.0 * 3e-7 * 70.3f64.to_radians().tan() / std::f64::consts::PI;
        assert!((p.contact_half_width / a - 1.0).abs() < 1e-15);
        assert!(p.particles_across >= 4.0 && p.particles_across / 2.0 < 4.0);
        for b in &p.boxes {
            assert_eq!(b[0], 0.0);
        }
        let f = p.boxes.last().unwrap();
        assert!(f[2] >= 20.0 * a && big - f[1] >= 20.0 * a);
        // Off the axis: refused, naming both.
        r.axis_x = 1e-6;
        let m = propose(&r).unwrap_err().msg;
        assert!(
            m.contains("x0 = 0") && m.contains("axis_x must be 0"),
            "{m}"
        );
        r.axis_x = 0.0;
        r.domain[0] = -1e-6;
        assert!(propose(&r).unwrap_err().msg.contains("starts at -0.000001"));
    }

    #[test]
    fn main_job_layout_reaches_the_target_and_nests() {
        for (across, levels) in [(3.5, 3), (7.0, 4), (14.0, 5), (1.0, 2)] {
            let p = propose(&main_job(across)).unwrap();
            assert_eq!(p.levels, levels, "across {across}");
            assert_eq!(p.boxes.len(), levels - 1);
            assert!(p.particles_across >= across, "{p:?}");
            // One level fewer would not reach the target.
            assert!(p.particles_across / 2.0 < across);
            // Boxes: on the axis, up to the domain's top, each inside the
            // coarser one, the finest reaching box_factor a.
            for w in p.boxes.windows(2) {
                assert!(w[1][2] < w[0][2] && w[1][1] > w[0][1]);
            }
            if let Some(f) = p.boxes.last() {
                assert_eq!(f[0], 0.0);
                assert_eq!(f[3], 41e-6);
                assert!(f[2] >= 20.0 * p.contact_half_width);
                assert!(40e-6 - f[1] >= 20.0 * p.contact_half_width);
            }
            // The hierarchy accepts them in order (checked inside propose,
            // and again here with the largest buffer the doubling allows).
            let mut h = Hierarchy::new(0.0, 0.0, 31e-6, 41e-6, 5e-7).unwrap();
            h.set_nest_buffer(15).unwrap();
            for b in &p.boxes {
                h.add_level(&[*b]).unwrap();
            }
        }
    }

    #[test]
    fn bad_requests_name_the_argument_and_the_bound() {
        let msg = |r: Request| propose(&r).unwrap_err().msg;
        let mut r = main_job(3.5);
        r.max_levels = 2;
        assert!(msg(r).contains("max_levels = 2"));
        let mut r = main_job(3.5);
        r.particles_across = 0.0;
        assert!(msg(r).contains("particles_across = 0"));
        let mut r = main_job(3.5);
        r.particles_per_cell = 9;
        assert!(msg(r).contains("particles_per_cell = 9"));
        let mut r = main_job(3.5);
        r.box_factor = 0.5;
        assert!(msg(r).contains("box_factor = 0.5"));
        let mut r = main_job(3.5);
        r.axis_x = -1e-6;
        assert!(msg(r).contains("axis_x"));
        let mut r = main_job(3.5);
        r.surface_y = 0.0;
        assert!(msg(r).contains("surface_y"));
        let mut r = main_job(3.5);
        r.indenter = Indenter::Wedge {
            half_angle_deg: 90.0,
        };
        assert!(msg(r).contains("half-angle"));
        let mut r = main_job(3.5);
        r.depth = f64::NAN;
        assert!(msg(r).contains("depth = NaN"));
        let mut r = main_job(3.5);
        r.depth = 30e-6;
        assert!(msg(r).contains("too deep"));
    }
}
