//! The lane trait the packet kernels are written against, its three implementations
//! ([`f32x4`], [`f32x8`], [`f32x16`]), and [`Vec3x`], a struct-of-arrays 3-vector of lanes.
//!
//! # Masks
//! As in `wide`, a mask is a value of the lane type itself whose lanes are all ones (true) or all
//! zeros (false); comparisons return one, [`Lanes::select`] consumes one, and `&`, `|`, `!` combine
//! them. Comparisons follow IEEE 754: a comparison with a NaN operand is false, except
//! [`Lanes::ne`], which is true, as `!=` is.
//!
//! # Exactness
//! Every operation the kernels use rounds exactly as the scalar `f32` operation does: `+ − × ÷`
//! and comparisons are IEEE on every `wide` backend, [`Lanes::recip`] is a true division (never
//! the ~12-bit `rcpps` estimate), and [`Lanes::sqrt`] is correctly rounded on every backend (the
//! portable fallback calls `libm::sqrtf`, the function [`crate::math::sqrt`] uses). Only
//! [`Lanes::mul_add`] may round differently from `a * b + c`: it fuses where the build has FMA.

use crate::ray::Ray;
use core::fmt::Debug;
use core::ops::{Add, BitAnd, BitOr, BitXor, Div, Mul, Neg, Not, Sub};
use glam::Vec3;
use wide::{f32x4, f32x8, f32x16, u32x4, u32x8, u32x16};

/// `W` `f32` lanes, and `W` `u32` lanes for primitive indices. Implemented for [`f32x4`],
/// [`f32x8`] and [`f32x16`]; kernels are written once, generic over it.
pub trait Lanes:
    Copy
    + Debug
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + BitAnd<Output = Self>
    + BitOr<Output = Self>
    + BitXor<Output = Self>
    + Not<Output = Self>
{
    /// The number of lanes `W`.
    const WIDTH: usize;
    /// `[f32; W]`.
    type Array: Copy + Debug + AsRef<[f32]> + AsMut<[f32]>;
    /// `W` lanes of `u32` (primitive indices).
    type Index: Copy + Debug;
    /// `[u32; W]`.
    type IndexArray: Copy + Debug + AsRef<[u32]> + AsMut<[u32]>;

    /// Every lane `x`.
    fn splat(x: f32) -> Self;
    /// Lane `i` is `a[i]`.
    fn from_array(a: Self::Array) -> Self;
    /// The lanes as an array.
    fn to_array(self) -> Self::Array;
    /// Lane `i` is `f(i)`.
    fn from_fn(f: impl FnMut(usize) -> f32) -> Self;

    /// `self * a + b`, fused (one rounding) where the build has FMA, else two roundings: results
    /// depend on the build, so the kernels that must match the scalar reference do not use it.
    fn mul_add(self, a: Self, b: Self) -> Self;
    /// `1 / self` by true division: exact IEEE rounding, `±inf` for `±0`.
    fn recip(self) -> Self;
    /// Correctly rounded square root (NaN for negative lanes).
    fn sqrt(self) -> Self;
    /// Clears the sign bit.
    fn abs(self) -> Self;
    /// Lanewise minimum; where one operand is NaN, the other (IEEE `minNum`), on every backend.
    fn min(self, rhs: Self) -> Self;
    /// Lanewise maximum; where one operand is NaN, the other (IEEE `maxNum`), on every backend.
    fn max(self, rhs: Self) -> Self;

    /// Mask of `self < rhs`.
    fn lt(self, rhs: Self) -> Self;
    /// Mask of `self <= rhs`.
    fn le(self, rhs: Self) -> Self;
    /// Mask of `self > rhs`.
    fn gt(self, rhs: Self) -> Self;
    /// Mask of `self >= rhs`.
    fn ge(self, rhs: Self) -> Self;
    /// Mask of `self == rhs`.
    fn eq(self, rhs: Self) -> Self;
    /// Mask of `self != rhs` (true where either is NaN).
    fn ne(self, rhs: Self) -> Self;
    /// Mask of NaN lanes.
    fn is_nan(self) -> Self;
    /// Mask of finite lanes (neither infinite nor NaN).
    fn is_finite(self) -> Self;

    /// With `self` a mask: `if_true` where it is set, else `if_false`.
    fn select(self, if_true: Self, if_false: Self) -> Self;
    /// With `self` a mask: bit `i` is lane `i`.
    fn bitmask(self) -> u32;
    /// The mask whose lane `i` is bit `i` of `bits` (bits at or above `W` are ignored).
    fn mask_from_bits(bits: u32) -> Self;
    /// With `self` a mask: true if any lane is set.
    fn any(self) -> bool;
    /// With `self` a mask: true if every lane is set.
    fn all(self) -> bool;
    /// With `self` a mask: true if no lane is set.
    #[inline]
    fn none(self) -> bool {
        !self.any()
    }

    /// Every index lane `i`.
    fn splat_index(i: u32) -> Self::Index;
    /// The index lanes as an array.
    fn index_to_array(i: Self::Index) -> Self::IndexArray;
    /// The rays `rays[..W]` as eight columns, `[ox, oy, oz, dx, dy, dz, tmin, tmax]`, lane `i` of
    /// each from ray `i` (a register transpose); `None` when `rays` holds fewer than `W`.
    fn ray_columns(rays: &[Ray]) -> Option<[Self; 8]>;
    /// With `self` a mask: `if_true` where it is set, else `if_false`.
    fn select_index(self, if_true: Self::Index, if_false: Self::Index) -> Self::Index;
}

/// One implementation for every width: they differ only in names and `W`.
macro_rules! impl_lanes {
    ($f:ident, $u:ident, $w:literal, $columns:ident) => {
        impl Lanes for $f {
            const WIDTH: usize = $w;
            type Array = [f32; $w];
            type Index = $u;
            type IndexArray = [u32; $w];

            #[inline]
            fn splat(x: f32) -> Self {
                $f::splat(x)
            }
            #[inline]
            fn from_array(a: Self::Array) -> Self {
                $f::new(a)
            }
            #[inline]
            fn to_array(self) -> Self::Array {
                $f::to_array(self)
            }
            #[inline]
            fn from_fn(f: impl FnMut(usize) -> f32) -> Self {
                $f::new(core::array::from_fn(f))
            }

            #[inline]
            fn mul_add(self, a: Self, b: Self) -> Self {
                $f::mul_add(self, a, b)
            }
            #[inline]
            fn recip(self) -> Self {
                // Not `wide`'s `recip`: on SSE/AVX that is the `rcpps` estimate (12 bits).
                $f::splat(1.0) / self
            }
            #[inline]
            fn sqrt(self) -> Self {
                // `wide`'s own `sqrt` is the hardware instruction (correctly rounded) on these
                // backends; its portable fallback is a software routine, so there use the same
                // `libm::sqrtf` the scalar kernels use, lane by lane.
                if cfg!(any(
                    target_feature = "sse",
                    target_feature = "simd128",
                    all(target_feature = "neon", target_arch = "aarch64")
                )) {
                    $f::sqrt(self)
                } else {
                    $f::new(self.to_array().map(crate::math::sqrt))
                }
            }
            #[inline]
            fn abs(self) -> Self {
                $f::abs(self)
            }
            #[inline]
            fn min(self, rhs: Self) -> Self {
                $f::min(self, rhs)
            }
            #[inline]
            fn max(self, rhs: Self) -> Self {
                $f::max(self, rhs)
            }

            #[inline]
            fn lt(self, rhs: Self) -> Self {
                self.simd_lt(rhs)
            }
            #[inline]
            fn le(self, rhs: Self) -> Self {
                self.simd_le(rhs)
            }
            #[inline]
            fn gt(self, rhs: Self) -> Self {
                self.simd_gt(rhs)
            }
            #[inline]
            fn ge(self, rhs: Self) -> Self {
                self.simd_ge(rhs)
            }
            #[inline]
            fn eq(self, rhs: Self) -> Self {
                self.simd_eq(rhs)
            }
            #[inline]
            fn ne(self, rhs: Self) -> Self {
                self.simd_ne(rhs)
            }
            #[inline]
            fn is_nan(self) -> Self {
                $f::is_nan(self)
            }
            #[inline]
            fn is_finite(self) -> Self {
                $f::is_finite(self)
            }

            #[inline]
            fn select(self, if_true: Self, if_false: Self) -> Self {
                $f::select(self, if_true, if_false)
            }
            #[inline]
            fn bitmask(self) -> u32 {
                self.to_bitmask()
            }
            #[inline]
            fn mask_from_bits(bits: u32) -> Self {
                let all = f32::from_bits(u32::MAX);
                $f::new(core::array::from_fn(|i| {
                    if bits >> i & 1 != 0 { all } else { 0.0 }
                }))
            }
            #[inline]
            fn any(self) -> bool {
                $f::any(self)
            }
            #[inline]
            fn all(self) -> bool {
                $f::all(self)
            }

            #[inline(always)]
            fn ray_columns(rays: &[Ray]) -> Option<[Self; 8]> {
                Some($columns(rays.first_chunk::<$w>()?))
            }
            #[inline]
            fn splat_index(i: u32) -> Self::Index {
                $u::splat(i)
            }
            #[inline]
            fn index_to_array(i: Self::Index) -> Self::IndexArray {
                i.to_array()
            }
            #[inline]
            fn select_index(self, if_true: Self::Index, if_false: Self::Index) -> Self::Index {
                let mask: $u = bytemuck::cast(self);
                mask.select(if_true, if_false)
            }
        }
    };
}

impl_lanes!(f32x4, u32x4, 4, columns4);
impl_lanes!(f32x8, u32x8, 8, columns8);
impl_lanes!(f32x16, u32x16, 16, columns16);

/// A ray's eight floats in the order of [`Lanes::ray_columns`].
#[inline(always)]
fn ray_row(r: &Ray) -> [f32; 8] {
    let (o, d) = (r.origin, r.dir);
    [o.x, o.y, o.z, d.x, d.y, d.z, r.tmin, r.tmax]
}

/// Eight rays, one per row of an 8×8 matrix, transposed into columns.
#[inline(always)]
fn columns8(rays: &[Ray; 8]) -> [f32x8; 8] {
    f32x8::transpose(rays.each_ref().map(|r| f32x8::new(ray_row(r))))
}

/// Sixteen rays: two 8×8 transposes, of the first and the last eight rays, side by side.
#[inline(always)]
fn columns16(rays: &[Ray; 16]) -> [f32x16; 8] {
    let half =
        |at: usize| f32x8::transpose(core::array::from_fn(|i| f32x8::new(ray_row(&rays[at + i]))));
    let (a, b) = (half(0), half(8));
    core::array::from_fn(|k| {
        let (a, b) = (a[k].to_array(), b[k].to_array());
        f32x16::new(core::array::from_fn(
            |i| if i < 8 { a[i] } else { b[i - 8] },
        ))
    })
}

/// Four rays: two 4×4 transposes, of their first and last four floats.
#[inline(always)]
fn columns4(rays: &[Ray; 4]) -> [f32x4; 8] {
    let rows = rays.each_ref().map(ray_row);
    let lo = f32x4::transpose(rows.map(|r| f32x4::new([r[0], r[1], r[2], r[3]])));
    let hi = f32x4::transpose(rows.map(|r| f32x4::new([r[4], r[5], r[6], r[7]])));
    [lo[0], lo[1], lo[2], lo[3], hi[0], hi[1], hi[2], hi[3]]
}

/// A 3-vector of lanes, struct-of-arrays: lane `i` of `x`, `y`, `z` is vector `i`.
///
/// [`dot`](Self::dot) and [`cross`](Self::cross) evaluate in exactly the order of glam's `Vec3`
/// (`(x·x' + y·y') + z·z'`; `y·z' − y'·z`, …), so each lane rounds as the scalar reference does.
#[derive(Clone, Copy, Debug)]
pub struct Vec3x<L> {
    pub x: L,
    pub y: L,
    pub z: L,
}

impl<L: Lanes> Vec3x<L> {
    /// Every lane `v`.
    #[inline]
    pub fn splat(v: Vec3) -> Self {
        Self {
            x: L::splat(v.x),
            y: L::splat(v.y),
            z: L::splat(v.z),
        }
    }

    /// Lane `i` is `f(i)`.
    #[inline]
    pub fn from_fn(mut f: impl FnMut(usize) -> Vec3) -> Self {
        Self {
            x: L::from_fn(|i| f(i).x),
            y: L::from_fn(|i| f(i).y),
            z: L::from_fn(|i| f(i).z),
        }
    }

    /// Vector `i` (lane `i` of each component).
    ///
    /// # Panics
    /// If `i >= W`.
    #[inline]
    pub fn lane(&self, i: usize) -> Vec3 {
        Vec3::new(
            self.x.to_array().as_ref()[i],
            self.y.to_array().as_ref()[i],
            self.z.to_array().as_ref()[i],
        )
    }

    /// The dot product, `(x·x' + y·y') + z·z'` as glam's `Vec3::dot`.
    #[inline]
    pub fn dot(self, rhs: Self) -> L {
        self.x * rhs.x + self.y * rhs.y + self.z * rhs.z
    }

    /// The cross product, in glam's `Vec3::cross` order.
    #[inline]
    pub fn cross(self, rhs: Self) -> Self {
        Self {
            x: self.y * rhs.z - rhs.y * self.z,
            y: self.z * rhs.x - rhs.z * self.x,
            z: self.x * rhs.y - rhs.x * self.y,
        }
    }

    /// Each component times `s`.
    #[inline]
    pub fn scale(self, s: L) -> Self {
        Self {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }

    /// Componentwise `1 / self` by true division ([`Lanes::recip`]).
    #[inline]
    pub fn recip(self) -> Self {
        Self {
            x: self.x.recip(),
            y: self.y.recip(),
            z: self.z.recip(),
        }
    }

    /// With `mask` a mask: `if_true`'s vectors where it is set, else `if_false`'s.
    #[inline]
    pub fn select(mask: L, if_true: Self, if_false: Self) -> Self {
        Self {
            x: mask.select(if_true.x, if_false.x),
            y: mask.select(if_true.y, if_false.y),
            z: mask.select(if_true.z, if_false.z),
        }
    }

    /// Mask of lanes whose three components are all finite.
    #[inline]
    pub fn is_finite(self) -> L {
        self.x.is_finite() & self.y.is_finite() & self.z.is_finite()
    }
}

impl<L: Lanes> Add for Vec3x<L> {
    type Output = Self;
    #[inline]
    fn add(self, rhs: Self) -> Self {
        Self {
            x: self.x + rhs.x,
            y: self.y + rhs.y,
            z: self.z + rhs.z,
        }
    }
}

impl<L: Lanes> Sub for Vec3x<L> {
    type Output = Self;
    #[inline]
    fn sub(self, rhs: Self) -> Self {
        Self {
            x: self.x - rhs.x,
            y: self.y - rhs.y,
            z: self.z - rhs.z,
        }
    }
}

/// The indices of the set bits of a lane bitmask ([`Lanes::bitmask`]), lowest first.
#[inline]
pub(crate) fn set_lanes(mut mask: u32) -> impl Iterator<Item = usize> {
    core::iter::from_fn(move || {
        let i = mask.trailing_zeros();
        mask &= mask.wrapping_sub(1);
        (i < 32).then_some(i as usize)
    })
}
