//! Which vector instructions the particle loops run with.
//!
//! The library is built for the x86-64 baseline (SSE2), so that one binary
//! runs on any x86-64 machine; the particle loops are compiled three times
//! (baseline, AVX2, AVX-512) and the best one the CPU supports is chosen at
//! run time. The three builds perform the same IEEE operations in the same
//! order (no fused multiply-add: Rust never contracts `a * b + c`), only
//! more particles per instruction, so they give the same bits; a test runs
//! every level the machine has and compares.

use std::sync::atomic::{AtomicU8, Ordering};

/// An instruction-set level of the particle loops.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
#[repr(u8)]
pub enum Isa {
    /// x86-64 baseline (SSE2), or a non-x86 target.
    Base = 0,
    /// AVX2 (x86-64-v3).
    Avx2 = 1,
    /// AVX-512 F/DQ/VL (x86-64-v4).
    Avx512 = 2,
}

impl Isa {
    /// Lower-case name, as the benchmarks print it.
    pub fn name(self) -> &'static str {
        match self {
            Isa::Base => "baseline",
            Isa::Avx2 => "avx2",
            Isa::Avx512 => "avx512",
        }
    }
}

/// Highest level allowed (testing and benchmarking only).
static CAP: AtomicU8 = AtomicU8::new(Isa::Avx512 as u8);

/// Best level this CPU supports.
pub fn detected() -> Isa {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512dq")
            && std::arch::is_x86_feature_detected!("avx512vl")
            && std::arch::is_x86_feature_detected!("avx2")
            && std::arch::is_x86_feature_detected!("fma")
        {
            return Isa::Avx512;
        }
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            return Isa::Avx2;
        }
    }
    Isa::Base
}

/// The level the particle loops use: the detected one, lowered by
/// [`set_cap`].
#[inline]
pub fn active() -> Isa {
    let d = detected();
    let cap = CAP.load(Ordering::Relaxed);
    if (d as u8) <= cap {
        d
    } else if cap >= Isa::Avx2 as u8 {
        Isa::Avx2
    } else {
        Isa::Base
    }
}

/// Caps the level for the whole process (to compare the builds, or to time
/// them side by side); returns the previous cap. Results do not depend on
/// it.
pub fn set_cap(cap: Isa) -> Isa {
    match CAP.swap(cap as u8, Ordering::Relaxed) {
        0 => Isa::Base,
        1 => Isa::Avx2,
        _ => Isa::Avx512,
    }
}

/// Defines `$name`, which runs the `#[inline(always)]` function `$body`
/// with the best instruction set [`active`] allows: `$body` is compiled
/// into one copy per level, with that level's target features. The first
/// bracket declares the generic parameters, the second passes them on;
/// `$body` takes one more generic parameter first, the
/// [`crate::kernel::simd::Simd4`] of its level.
macro_rules! multiversion {
    (
        $(#[$meta:meta])*
        $vis:vis fn $name:ident [$($decl:tt)*] [$($gen:tt)*]
            ($($a:ident: $t:ty),* $(,)?) -> $r:ty = $body:ident;
    ) => {
        $(#[$meta])*
        $vis fn $name<$($decl)*>($($a: $t),*) -> $r {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
                fn v4<$($decl)*>($($a: $t),*) -> $r {
                    $body::<$crate::kernel::simd::Avx, $($gen)*>($($a),*)
                }
                #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
                fn v3<$($decl)*>($($a: $t),*) -> $r {
                    $body::<$crate::kernel::simd::Avx, $($gen)*>($($a),*)
                }
                match $crate::kernel::isa::active() {
                    // SAFETY: `active` returns a level only when the CPU
                    // has its features.
                    $crate::kernel::isa::Isa::Avx512 => return unsafe { v4::<$($gen)*>($($a),*) },
                    // SAFETY: as above.
                    $crate::kernel::isa::Isa::Avx2 => return unsafe { v3::<$($gen)*>($($a),*) },
                    $crate::kernel::isa::Isa::Base => {}
                }
            }
            $body::<$crate::kernel::simd::Base, $($gen)*>($($a),*)
        }
    };
}
pub(crate) use multiversion;
