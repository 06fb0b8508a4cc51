//! The contact set-up in a checkpoint (format version 4): the indenters, each
//! with its shape, placement and prescribed motion, and the contact options
//! a host sets through `gimlet_set_contact_option`. An indenter's position
//! is a function of time (its motion is prescribed), so with the clock of
//! the checkpoint a restart puts every indenter where the uninterrupted run
//! has it.
//!
//! | path | content |
//! |---|---|
//! | `/contact` | attributes `count` (indenters), `options` (`regularization`, `band_cells`, `gap_mode`, `ksp_rtol`, `dense_max`, `friction_tol`, `friction_max_iter`; files written before friction have the first 5) |
//! | `/contact/indenter_<k>` | attributes `shape` (0 wedge, 1 cylinder, 2 flat punch, 3 polygon), `params` (wedge: half-angle in radians, height; cylinder: radius; punch: half-width, corner radius, height; polygon: the vertices `x0, y0, x1, y1, …`), `tip0` (placement), `motion` (0 at rest, 1 velocity, 2 depth) and, when moving, `times` and `values`; `friction` (the Coulomb coefficient, `inf` for stick; absent in files written before friction: 0) and, with a sideways motion, `lateral_times` and `lateral_x` |
//!
//! Not stored: what a step recomputes (the contact found by the last step,
//! the force it reported, the linear solver and its last iterate). The
//! force `gimlet_indenter_state` reports is zero until the first step after
//! a restart, and a PETSc solve starts from zero instead of the last
//! iterate (the result agrees to the KSP tolerance; the direct solve, the
//! default for small systems, is bitwise the same).

use super::h5::{Attributes, File};
use crate::contact::{Motion, Shape};
use crate::error::{Error, Result, Status};
use crate::fnv::fnv1a;
use crate::sim::Simulation;
use std::path::Path;

/// One indenter as stored.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct StoredIndenter {
    shape: Shape,
    tip0: [f64; 2],
    motion: Motion,
    friction: f64,
    lateral: (Vec<f64>, Vec<f64>),
}

/// The contact set-up as stored.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct ContactSetup {
    indenters: Vec<StoredIndenter>,
    /// `regularization`, `band_cells`, `gap_mode`, `ksp_rtol`, `dense_max`,
    /// `friction_tol`, `friction_max_iter` (the last two absent in files
    /// written before friction).
    options: Vec<f64>,
}

/// The contact set-up of `sim`.
pub(super) fn setup_of(sim: &Simulation) -> ContactSetup {
    let c = &sim.contact;
    ContactSetup {
        indenters: c
            .indenters
            .iter()
            .map(|i| StoredIndenter {
                shape: i.shape().clone(),
                tip0: i.placement(),
                motion: i.motion().clone(),
                friction: i.friction(),
                lateral: (i.lateral().0.to_vec(), i.lateral().1.to_vec()),
            })
            .collect(),
        options: vec![
            c.options.regularization,
            c.options.band_cells,
            f64::from(c.options.gap_mode),
            c.lcp.rtol,
            c.lcp.dense_max as f64,
            c.options.friction_tol,
            f64::from(c.options.friction_max_iter),
        ],
    }
}

fn shape_params(s: &Shape) -> (i32, Vec<f64>) {
    match s {
        Shape::Wedge { half_angle, height } => (0, vec![*half_angle, *height]),
        Shape::Cylinder { radius } => (1, vec![*radius]),
        Shape::FlatPunch {
            half_width,
            corner_radius,
            height,
        } => (2, vec![*half_width, *corner_radius, *height]),
        Shape::Polygon { vertices } => (3, vertices.iter().flatten().copied().collect()),
    }
}

fn motion_params(m: &Motion) -> (i32, &[f64], &[f64]) {
    match m {
        Motion::Rest => (0, &[], &[]),
        Motion::Velocity { times, speed } => (1, times, speed),
        Motion::Depth { times, depth } => (2, times, depth),
    }
}

/// Folds the set-up into the settings digest `h`.
pub(super) fn digest(mut h: u64, s: &ContactSetup) -> u64 {
    let mut f = |b: &[u8]| h = fnv1a(h, b);
    let r = |v: f64| v.to_bits().to_le_bytes();
    f(&(s.indenters.len() as u64).to_le_bytes());
    for i in &s.indenters {
        let (code, p) = shape_params(&i.shape);
        f(&code.to_le_bytes());
        f(&(p.len() as u64).to_le_bytes());
        for v in p.iter().chain(&i.tip0) {
            f(&r(*v));
        }
        let (code, t, v) = motion_params(&i.motion);
        f(&code.to_le_bytes());
        f(&(t.len() as u64).to_le_bytes());
        for x in t.iter().chain(v) {
            f(&r(*x));
        }
        // Folded only when set, so that files written before friction keep
        // their digest.
        if i.friction != 0.0 {
            f(b"friction");
            f(&r(i.friction));
        }
        if !i.lateral.0.is_empty() {
            f(b"lateral");
            f(&(i.lateral.0.len() as u64).to_le_bytes());
            for x in i.lateral.0.iter().chain(&i.lateral.1) {
                f(&r(*x));
            }
        }
    }
    for v in &s.options {
        f(&r(*v));
    }
    h
}

/// Writes the set-up (the `/contact` group).
pub(super) fn write(f: &File, s: &ContactSetup) -> Result<()> {
    let g = f.create_group("/contact")?;
    g.set_attr("count", s.indenters.len() as i64)?;
    g.set_attr_array("options", &s.options)?;
    for (k, i) in s.indenters.iter().enumerate() {
        let gi = g.create_group(&format!("indenter_{k}"))?;
        let (code, p) = shape_params(&i.shape);
        gi.set_attr("shape", code)?;
        gi.set_attr_array("params", &p)?;
        gi.set_attr_array("tip0", &i.tip0)?;
        let (code, t, v) = motion_params(&i.motion);
        gi.set_attr("motion", code)?;
        if code != 0 {
            gi.set_attr_array("times", t)?;
            gi.set_attr_array("values", v)?;
        }
        gi.set_attr_array("friction", &[i.friction])?;
        if !i.lateral.0.is_empty() {
            gi.set_attr_array("lateral_times", &i.lateral.0)?;
            gi.set_attr_array("lateral_x", &i.lateral.1)?;
        }
    }
    Ok(())
}

fn bad(path: &Path, what: String) -> Error {
    Error::new(
        Status::Io,
        format!("checkpoint '{}' {what}", path.display()),
    )
}

/// Reads the set-up back (the values are checked when
/// [`apply`] adds them).
pub(super) fn read(f: &File, path: &Path) -> Result<ContactSetup> {
    let g = f.group("/contact")?;
    let n = g.attr::<i64>("count")?;
    if !(0..=crate::contact::MAX_INDENTERS as i64).contains(&n) {
        return Err(bad(path, format!("declares {n} indenters")));
    }
    let options = g.attr_array::<f64>("options")?;
    if !(options.len() == 5 || options.len() == 7) {
        return Err(bad(
            path,
            format!(
                "has {} contact options where 7 (or 5, before friction) belong",
                options.len()
            ),
        ));
    }
    let mut indenters = Vec::with_capacity(n as usize);
    for k in 0..n {
        let gi = g.group(&format!("indenter_{k}"))?;
        let p = gi.attr_array::<f64>("params")?;
        let code = gi.attr::<i32>("shape")?;
        let len_ok = |want: usize| {
            if p.len() == want {
                Ok(())
            } else {
                Err(bad(
                    path,
                    format!(
                        "has indenter {k} with {} shape parameters where {want} belong",
                        p.len()
                    ),
                ))
            }
        };
        let shape = match code {
            0 => {
                len_ok(2)?;
                Shape::Wedge {
                    half_angle: p[0],
                    height: p[1],
                }
            }
            1 => {
                len_ok(1)?;
                Shape::Cylinder { radius: p[0] }
            }
            2 => {
                len_ok(3)?;
                Shape::FlatPunch {
                    half_width: p[0],
                    corner_radius: p[1],
                    height: p[2],
                }
            }
            3 if p.len() % 2 == 0 => Shape::Polygon {
                vertices: p.chunks_exact(2).map(|v| [v[0], v[1]]).collect(),
            },
            _ => {
                return Err(bad(
                    path,
                    format!("has indenter {k} of unknown shape {code}"),
                ))
            }
        };
        let t0 = gi.attr_array::<f64>("tip0")?;
        let tip0: [f64; 2] = t0
            .try_into()
            .map_err(|_| bad(path, format!("has indenter {k} without a 2D placement")))?;
        let code = gi.attr::<i32>("motion")?;
        let motion = match code {
            0 => Motion::Rest,
            1 | 2 => {
                let times = gi.attr_array::<f64>("times")?;
                let values = gi.attr_array::<f64>("values")?;
                if code == 1 {
                    Motion::Velocity {
                        times,
                        speed: values,
                    }
                } else {
                    Motion::Depth {
                        times,
                        depth: values,
                    }
                }
            }
            _ => {
                return Err(bad(
                    path,
                    format!("has indenter {k} of unknown motion {code}"),
                ))
            }
        };
        let friction = if gi.has_attr("friction")? {
            let v = gi.attr_array::<f64>("friction")?;
            *v.first().filter(|_| v.len() == 1).ok_or_else(|| {
                bad(
                    path,
                    format!("has indenter {k} with {} friction values", v.len()),
                )
            })?
        } else {
            0.0
        };
        let lateral = if gi.has_attr("lateral_times")? {
            (
                gi.attr_array::<f64>("lateral_times")?,
                gi.attr_array::<f64>("lateral_x")?,
            )
        } else {
            (Vec::new(), Vec::new())
        };
        indenters.push(StoredIndenter {
            shape,
            tip0,
            motion,
            friction,
            lateral,
        });
    }
    Ok(ContactSetup { indenters, options })
}

/// Adds the stored indenters and options to `sim` (which has none yet),
/// through the same checks as the C API's calls.
pub(super) fn apply(sim: &mut Simulation, s: &ContactSetup) -> Result<()> {
    let c = &mut sim.contact;
    for i in &s.indenters {
        let k = c.add_indenter(i.shape.clone(), i.tip0)?;
        let ind = c.indenter_mut(i64::from(k))?;
        ind.set_motion(i.motion.clone())?;
        ind.set_friction(i.friction)?;
        ind.set_lateral(&i.lateral.0, &i.lateral.1)?;
    }
    let (reg, band, gap, rtol, dense) = (
        s.options[0],
        s.options[1],
        s.options[2],
        s.options[3],
        s.options[4],
    );
    let (ftol, fmax) = match s.options.get(5..7) {
        Some(&[t, m]) => (t, m),
        _ => {
            let d = crate::contact::ContactOptions::default();
            (d.friction_tol, f64::from(d.friction_max_iter))
        }
    };
    // The bounds of `gimlet_set_contact_option`.
    let ok = (0.0..=1.0).contains(&reg)
        && (0.0..=1.0).contains(&band)
        && (0.0..=2.0).contains(&gap)
        && gap.fract() == 0.0
        && rtol > 0.0
        && rtol < 1.0
        && (0.0..=1e6).contains(&dense)
        && dense.fract() == 0.0
        && ftol > 0.0
        && ftol <= 0.1
        && (1.0..=1e4).contains(&fmax)
        && fmax.fract() == 0.0;
    if !ok {
        return Err(Error::arg(format!(
            "contact options {:?} out of their bounds",
            s.options
        )));
    }
    c.options.regularization = reg;
    c.options.band_cells = band;
    c.options.gap_mode = gap as u8;
    c.lcp.rtol = rtol;
    c.lcp.dense_max = dense as usize;
    c.options.friction_tol = ftol;
    c.options.friction_max_iter = fmax as u32;
    Ok(())
}
