//! From the run's configuration to the compiled loops: every particle pass
//! is compiled once per weight function, material law, pass and scatter
//! (const generics, see [`super::g2p::g2p_impl`] and
//! [`super::p2g::p2g_impl`]), and the functions here pick the instance a
//! call needs with one `match` per pass, so that no per-particle branch
//! tests the configuration.

use super::g2p::{g2p_impl, G2pCtx};
use super::p2g::{p2g_impl, Sinks};
use super::{BodyForce, G2pPass, Grid, PassStats, StepParams, Transfer};
use crate::error::Result;
use crate::material::{
    AnyLaw, Constitutive, J2Law, LinearElasticLaw, MatKind, MatParams, NeoHookeanLaw,
};
use crate::particles::Particles;
use crate::shape::Shape1D;

/// Runs `$body` with the type `$S` bound to the weights of the run's
/// `($shape, $mode)`: `MpmShape` or `GimpShape` (uGIMP and cpGIMP share
/// it; the run-time variant picks the domain update) in plane strain, and
/// the `Axi` of either in axisymmetry. The one place that maps the
/// configuration to the compiled weight types.
macro_rules! with_shape {
    ($shape:expr, $mode:expr, $S:ident => $body:expr) => {{
        use $crate::mode::ModeKind as M;
        use $crate::shape::{Axi, GimpShape, MpmShape, ShapeKind as K};
        match ($shape, $mode) {
            (K::Mpm, M::PlaneStrain) => {
                type $S = MpmShape;
                $body
            }
            (_, M::PlaneStrain) => {
                type $S = GimpShape;
                $body
            }
            (K::Mpm, M::Axisymmetric) => {
                type $S = Axi<MpmShape>;
                $body
            }
            (_, M::Axisymmetric) => {
                type $S = Axi<GimpShape>;
                $body
            }
        }
    }};
}
pub(super) use with_shape;

/// No P2G scatter (for [`g2p_any`]).
pub(super) const NO_SCATTER: (bool, bool, bool) = (false, false, false);

/// The law every material of the table shares, if they all share one.
pub(super) fn uniform_law(mats: &[MatParams]) -> Option<MatKind> {
    let k = mats.first()?.kind;
    mats.iter().all(|m| m.kind == k).then_some(k)
}

/// P2G: dispatch on the shape.
pub(super) fn p2g_any(
    grid: &mut Grid,
    parts: &Particles,
    prm: &StepParams,
    body: Option<BodyForce>,
    what: (bool, bool, bool),
) -> Result<()> {
    with_shape!(prm.shape, prm.mode, S => p2g_s::<S>(grid, parts, prm, body, what))
}

/// P2G: dispatch on what is scattered and on the transfer.
fn p2g_s<S: Shape1D>(
    grid: &mut Grid,
    parts: &Particles,
    prm: &StepParams,
    body: Option<BodyForce>,
    what: (bool, bool, bool),
) -> Result<()> {
    // The affine momentum (APIC) only where momentum is scattered.
    let apic = prm.transfer == Transfer::Apic;
    macro_rules! go {
        ($m:expr, $p:expr, $f:expr) => {
            if apic {
                p2g_impl::<S, $m, $p, $f, true>(grid, parts, prm, body)
            } else {
                p2g_impl::<S, $m, $p, $f, false>(grid, parts, prm, body)
            }
        };
    }
    match what {
        (true, true, true) => go!(true, true, true),
        (true, true, false) => go!(true, true, false),
        (false, true, false) => go!(false, true, false),
        (false, false, true) => p2g_impl::<S, false, false, true, false>(grid, parts, prm, body),
        (true, false, false) => p2g_impl::<S, true, false, false, false>(grid, parts, prm, body),
        (true, false, true) => p2g_impl::<S, true, false, true, false>(grid, parts, prm, body),
        (false, true, true) => go!(false, true, true),
        (false, false, false) => Ok(()),
    }
}

/// G2P (with the fused scatter `what`): dispatch on the shape and the
/// material law.
pub(super) fn g2p_any(
    ctx: G2pCtx,
    sinks: Sinks,
    parts: &mut Particles,
    pass: G2pPass,
    what: (bool, bool, bool),
) -> PassStats {
    with_shape!(ctx.prm.shape, ctx.prm.mode, S => g2p_s::<S>(ctx, sinks, parts, pass, what))
}

/// G2P: dispatch on the material law.
fn g2p_s<S: Shape1D>(
    ctx: G2pCtx,
    sinks: Sinks,
    parts: &mut Particles,
    pass: G2pPass,
    what: (bool, bool, bool),
) -> PassStats {
    match uniform_law(ctx.mats) {
        Some(MatKind::LinearElastic) => {
            g2p_sm::<S, LinearElasticLaw>(ctx, sinks, parts, pass, what)
        }
        Some(MatKind::NeoHookean) => g2p_sm::<S, NeoHookeanLaw>(ctx, sinks, parts, pass, what),
        Some(MatKind::J2) => g2p_sm::<S, J2Law>(ctx, sinks, parts, pass, what),
        None => g2p_sm::<S, AnyLaw>(ctx, sinks, parts, pass, what),
    }
}

/// G2P: dispatch on the pass, the scatter (`what` is [`NO_SCATTER`] or a
/// pair that [`super::fusable`] accepts) and the transfer.
fn g2p_sm<S: Shape1D, M: Constitutive>(
    ctx: G2pCtx,
    sinks: Sinks,
    parts: &mut Particles,
    pass: G2pPass,
    what: (bool, bool, bool),
) -> PassStats {
    const F: bool = false;
    const T: bool = true;
    // The APIC variant (velocity and affine matrix, affine momentum, the
    // objective update of F) where the transfer asks for it.
    let apic = ctx.prm.transfer == Transfer::Apic;
    macro_rules! go {
        ($vel:expr, $pos:expr, $strain:expr, $m:expr, $p:expr, $f:expr) => {
            if apic {
                g2p_impl::<S, M, $vel, $pos, $strain, $m, $p, $f, true>(ctx, sinks, parts)
            } else {
                g2p_impl::<S, M, $vel, $pos, $strain, $m, $p, $f, false>(ctx, sinks, parts)
            }
        };
    }
    match (pass, what) {
        (G2pPass::UslAll, NO_SCATTER) => go!(T, T, T, F, F, F),
        (G2pPass::UslAll, (T, T, T)) => go!(T, T, T, T, T, T),
        (G2pPass::MuslVelocity, NO_SCATTER) => go!(T, F, F, F, F, F),
        (G2pPass::MuslVelocity, (F, T, F)) => go!(T, F, F, F, T, F),
        (G2pPass::MuslPositionStrain, NO_SCATTER) => go!(F, T, T, F, F, F),
        (G2pPass::MuslPositionStrain, (T, T, T)) => go!(F, T, T, T, T, T),
        (G2pPass::MuslPositionStrain, (T, T, F)) => go!(F, T, T, T, T, F),
        (G2pPass::UsfStrain, NO_SCATTER) => go!(F, F, T, F, F, F),
        (G2pPass::UsfStrain, (F, F, T)) => go!(F, F, T, F, F, T),
        (G2pPass::UsfVelocityPosition, NO_SCATTER) => go!(T, T, F, F, F, F),
        (G2pPass::UsfVelocityPosition, (T, T, F)) => go!(T, T, F, T, T, F),
        (G2pPass::UsfVelocityPosition, (T, T, T)) => go!(T, T, F, T, T, T),
        _ => unreachable!("g2p_sm is called with no scatter or a fusable pair"),
    }
}
