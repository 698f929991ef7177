//! [`Affine`]: an instance's 3×4 transform, as stored (12 f32, row-major), and the few things the
//! top level does with one: move a ray into an instance in f32, check a transform and its stored
//! inverse in f64, and bound a box's image.

use glam::Vec3;

/// A vector in f64 (the core's glam has no f64 types): the few operations the checks need.
pub type D3 = [f64; 3];

#[inline]
fn dot(a: D3, b: D3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline]
fn cross(a: D3, b: D3) -> D3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Words of one stored transform.
pub const AFFINE_WORDS: usize = 12;

/// Tolerance of the inverse check ([`Affine::inverts`]), relative to the magnitude of the
/// products it sums: 2⁻¹⁶, some 500 times the rounding of an f32 inverse computed in f64.
pub const INVERSE_TOLERANCE: f64 = 1.0 / 65536.0;

/// Smallest `|det A| / (|a₀|·|a₁|·|a₂|)` (the determinant of the linear part over Hadamard's
/// bound, the product of its rows' lengths: 1 for a rotation or any scale, 0 for a singular
/// matrix) of a transform the top level accepts: below it the rows are too close to dependent
/// for an f32 inverse to mean anything. Scale-free, so huge and tiny scales pass.
pub const MIN_DET_RATIO: f64 = 1.0e-9;

/// Relative padding of an instance's world box ([`Affine::world_box`]) beyond the exact image of
/// its bottom scene's box, against the rounding of the ray moved into the instance in f32 (a hit
/// found on the moved ray lies a few ULPs of its coordinates off the world ray).
pub const BOX_PADDING: f64 = 1.0 / (1u64 << 20) as f64;

/// `x ↦ A·x + b`, stored as the three rows `(a₀₀ a₀₁ a₀₂ b₀), (a₁₀ …), (a₂₀ …)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Affine(pub [f32; AFFINE_WORDS]);

impl Affine {
    /// The identity.
    pub const IDENTITY: Self = Self([1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0]);

    /// From stored words (f32 bits).
    #[inline]
    pub fn from_words(w: &[u32; AFFINE_WORDS]) -> Self {
        Self(w.map(f32::from_bits))
    }

    /// The stored words.
    #[inline]
    pub fn to_words(&self) -> [u32; AFFINE_WORDS] {
        self.0.map(f32::to_bits)
    }

    /// Whether every entry is finite.
    #[inline]
    pub fn is_finite(&self) -> bool {
        self.0.iter().all(|x| x.is_finite())
    }

    /// `A·v` in f32, each row summed left to right (`(a₀·x + a₁·y) + a₂·z`): a row with one
    /// entry 1 and two 0 gives the component back exactly (bar the sign of a zero).
    #[inline(always)]
    pub fn vector(&self, v: Vec3) -> Vec3 {
        let m = &self.0;
        let row = |r: usize| (m[4 * r] * v.x + m[4 * r + 1] * v.y) + m[4 * r + 2] * v.z;
        Vec3::new(row(0), row(1), row(2))
    }

    /// `A·p + b` in f32: [`Self::vector`] plus the translation, added last, so that a
    /// translation alone is one exact subtraction where the coordinates allow it.
    #[inline(always)]
    pub fn point(&self, p: Vec3) -> Vec3 {
        let m = &self.0;
        self.vector(p) + Vec3::new(m[3], m[7], m[11])
    }

    /// Row `r` of the linear part in f64.
    #[inline]
    fn row64(&self, r: usize) -> D3 {
        let m = &self.0;
        [m[4 * r] as f64, m[4 * r + 1] as f64, m[4 * r + 2] as f64]
    }

    /// The translation in f64.
    #[inline]
    fn translation64(&self) -> D3 {
        let m = &self.0;
        [m[3] as f64, m[7] as f64, m[11] as f64]
    }

    /// `A·p + b` in f64.
    #[inline]
    pub fn point64(&self, p: D3) -> D3 {
        let t = self.translation64();
        core::array::from_fn(|r| dot(self.row64(r), p) + t[r])
    }

    /// The determinant of the linear part, in f64 (exact but for the last rounding: products of
    /// f32 entries).
    pub fn determinant(&self) -> f64 {
        let [r0, r1, r2] = [self.row64(0), self.row64(1), self.row64(2)];
        dot(r0, cross(r1, r2))
    }

    /// Whether the linear part is invertible in a meaningful sense: finite and
    /// `|det A| ≥ MIN_DET_RATIO·|a₀|·|a₁|·|a₂|` ([`MIN_DET_RATIO`]), in f64 (where the products
    /// of f32 entries cannot overflow).
    pub fn is_invertible(&self) -> bool {
        let [r0, r1, r2] = [self.row64(0), self.row64(1), self.row64(2)];
        self.invertible_with(r0, r1, r2, dot(r0, cross(r1, r2)))
    }

    /// [`Self::is_invertible`] given the rows in f64 and the determinant `dot(r0, r1 × r2)`.
    #[inline(always)]
    fn invertible_with(&self, r0: D3, r1: D3, r2: D3, det: f64) -> bool {
        // Squared, so that no square root is needed: f32 entries keep every square finite in f64.
        let bound2 = dot(r0, r0) * dot(r1, r1) * dot(r2, r2);
        self.is_finite() && det * det >= MIN_DET_RATIO * MIN_DET_RATIO * bound2 && bound2 > 0.0
    }

    /// The inverse, computed in f64 (the adjugate over the determinant) and rounded to f32; `None`
    /// unless [`Self::is_invertible`] and the result is finite. What the host stores beside a
    /// transform.
    pub fn inverse(&self) -> Option<Self> {
        let [r0, r1, r2] = [self.row64(0), self.row64(1), self.row64(2)];
        // The inverse's columns are the cross products of the rows over the determinant.
        let c = [cross(r1, r2), cross(r2, r0), cross(r0, r1)];
        let det = dot(r0, c[0]);
        if !self.invertible_with(r0, r1, r2, det) {
            return None;
        }
        let t = self.translation64();
        let mut m = [0.0f32; AFFINE_WORDS];
        for r in 0..3 {
            let row = [c[0][r] / det, c[1][r] / det, c[2][r] / det];
            m[4 * r] = row[0] as f32;
            m[4 * r + 1] = row[1] as f32;
            m[4 * r + 2] = row[2] as f32;
            m[4 * r + 3] = -dot(row, t) as f32;
        }
        let inv = Self(m);
        inv.is_finite().then_some(inv)
    }

    /// Whether `inv` is this transform's inverse within [`INVERSE_TOLERANCE`], checked in f64
    /// entry by entry of `self ∘ inv` against the identity: `|Σₖ aᵢₖ·bₖⱼ − δᵢⱼ| ≤ tol·Σₖ |aᵢₖ·bₖⱼ|`
    /// for the linear parts, and `|Σₖ aᵢₖ·cₖ + dᵢ| ≤ tol·(Σₖ |aᵢₖ·cₖ| + |dᵢ|)` for the
    /// translations (`c` the inverse's, `d` this one's). Relative to the products' own magnitude,
    /// so any scale, huge or tiny, is judged alike; an inverse of the wrong matrix, or of a
    /// different translation, is off by far more.
    pub fn inverts(&self, inv: &Affine) -> bool {
        let (a, b) = (&self.0, &inv.0);
        let f = |x: f32| x as f64;
        for i in 0..3 {
            for j in 0..4 {
                let mut sum = if j == 3 { f(a[4 * i + 3]) } else { 0.0 };
                let mut mag = sum.abs();
                for k in 0..3 {
                    let p = f(a[4 * i + k]) * f(b[4 * k + j]);
                    sum += p;
                    mag += p.abs();
                }
                let want = if i == j { 1.0 } else { 0.0 };
                if !((sum - want).abs() <= INVERSE_TOLERANCE * mag.max(want)) {
                    return false;
                }
            }
        }
        true
    }

    /// The eight corners of `bounds` mapped exactly enough in f64 ([`Self::point64`]).
    pub fn corners64(&self, bounds: [Vec3; 2]) -> [D3; 8] {
        core::array::from_fn(|i| {
            let pick = |axis: usize| bounds[(i >> axis) & 1][axis] as f64;
            self.point64([pick(0), pick(1), pick(2)])
        })
    }

    /// The world box the host stores for an instance of a bottom scene with box `bounds`: the
    /// least and greatest of the corners' images in f64 ([`Self::corners64`]), grown by
    /// [`BOX_PADDING`] of their largest magnitude and extent, rounded outward to f32. `None` if
    /// it is not finite in f32.
    ///
    /// Computed per row without the eight corners (Arvo 1990, "Transforming axis-aligned
    /// bounding boxes"): the least image on row `r` takes, term by term, the lesser of
    /// `a_rj·lo_j` and `a_rj·hi_j` and sums them in [`Self::point64`]'s order. That is the
    /// image of one corner, bit for bit, and no corner's is less, since every term of another
    /// corner is at least as large and rounded addition is monotone; likewise the greatest. So
    /// the box is the corners' exactly, for a third of the arithmetic.
    pub fn world_box(&self, bounds: [Vec3; 2]) -> Option<[Vec3; 2]> {
        let (b0, b1) = (bounds[0].to_array(), bounds[1].to_array());
        let t = self.translation64();
        let (mut lo, mut hi) = ([0.0f64; 3], [0.0f64; 3]);
        for r in 0..3 {
            let a = self.row64(r);
            let terms: [(f64, f64); 3] = core::array::from_fn(|j| {
                let (p, q) = (a[j] * b0[j] as f64, a[j] * b1[j] as f64);
                if p <= q { (p, q) } else { (q, p) }
            });
            lo[r] = terms[0].0 + terms[1].0 + terms[2].0 + t[r];
            hi[r] = terms[0].1 + terms[1].1 + terms[2].1 + t[r];
        }
        padded_box(lo, hi)
    }

    /// Whether `world` contains the image of `bounds` ([`Self::corners64`], compared in f64):
    /// what validation asks of a stored instance box.
    pub fn box_contains_image(&self, world: [Vec3; 2], bounds: [Vec3; 2]) -> bool {
        self.corners64(bounds)
            .iter()
            .all(|c| (0..3).all(|a| c[a] >= world[0][a] as f64 && c[a] <= world[1][a] as f64))
    }
}

/// The f32 box the host stores for the f64 box `lo`..`hi` (an instance's image,
/// [`Affine::world_box`]): grown by [`BOX_PADDING`] of its largest magnitude and extent, then
/// rounded outward. `None` if it is not finite in f32.
pub fn padded_box(lo: D3, hi: D3) -> Option<[Vec3; 2]> {
    let size = (0..3).fold(0.0f64, |m, a| {
        m.max(lo[a].abs()).max(hi[a].abs()).max(hi[a] - lo[a])
    });
    let pad = BOX_PADDING * size;
    let down = |x: f64| {
        let y = x as f32;
        if y as f64 > x { y.next_down() } else { y }
    };
    let up = |x: f64| {
        let y = x as f32;
        if (y as f64) < x { y.next_up() } else { y }
    };
    let b = [
        Vec3::from_array(lo.map(|x| down(x - pad))),
        Vec3::from_array(hi.map(|x| up(x + pad))),
    ];
    (b[0].is_finite() && b[1].is_finite()).then_some(b)
}
