//! The geometric mode of a simulation: plane strain or axisymmetry.
//!
//! A mode is a property of the whole simulation, chosen once before the
//! first insertion, and reaches the numerical layers as a type parameter
//! fixed for a whole pass (as the shape and the law are), never as a branch
//! per particle. The two modes differ only in a few places:
//!
//! | | plane strain | axisymmetric |
//! |---|---|---|
//! | x, y | x, y | radius r ≥ 0, axis z |
//! | particle volume, mass | per unit thickness | per radian (`A_p r_p`, `ρ A_p r_p`) |
//! | weights | [`crate::shape::Shape1D`] | r-weighted along r ([`crate::shape::axi`]) |
//! | out-of-plane strain rate | `D_zz = 0` | hoop rate `L_θθ = v_r / r` |
//! | out-of-plane stretch | `F_zz = 1` | `F_θθ` (a particle field) |
//! | fourth stress component | `σ_zz` | `σ_θθ`, in the radial internal force |
//!
//! The laws take the mode through
//! [`crate::material::Constitutive::update_in`]; with [`PlaneStrain`] it is
//! the plane-strain update itself, the same operations and bits, and the
//! hoop inputs are never read. The kinematics of the mode (the 3D Jacobian,
//! the dilatation, the strain increment, the hoop stretch update) are in
//! [`crate::material::axi`].

/// A geometric mode, as a type (zero-sized: [`PlaneStrain`] or
/// [`Axisymmetric`]) so that the kernel and the laws are monomorphised on
/// it.
pub trait Mode: Copy + Default + Send + Sync + 'static {
    /// The mode's tag.
    const KIND: ModeKind;
    /// True for the axisymmetric mode: the out-of-plane direction is the
    /// hoop direction, with its own strain rate `v_r / r`.
    const AXISYMMETRIC: bool;
}

/// Plane strain: the out-of-plane strain is zero, `F_zz = 1`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PlaneStrain;

/// Axisymmetry about the y axis: x is the radius, the out-of-plane
/// direction is the hoop direction θ.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Axisymmetric;

/// The modes as a run-time value (what a simulation stores and the C API
/// sets); the passes dispatch on it once, to a [`Mode`] type.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ModeKind {
    /// See [`PlaneStrain`].
    #[default]
    PlaneStrain,
    /// See [`Axisymmetric`].
    Axisymmetric,
}

impl Mode for PlaneStrain {
    const KIND: ModeKind = ModeKind::PlaneStrain;
    const AXISYMMETRIC: bool = false;
}

impl Mode for Axisymmetric {
    const KIND: ModeKind = ModeKind::Axisymmetric;
    const AXISYMMETRIC: bool = true;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kind_of<G: Mode>() -> (ModeKind, bool) {
        (G::KIND, G::AXISYMMETRIC)
    }

    #[test]
    fn the_types_carry_their_tags() {
        assert_eq!(kind_of::<PlaneStrain>(), (ModeKind::PlaneStrain, false));
        assert_eq!(kind_of::<Axisymmetric>(), (ModeKind::Axisymmetric, true));
        assert_eq!(ModeKind::default(), ModeKind::PlaneStrain);
        assert_eq!(std::mem::size_of::<Axisymmetric>(), 0);
    }
}
