//! The bounds the library puts on its inputs, so that a call it accepts can
//! never lead to a non-finite or zero stable step, an overflow in the step,
//! or an allocation the machine cannot make. Every bound is checked where the
//! input enters (the call that would cause the trouble fails, naming the
//! argument and the bound), never later in a step.
//!
//! **Magnitudes.** The library is unit-agnostic, so its bounds are a window
//! of magnitudes rather than physical constants: every dimensional input lies
//! in `[-MAG_MAX, MAG_MAX]` = ±1e30, and every input that must be positive
//! (cell size, domain lengths, thickness, Young's modulus, density, the
//! density a particle's mass implies, half-lengths) in `[MAG_MIN, MAG_MAX]` =
//! [1e-30, 1e30]. Why these: the step forms products of at most three or four
//! inputs (mass = density × area × thickness ≤ 1e120, kinetic energy = mass ×
//! velocity² ≤ 1e180, force = stress × length × thickness), which stay far
//! from the `f64` overflow at 1.8e308 and, for nonzero inputs, far above the
//! underflow near 1e-308; the wave speed `c = sqrt(M/ρ)` with the P-wave
//! modulus `M ≤ 4.5e15 E` (Poisson's ratio just below 0.5) stays below 1e38,
//! so the stable step `cfl · h / (c + |v|)` is finite and at least about
//! 1e-78, never zero. No SI, CGS or nondimensional problem comes near the
//! window: Young's modulus of diamond is 1.2e12 Pa, densities run from 1e-3
//! (gases) to 2.3e4 kg/m³, atomistic lengths are 1e-10 m, speeds of interest
//! below 1e5 m/s.
//!
//! **Resolution.** A domain whose corners lie more than 2^32 level-0 cells
//! from the origin of coordinates (a tiny cell far from zero) is rejected:
//! positions there could not be resolved to a fraction of the finest cell.
//!
//! **Memory.** A patch's grid holds 72 bytes per node; a patch may have at
//! most [`MAX_PATCH_NODES`] nodes (2^25, 2.4 GB), checked for every patch
//! when the layout freezes (first insertion), so a domain of 65000 × 65000
//! cells left as one patch is refused there with the advice to tile it. A
//! level may have at most [`MAX_PATCHES_PER_LEVEL`] patches and
//! [`MAX_BOXES_PER_LEVEL`] boxes (the layout's set-up is quadratic in them).
//! An insertion or fill is refused when the particles it adds would need
//! more memory than this rank can get ([`available_memory`]), and grid and
//! message buffers are allocated fallibly, so an allocation the system
//! refuses is an error status, not an abort.

use crate::error::{Error, Result};

/// Largest magnitude of any dimensional input.
pub const MAG_MAX: f64 = 1e30;
/// Smallest value of a dimensional input that must be positive.
pub const MAG_MIN: f64 = 1e-30;
/// Most nodes of one patch's grid (cells + 1 + 2 ghost cells per axis,
/// multiplied): 2^25 nodes, 2.4 GB of nodal arrays.
pub const MAX_PATCH_NODES: u64 = 1 << 25;
/// Most patches of one level.
pub const MAX_PATCHES_PER_LEVEL: u64 = 1 << 14;
/// Most boxes of one level.
pub const MAX_BOXES_PER_LEVEL: usize = 4096;
/// Most level-0 cells between the origin of coordinates and the farthest
/// domain corner, per axis.
pub const MAX_EXTENT_CELLS: f64 = 4_294_967_296.0;
/// Bytes a particle needs while it is inserted and stored (its fields, the
/// insertion message, vector growth), for the memory estimate.
pub const BYTES_PER_PARTICLE: u64 = 640;
/// Most particles one insertion or fill may add (over all ranks).
pub const MAX_NEW_PARTICLES: u64 = 1 << 31;

/// A number for a message: plain decimals for ordinary magnitudes,
/// scientific notation for very large or small ones (`1e200`, not 201
/// digits).
pub fn num(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 || !a.is_finite() || (1e-4..1e15).contains(&a) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// Checks a dimensional input that may have any sign: finite and
/// `|v| <= MAG_MAX`.
pub fn magnitude(name: &str, v: f64) -> Result<()> {
    if !(v.is_finite() && v.abs() <= MAG_MAX) {
        return Err(Error::arg(format!(
            "{name} = {} must be finite with |{name}| <= {MAG_MAX:e}",
            num(v)
        )));
    }
    Ok(())
}

/// Checks a dimensional input that must be positive: in
/// `[MAG_MIN, MAG_MAX]`.
pub fn positive(name: &str, v: f64) -> Result<()> {
    if !(v.is_finite() && (MAG_MIN..=MAG_MAX).contains(&v)) {
        return Err(Error::arg(format!(
            "{name} = {} must be finite and between {MAG_MIN:e} and {MAG_MAX:e}",
            num(v)
        )));
    }
    Ok(())
}

/// Checks a grid of `nodes` nodes for one patch (level `l`, patch of
/// `cells` cells per axis).
pub fn patch_nodes(l: usize, cells: [i64; 2], nodes: u64) -> Result<()> {
    if nodes > MAX_PATCH_NODES {
        return Err(Error::arg(format!(
            "level {l} has a patch of {} x {} cells, whose grid would have {nodes} nodes ({:.1} GB), above the {MAX_PATCH_NODES} nodes a patch may have: tile the level into smaller patches with gimlet_set_patch_size",
            cells[0],
            cells[1],
            nodes as f64 * 72.0 / 1e9
        )));
    }
    Ok(())
}

/// The memory this process can still allocate, in bytes (`MemAvailable` of
/// `/proc/meminfo`), or `None` where that is unknown.
pub fn available_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb.saturating_mul(1024))
}

/// Checks that `n` new particles (an upper bound, over all ranks), of which
/// at most `local` land on this rank, can be stored.
pub fn new_particles(n: f64, local: f64) -> Result<()> {
    if n.is_nan() || n > MAX_NEW_PARTICLES as f64 {
        return Err(Error::arg(format!(
            "the call would add up to {n:.3e} particles, more than the {MAX_NEW_PARTICLES} one insertion may add"
        )));
    }
    if let Some(avail) = available_memory() {
        let need = local * BYTES_PER_PARTICLE as f64;
        if need > avail as f64 {
            return Err(Error::arg(format!(
                "the call would store up to {local:.3e} particles on this rank, about {:.1} GB, more than the {:.1} GB of memory available",
                need / 1e9,
                avail as f64 / 1e9
            )));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn windows_name_the_bound() {
        assert!(magnitude("vx", 0.0).is_ok());
        assert!(magnitude("vx", -1e30).is_ok());
        let e = magnitude("vx", 1e200).unwrap_err();
        assert!(
            e.msg.contains("vx = 1e200") && e.msg.contains("1e30"),
            "{}",
            e.msg
        );
        assert!(magnitude("g", f64::NAN).is_err());
        assert!(positive("rho", 2700.0).is_ok());
        assert!(positive("rho", 0.0).is_err());
        assert!(positive("rho", 1e-300).is_err());
        assert!(positive("e", 1e308).is_err());
    }

    /// The window keeps the stable step of the most extreme accepted
    /// material finite and nonzero, and the step's products finite.
    #[test]
    fn extreme_inputs_keep_the_step_finite() {
        // Largest P-wave modulus: E = MAG_MAX, nu just below 0.5.
        let (e, nu) = (MAG_MAX, 0.5 - f64::EPSILON);
        let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
        let mu = e / (2.0 * (1.0 + nu));
        let c = ((lambda + 2.0 * mu) / MAG_MIN).sqrt();
        assert!(c.is_finite());
        // Smallest finest cell: MAG_MIN / 2^7 (8 levels).
        let dt = 0.01 * (MAG_MIN / 128.0) / (c + MAG_MAX);
        assert!(dt.is_finite() && dt > 0.0, "dt = {dt}");
        // Largest mass and kinetic energy.
        let m = MAG_MAX * (MAG_MAX * MAG_MAX) * MAG_MAX;
        assert!((0.5 * m * MAG_MAX * MAG_MAX).is_finite());
        // Smallest nonzero mass stays a normal number.
        let m = MAG_MIN * (MAG_MIN / 256.0).powi(2) * MAG_MIN;
        assert!(m.is_normal());
    }
}
