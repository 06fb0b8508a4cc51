//! Structure-of-arrays particle storage, one instance per patch (or per rank
//! before patches exist). Every field is a contiguous [`FieldVec<f64>`] (or
//! integer array) indexed by the particle's local slot, each at a cache-line
//! offset of its own (see [`crate::storage`]: the kernels stream the fields
//! in lock step); global ids are stable for the life of the simulation and
//! are what levels and ranks match particles by.
//!
//! Units are the caller's (SI in the examples). In 2D plane strain every
//! extensive quantity is per the simulation's thickness `t`: a particle of
//! half-lengths `lpx, lpy` has volume `4 lpx lpy t`.

use crate::storage::FieldVec;

/// Structure-of-arrays particle storage.
///
/// `Clone` is written out (from one list of the fields): `clone_from` copies
/// field by field into the arrays `self` already has
/// ([`FieldVec::clone_from`]), so that a copy taken over and over (the
/// snapshot of a step) allocates nothing once its arrays are big enough.
#[derive(Debug, Default, PartialEq)]
pub struct Particles {
    /// Global id, unique over all ranks and levels (copies on another level
    /// share the id of their original).
    pub id: FieldVec<u64>,
    /// Position x.
    pub x: FieldVec<f64>,
    /// Position y.
    pub y: FieldVec<f64>,
    /// Reference (initial) position x, for displacements.
    pub x0: FieldVec<f64>,
    /// Reference (initial) position y.
    pub y0: FieldVec<f64>,
    /// Velocity x.
    pub vx: FieldVec<f64>,
    /// Velocity y.
    pub vy: FieldVec<f64>,
    /// Mass (per thickness `t` of the plane-strain slab, i.e. `rho * V`).
    pub mass: FieldVec<f64>,
    /// Reference volume `4 lpx0 lpy0 t`.
    pub vol0: FieldVec<f64>,
    /// Reference half-length in x.
    pub lpx0: FieldVec<f64>,
    /// Reference half-length in y.
    pub lpy0: FieldVec<f64>,
    /// Current half-length in x (equals `lpx0` for uGIMP and MPM).
    pub lpx: FieldVec<f64>,
    /// Current half-length in y.
    pub lpy: FieldVec<f64>,
    /// Deformation gradient F_xx.
    pub fxx: FieldVec<f64>,
    /// Deformation gradient F_xy.
    pub fxy: FieldVec<f64>,
    /// Deformation gradient F_yx.
    pub fyx: FieldVec<f64>,
    /// Deformation gradient F_yy.
    pub fyy: FieldVec<f64>,
    /// The out-of-plane stretch: 1 in plane strain, the hoop stretch
    /// `F_θθ = r/R` in the axisymmetric mode (see [`crate::mode`]).
    pub fzz: FieldVec<f64>,
    /// Cauchy stress xx.
    pub sxx: FieldVec<f64>,
    /// Cauchy stress yy.
    pub syy: FieldVec<f64>,
    /// Cauchy stress xy.
    pub sxy: FieldVec<f64>,
    /// Cauchy stress zz (plane strain out-of-plane component).
    pub szz: FieldVec<f64>,
    /// Reference external force x of the traction on the particle's face in
    /// y (top or bottom, as [`Particles::load_faces`] says): a traction
    /// times the loaded face length and the thickness, scaled by the load
    /// ramp at each step and spread over the nodes with the face integral
    /// of their shape functions (see [`crate::kernel`]).
    pub fext_x: FieldVec<f64>,
    /// Reference external force y on the face in y (see `fext_x`).
    pub fext_y: FieldVec<f64>,
    /// Reference external force x of the traction on the particle's face in
    /// x (left or right, as [`Particles::load_faces`] says).
    pub fside_x: FieldVec<f64>,
    /// Reference external force y on the face in x (see `fside_x`).
    pub fside_y: FieldVec<f64>,
    /// Which faces carry the loads `fext` and `fside`, and how: `ty + 3 tx`
    /// with `ty` = +1 (top), −1 (bottom) or 0 and `tx` = +1 (right), −1
    /// (left) or 0, plus [`FOLLOWER_OFFSET`] (once or twice) when the
    /// loads follow the deformed faces ([`LoadKind`]; see
    /// [`load_faces_code`]); 0
    /// for an unloaded particle, so the particle loops test one value per
    /// particle.
    pub load_faces: FieldVec<f64>,
    /// Material index into the simulation's material table.
    pub material: FieldVec<u32>,
    /// Equivalent plastic strain (the state of a J2 material; stays 0 for
    /// the elastic laws).
    pub eps_p: FieldVec<f64>,
    /// Affine velocity matrix C_xx of the APIC transfer (see
    /// [`crate::kernel::Transfer::Apic`]): the particle carries the velocity
    /// field `v_p + C (x − x_p)` around it. Zero until a step with APIC (or a
    /// caller) sets it; the FLIP/PIC transfer neither reads nor writes it.
    pub cxx: FieldVec<f64>,
    /// Affine velocity matrix C_xy (`∂v_x/∂y`-like; see `cxx`).
    pub cxy: FieldVec<f64>,
    /// Affine velocity matrix C_yx (`∂v_y/∂x`-like; see `cxx`).
    pub cyx: FieldVec<f64>,
    /// Affine velocity matrix C_yy (see `cxx`).
    pub cyy: FieldVec<f64>,
    /// Whether this is a copy kept for coupling levels: 0 = owned by this
    /// level, 1 = copy of a particle owned by the next coarser level (fine
    /// ghost ring), 2 = copy of a particle owned by the next finer level.
    /// Stored as f64 so that it travels with the other fields (packing,
    /// files) without a special case.
    pub copy: FieldVec<f64>,
}

/// Calls `$m!` with every field of [`Particles`]: the one list the
/// hand-written `Clone` uses. Both of its methods name the fields in a
/// struct expression or pattern without `..`, so a field added to the
/// struct and not to this list is a compile error, not a field a clone
/// forgets.
macro_rules! particle_fields {
    ($m:ident) => {
        $m! {
            id, x, y, x0, y0, vx, vy, mass, vol0, lpx0, lpy0, lpx, lpy, fxx, fxy, fyx, fyy, fzz,
            sxx, syy, sxy, szz, fext_x, fext_y, fside_x, fside_y, load_faces, material, eps_p, cxx, cxy,
            cyx, cyy, copy
        }
    };
}

macro_rules! particles_clone {
    ($($f:ident),* $(,)?) => {
        impl Clone for Particles {
            fn clone(&self) -> Self {
                let Particles { $($f),* } = self;
                Particles { $($f: $f.clone()),* }
            }

            fn clone_from(&mut self, src: &Self) {
                let Particles { $($f),* } = self;
                $($f.clone_from(&src.$f);)*
            }
        }
    };
}

particle_fields!(particles_clone);

#[cfg(test)]
macro_rules! particles_assert_same {
    ($($f:ident),* $(,)?) => {
        impl Particles {
            /// Asserts that every field of `self` equals `o`'s bit for bit
            /// (lengths included) and keeps the storage's layout property
            /// ([`FieldVec::assert_layout`]).
            pub(crate) fn assert_same(&self, o: &Particles) {
                let Particles { $($f),* } = self;
                $(
                    assert_eq!($f.bytes(), o.$f.bytes(), "field {}", stringify!($f));
                    $f.assert_layout();
                )*
            }
        }
    };
}

#[cfg(test)]
particle_fields!(particles_assert_same);

/// Value of [`Particles::copy`] for an owned particle.
pub const OWNED: f64 = 0.0;
/// Value of [`Particles::copy`] for a copy from the next coarser level.
pub const COPY_FROM_COARSER: f64 = 1.0;
/// Value of [`Particles::copy`] for a copy from the next finer level.
pub const COPY_FROM_FINER: f64 = 2.0;

/// The two kinds of copies a level holds for coupling (the values of
/// [`Particles::copy`] other than [`OWNED`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CopyKind {
    /// A copy of a particle owned by the next coarser level (in a refined
    /// level's ghost ring).
    FromCoarser,
    /// A copy of a particle owned by the next finer level (in the layer
    /// inside the refined region).
    FromFiner,
}

impl CopyKind {
    /// Its value of [`Particles::copy`].
    pub const fn flag(self) -> f64 {
        match self {
            CopyKind::FromCoarser => COPY_FROM_COARSER,
            CopyKind::FromFiner => COPY_FROM_FINER,
        }
    }
}

/// The index of the f64 field `name` in [`Particles::F64_NAMES`] (and in
/// [`Particles::f64_fields`]), computed at compile time where it is used in
/// a constant: a name that is no field does not compile there.
pub const fn f64_field(name: &str) -> usize {
    let want = name.as_bytes();
    let mut k = 0;
    while k < Particles::N_F64 {
        let have = Particles::F64_NAMES[k].as_bytes();
        if have.len() == want.len() {
            let mut i = 0;
            while i < want.len() && have[i] == want[i] {
                i += 1;
            }
            if i == want.len() {
                return k;
            }
        }
        k += 1;
    }
    panic!("no f64 particle field of that name")
}

/// A particle packed as [`Particles::pack`] writes it: the id (u64), the
/// material (as u64), then the f64 fields in the order of
/// [`Particles::F64_NAMES`], all little-endian.
pub type Packed = [u8; Particles::PACKED_BYTES];

/// The particle with global id `id`, material `material` and the f64
/// fields `f64s` (in the order of [`Particles::F64_NAMES`]; missing ones
/// are zero) packed: the one writer of the layout [`PackedParticle`] reads.
#[inline]
pub fn pack_values(id: u64, material: u32, f64s: impl IntoIterator<Item = f64>) -> Packed {
    let mut b = [0u8; Particles::PACKED_BYTES];
    b[0..8].copy_from_slice(&id.to_le_bytes());
    b[8..16].copy_from_slice(&u64::from(material).to_le_bytes());
    for (w, v) in b[16..].chunks_exact_mut(8).zip(f64s) {
        w.copy_from_slice(&v.to_le_bytes());
    }
    b
}

/// A view of a packed particle (see [`Packed`]): the one reader of the
/// layout [`pack_values`] writes.
#[derive(Clone, Copy, Debug)]
pub struct PackedParticle<'a>(&'a [u8]);

impl<'a> PackedParticle<'a> {
    /// The packed particle in the first [`Particles::PACKED_BYTES`] bytes
    /// of `b`.
    ///
    /// # Panics
    /// If `b` is shorter.
    #[inline]
    pub fn new(b: &'a [u8]) -> PackedParticle<'a> {
        PackedParticle(&b[..Particles::PACKED_BYTES])
    }

    #[inline]
    fn word(&self, k: usize) -> u64 {
        u64::from_le_bytes(self.0[8 * k..8 * k + 8].try_into().expect("8 bytes"))
    }

    /// Global id.
    #[inline]
    pub fn id(&self) -> u64 {
        self.word(0)
    }

    /// Material index.
    #[inline]
    pub fn material(&self) -> u32 {
        self.word(1) as u32
    }

    /// The f64 field with index `k` (see [`f64_field`]).
    #[inline]
    pub fn f64(&self, k: usize) -> f64 {
        f64::from_bits(self.word(2 + k))
    }

    /// Position x.
    #[inline]
    pub fn x(&self) -> f64 {
        const K: usize = f64_field("x");
        self.f64(K)
    }

    /// Position y.
    #[inline]
    pub fn y(&self) -> f64 {
        const K: usize = f64_field("y");
        self.f64(K)
    }

    /// Current half-length in x.
    #[inline]
    pub fn lpx(&self) -> f64 {
        const K: usize = f64_field("lpx");
        self.f64(K)
    }

    /// Current half-length in y.
    #[inline]
    pub fn lpy(&self) -> f64 {
        const K: usize = f64_field("lpy");
        self.f64(K)
    }

    /// The packed bytes.
    #[inline]
    pub fn bytes(&self) -> &'a [u8] {
        self.0
    }
}

/// How a particle's surface loads act (one kind per particle, for both of
/// its loaded faces). For a face with reference outward normal `N`,
/// reference tangent `T` (`e_x` for a face in y, `e_y` for a face in x)
/// and reference force `f0` (a traction times the reference face length
/// and the thickness), with `F` the particle's deformation gradient:
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum LoadKind {
    /// A dead load: `f0` acts as it is, whatever the deformation (a
    /// nominal traction on the reference face, in fixed axes).
    #[default]
    Dead,
    /// A traction per current area in fixed axes: `f0 |F T|`, the force
    /// scaled by the face's current length per reference length (the size
    /// of Nanson's `n da = J F^{-T} N dA` in plane strain, where the
    /// thickness does not change), its direction kept. A Cauchy traction
    /// of fixed direction.
    FollowArea,
    /// A traction per current area that turns with the face: `f0` rotated
    /// by the angle from `T` to `F T` and scaled by `|F T|` (as complex
    /// numbers `f0 (F T) / T`, which is Nanson's `J F^{-T} N dA` times the
    /// traction): its normal and tangential components stay fixed relative
    /// to the current face. A Cauchy traction that follows the face.
    FollowFace,
}

/// What [`load_faces_code`] adds for a [`LoadKind::FollowArea`] load (the
/// face part of a code lies in `[-4, 4]`); twice this for
/// [`LoadKind::FollowFace`].
pub const FOLLOWER_OFFSET: f64 = 9.0;

/// The [`Particles::load_faces`] code of a particle loaded on its face in
/// y with sign `ty` (+1 top, −1 bottom, 0 none) and on its face in x with
/// sign `tx` (+1 right, −1 left, 0 none), by loads of `kind` (an unloaded
/// particle's code is 0 whatever `kind`).
pub fn load_faces_code(ty: i32, tx: i32, kind: LoadKind) -> f64 {
    let c = (ty.signum() + 3 * tx.signum()) as f64;
    match kind {
        _ if c == 0.0 => 0.0,
        LoadKind::Dead => c,
        LoadKind::FollowArea => c + FOLLOWER_OFFSET,
        LoadKind::FollowFace => c + 2.0 * FOLLOWER_OFFSET,
    }
}

/// The face signs `(ty, tx)` of a [`Particles::load_faces`] code (see
/// [`load_faces_code`]).
#[inline]
pub fn load_faces_of(code: f64) -> (i32, i32) {
    let k = FOLLOWER_OFFSET as i32;
    let mut c = code as i32;
    if c > 4 + k {
        c -= 2 * k;
    } else if c > 4 {
        c -= k;
    }
    let tx = (c + 4).div_euclid(3) - 1;
    (c - 3 * tx, tx)
}

/// The kind of the loads of a [`Particles::load_faces`] code (`Dead` for
/// an unloaded particle).
#[inline]
pub fn load_kind_of(code: f64) -> LoadKind {
    if code > 4.5 + FOLLOWER_OFFSET {
        LoadKind::FollowFace
    } else if code > 4.5 {
        LoadKind::FollowArea
    } else {
        LoadKind::Dead
    }
}

/// One particle's initial description, used for insertion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NewParticle {
    /// Global id.
    pub id: u64,
    /// Position.
    pub x: f64,
    /// Position.
    pub y: f64,
    /// Half-length in x.
    pub lpx: f64,
    /// Half-length in y.
    pub lpy: f64,
    /// Velocity.
    pub vx: f64,
    /// Velocity.
    pub vy: f64,
    /// Mass.
    pub mass: f64,
    /// Material index.
    pub material: u32,
}

impl Particles {
    /// An empty set.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of particles stored.
    pub fn len(&self) -> usize {
        self.id.len()
    }

    /// True when no particle is stored.
    pub fn is_empty(&self) -> bool {
        self.id.is_empty()
    }

    /// Appends a particle in its reference state (F = I, zero stress, no
    /// external force). `thickness` is the plane-strain thickness.
    pub fn push(&mut self, p: &NewParticle, thickness: f64) {
        self.id.push(p.id);
        self.x.push(p.x);
        self.y.push(p.y);
        self.x0.push(p.x);
        self.y0.push(p.y);
        self.vx.push(p.vx);
        self.vy.push(p.vy);
        self.mass.push(p.mass);
        self.vol0.push(4.0 * p.lpx * p.lpy * thickness);
        self.lpx0.push(p.lpx);
        self.lpy0.push(p.lpy);
        self.lpx.push(p.lpx);
        self.lpy.push(p.lpy);
        self.fxx.push(1.0);
        self.fxy.push(0.0);
        self.fyx.push(0.0);
        self.fyy.push(1.0);
        self.fzz.push(1.0);
        self.sxx.push(0.0);
        self.syy.push(0.0);
        self.sxy.push(0.0);
        self.szz.push(0.0);
        self.fext_x.push(0.0);
        self.fext_y.push(0.0);
        self.fside_x.push(0.0);
        self.fside_y.push(0.0);
        self.load_faces.push(0.0);
        self.material.push(p.material);
        self.eps_p.push(0.0);
        self.cxx.push(0.0);
        self.cxy.push(0.0);
        self.cyx.push(0.0);
        self.cyy.push(0.0);
        self.copy.push(OWNED);
    }

    /// Applies `f` to every per-particle vector, so that operations that
    /// reorder or filter particles never forget a field.
    fn for_each_f64(&mut self, mut f: impl FnMut(&mut FieldVec<f64>)) {
        for v in self.f64_fields_mut() {
            f(v);
        }
    }

    /// The f64 fields in the order of [`Particles::f64_fields`], mutable.
    pub fn f64_fields_mut(&mut self) -> [&mut FieldVec<f64>; Self::N_F64] {
        [
            &mut self.x,
            &mut self.y,
            &mut self.x0,
            &mut self.y0,
            &mut self.vx,
            &mut self.vy,
            &mut self.mass,
            &mut self.vol0,
            &mut self.lpx0,
            &mut self.lpy0,
            &mut self.lpx,
            &mut self.lpy,
            &mut self.fxx,
            &mut self.fxy,
            &mut self.fyx,
            &mut self.fyy,
            &mut self.fzz,
            &mut self.sxx,
            &mut self.syy,
            &mut self.sxy,
            &mut self.szz,
            &mut self.fext_x,
            &mut self.fext_y,
            &mut self.fside_x,
            &mut self.fside_y,
            &mut self.load_faces,
            &mut self.eps_p,
            &mut self.cxx,
            &mut self.cxy,
            &mut self.cyx,
            &mut self.cyy,
            &mut self.copy,
        ]
    }

    /// Copies particle `i` of `src` onto the end of `self` (all fields).
    pub fn push_from(&mut self, src: &Particles, i: usize) {
        self.id.push(src.id[i]);
        self.material.push(src.material[i]);
        let fields_src = src.f64_fields();
        let mut k = 0;
        self.for_each_f64(|v| {
            v.push(fields_src[k][i]);
            k += 1;
        });
    }

    /// The f64 fields in a fixed order (the order `for_each_f64` visits).
    pub fn f64_fields(&self) -> [&FieldVec<f64>; Self::N_F64] {
        [
            &self.x,
            &self.y,
            &self.x0,
            &self.y0,
            &self.vx,
            &self.vy,
            &self.mass,
            &self.vol0,
            &self.lpx0,
            &self.lpy0,
            &self.lpx,
            &self.lpy,
            &self.fxx,
            &self.fxy,
            &self.fyx,
            &self.fyy,
            &self.fzz,
            &self.sxx,
            &self.syy,
            &self.sxy,
            &self.szz,
            &self.fext_x,
            &self.fext_y,
            &self.fside_x,
            &self.fside_y,
            &self.load_faces,
            &self.eps_p,
            &self.cxx,
            &self.cxy,
            &self.cyx,
            &self.cyy,
            &self.copy,
        ]
    }

    /// Number of f64 fields per particle (see `f64_fields`).
    pub const N_F64: usize = 32;

    /// Names of the f64 fields, in the order of `f64_fields` (used as
    /// dataset names in files; see [`f64_field`] for the index of a name).
    pub const F64_NAMES: [&'static str; Self::N_F64] = [
        "x",
        "y",
        "x0",
        "y0",
        "vx",
        "vy",
        "mass",
        "vol0",
        "lpx0",
        "lpy0",
        "lpx",
        "lpy",
        "fxx",
        "fxy",
        "fyx",
        "fyy",
        "fzz",
        "sxx",
        "syy",
        "sxy",
        "szz",
        "fext_x",
        "fext_y",
        "fside_x",
        "fside_y",
        "load_faces",
        "eps_p",
        "cxx",
        "cxy",
        "cyx",
        "cyy",
        "copy",
    ];

    /// Bytes per particle in [`Particles::pack`].
    pub const PACKED_BYTES: usize = 8 * (2 + Self::N_F64);

    /// Appends every field of particle `i` to `out` (little-endian, see
    /// [`Packed`]), for sending it to another patch or rank.
    pub fn pack(&self, i: usize, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.packed(i));
    }

    /// Particle `i` packed (see [`Packed`] and [`pack_values`]).
    #[inline]
    pub fn packed(&self, i: usize) -> Packed {
        pack_values(
            self.id[i],
            self.material[i],
            self.f64_fields().iter().map(|f| f[i]),
        )
    }

    /// Appends the packed particle `b` (see [`Particles::pack`]).
    pub fn push_packed(&mut self, b: PackedParticle) {
        self.id.push(b.id());
        self.material.push(b.material());
        let mut k = 0;
        self.for_each_f64(|v| {
            v.push(b.f64(k));
            k += 1;
        });
    }

    /// Appends the particles packed in `recs` (each as [`Particles::pack`]
    /// writes it), in order: the same as [`Particles::push_packed`] on each.
    /// Blocks of records small enough for the L1 cache are transposed one
    /// field at a time, so that both the reads and the writes stream.
    pub fn extend_packed<'a, I>(&mut self, recs: I)
    where
        I: ExactSizeIterator<Item = PackedParticle<'a>> + Clone,
    {
        /// Records per block (64 records: 15 KB).
        const BLOCK: usize = 64;
        let n = recs.len();
        self.id.reserve(n);
        self.material.reserve(n);
        self.for_each_f64(|v| v.reserve(n));
        let mut rest = recs;
        while rest.len() > 0 {
            let blk = rest.clone().take(BLOCK);
            self.id.extend(blk.clone().map(|b| b.id()));
            self.material.extend(blk.clone().map(|b| b.material()));
            let mut k = 0;
            self.for_each_f64(|v| {
                v.extend(blk.clone().map(|b| b.f64(k)));
                k += 1;
            });
            if rest.len() <= BLOCK {
                break;
            }
            rest.nth(BLOCK - 1);
        }
    }

    /// Keeps the particles for which `keep(i)` is true, preserving order.
    pub fn retain(&mut self, mut keep: impl FnMut(usize) -> bool) {
        let gone: Vec<usize> = (0..self.len()).filter(|&i| !keep(i)).collect();
        self.remove_sorted(&gone);
    }

    /// Removes the particles at the slots `gone` (strictly increasing),
    /// preserving the order of the others: the particles before the first
    /// removed slot stay in place, and each run of kept particles after it
    /// moves down with one block copy per field.
    ///
    /// # Panics
    /// If a slot is out of range or the slots are not increasing.
    pub fn remove_sorted(&mut self, gone: &[usize]) {
        if gone.is_empty() {
            return;
        }
        assert!(
            gone.windows(2).all(|w| w[0] < w[1]) && gone[gone.len() - 1] < self.len(),
            "slots to remove must be increasing and in range"
        );
        let n = self.len();
        let mut w = gone[0];
        let mut k = 0;
        while k < gone.len() {
            // A run of removed slots ending at r, then kept slots r + 1..end.
            let mut r = gone[k];
            while k + 1 < gone.len() && gone[k + 1] == r + 1 {
                k += 1;
                r += 1;
            }
            let end = gone.get(k + 1).copied().unwrap_or(n);
            if end > r + 1 {
                self.id.copy_within(r + 1..end, w);
                self.material.copy_within(r + 1..end, w);
                self.for_each_f64(|v| v.copy_within(r + 1..end, w));
                w += end - r - 1;
            }
            k += 1;
        }
        self.id.truncate(w);
        self.material.truncate(w);
        self.for_each_f64(|v| v.truncate(w));
    }

    /// Reorders particles by the permutation `perm` (new slot k holds old
    /// slot `perm[k]`).
    pub fn permute(&mut self, perm: &[usize]) {
        assert_eq!(perm.len(), self.len());
        fn apply<T: Copy>(v: &mut FieldVec<T>, perm: &[usize]) {
            let nv: FieldVec<T> = perm.iter().map(|&k| v[k]).collect();
            *v = nv;
        }
        apply(&mut self.id, perm);
        apply(&mut self.material, perm);
        self.for_each_f64(|v| apply(v, perm));
    }

    /// Removes every particle.
    pub fn clear(&mut self) {
        self.id.clear();
        self.material.clear();
        self.for_each_f64(|v| v.clear());
    }

    /// Appends all particles of `other`.
    pub fn extend_from(&mut self, other: &Particles) {
        self.id.extend_from_slice(&other.id);
        self.material.extend_from_slice(&other.material);
        let src = other.f64_fields();
        let mut k = 0;
        self.for_each_f64(|v| {
            v.extend_from_slice(src[k]);
            k += 1;
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(n: u64) -> Particles {
        let mut p = Particles::new();
        for i in 0..n {
            p.push(
                &NewParticle {
                    id: i,
                    x: i as f64,
                    y: 2.0 * i as f64,
                    lpx: 0.25,
                    lpy: 0.5,
                    vx: 1.0,
                    vy: -1.0,
                    mass: 3.0,
                    material: (i % 2) as u32,
                },
                2.0,
            );
        }
        p
    }

    #[test]
    fn load_face_codes_round_trip() {
        for kind in [LoadKind::Dead, LoadKind::FollowArea, LoadKind::FollowFace] {
            for ty in -1..=1 {
                for tx in -1..=1 {
                    let c = load_faces_code(ty, tx, kind);
                    assert_eq!(load_faces_of(c), (ty, tx));
                    assert_eq!(c == 0.0, ty == 0 && tx == 0);
                    if c != 0.0 {
                        assert_eq!(load_kind_of(c), kind);
                    }
                }
            }
        }
    }

    #[test]
    fn push_sets_reference_state() {
        let p = sample(3);
        assert_eq!(p.len(), 3);
        assert_eq!(p.vol0[1], 4.0 * 0.25 * 0.5 * 2.0);
        assert_eq!(
            (p.fxx[2], p.fxy[2], p.fyx[2], p.fyy[2]),
            (1.0, 0.0, 0.0, 1.0)
        );
    }

    #[test]
    fn retain_permute_and_copy_keep_fields_together() {
        let mut p = sample(6);
        for i in 0..6 {
            p.eps_p[i] = 0.01 * i as f64;
        }
        p.retain(|i| i % 2 == 0);
        assert_eq!(p.eps_p, vec![0.0, 0.02, 0.04]);
        assert_eq!(p.id, vec![0, 2, 4]);
        assert_eq!(p.y, vec![0.0, 4.0, 8.0]);
        p.permute(&[2, 0, 1]);
        assert_eq!(p.id, vec![4, 0, 2]);
        assert_eq!(p.x, vec![4.0, 0.0, 2.0]);
        let mut q = Particles::new();
        q.push_from(&p, 0);
        q.extend_from(&p);
        assert_eq!(q.id, vec![4, 4, 0, 2]);
        assert_eq!(q.x, vec![4.0, 4.0, 0.0, 2.0]);
        assert_eq!(q.eps_p, vec![0.04, 0.04, 0.0, 0.02]);
        assert_eq!(q.material, vec![0, 0, 0, 0]);
        q.clear();
        assert!(q.is_empty() && q.x.is_empty() && q.fext_y.is_empty());
        let mut bytes = Vec::new();
        p.pack(1, &mut bytes);
        assert_eq!(bytes.len(), Particles::PACKED_BYTES);
        q.push_packed(PackedParticle::new(&bytes));
        let mut r = Particles::new();
        r.push_from(&p, 1);
        assert_eq!(q, r);
        // The reader's named fields are the packed particle's.
        let b = PackedParticle::new(&bytes);
        assert_eq!((b.id(), b.material()), (p.id[1], p.material[1]));
        assert_eq!((b.x(), b.y()), (p.x[1], p.y[1]));
        assert_eq!((b.lpx(), b.lpy()), (p.lpx[1], p.lpy[1]));
        let fields = p.f64_fields();
        for (k, name) in Particles::F64_NAMES.iter().enumerate() {
            assert_eq!(f64_field(name), k);
            assert_eq!(b.f64(k).to_bits(), fields[k][1].to_bits(), "{name}");
        }
        assert_eq!(CopyKind::FromFiner.flag(), COPY_FROM_FINER);
        assert_eq!(CopyKind::FromCoarser.flag(), COPY_FROM_COARSER);
    }

    #[test]
    fn remove_sorted_and_extend_packed_match_retain_and_push_packed() {
        let mut p = sample(11);
        for i in 0..11 {
            p.sxx[i] = -(i as f64);
            p.copy[i] = (i % 3) as f64;
        }
        for gone in [
            vec![],
            vec![0],
            vec![10],
            vec![1, 2, 3, 7],
            vec![0, 5, 9, 10],
        ] {
            let mut a = p.clone();
            a.remove_sorted(&gone);
            let mut b = Particles::new();
            for i in (0..p.len()).filter(|i| !gone.contains(i)) {
                b.push_from(&p, i);
            }
            assert_eq!(a, b, "removing {gone:?}");
        }
        let mut bytes = Vec::new();
        // More than one block of `extend_packed`.
        for i in (0..150).map(|k| (k * 7) % 11) {
            p.pack(i, &mut bytes);
        }
        let recs = bytes
            .chunks_exact(Particles::PACKED_BYTES)
            .map(PackedParticle::new);
        let mut a = sample(2);
        a.extend_packed(recs.clone());
        let mut b = sample(2);
        for r in recs {
            b.push_packed(r);
        }
        assert_eq!(a, b);
    }
}
