//! What a model author needs to write a fast structured kernel of their own (the INS
//! model's covariance propagation is one): [`fma_kernel!`](crate::fma_kernel), which
//! compiles one kernel body for AVX2/FMA (and optionally AVX-512VL) with a portable twin
//! and picks the path at run time, and the fused multiply-add helpers such a body uses.
//!
//! A kernel body is an `#[inline(always)]` function generic over a trailing
//! `const FMA: bool`; it writes its multiply-adds with [`madd`] / [`nmadd`], which are one
//! instruction on the fused path and multiply-then-add on the portable one (where
//! `f64::mul_add` would be a slow library call).
//!
//! ```
//! use estimator_core::fma_kernel;
//! use estimator_core::simd::madd;
//!
//! fma_kernel! {
//!     /// `Σ aᵢ bᵢ`.
//!     pub fn dot(a: &[f64], b: &[f64]) -> f64 = dot_body / dot_avx2 / dot_portable
//! }
//!
//! #[inline(always)]
//! fn dot_body<const FMA: bool>(a: &[f64], b: &[f64]) -> f64 {
//!     a.iter().zip(b).fold(0.0, |acc, (x, y)| madd::<FMA>(*x, *y, acc))
//! }
//!
//! let (a, b) = ([1.0, 2.0, 3.0], [4.0, 5.0, 6.0]);
//! assert_eq!(dot(&a, &b), 32.0);
//! assert_eq!(dot_portable(&a, &b), dot_avx2(&a, &b)); // exact here: small integers
//! ```

// without `std`, `mul_add` is nalgebra's (libm)
#[cfg(not(feature = "std"))]
use nalgebra::ComplexField as _;

/// Whether this CPU has AVX2 and FMA (cached by the standard library); always false off
/// x86-64 and without the standard library.
#[inline(always)]
pub fn has_avx2_fma() -> bool {
    #[cfg(all(target_arch = "x86_64", feature = "std"))]
    {
        std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma")
    }
    #[cfg(not(all(target_arch = "x86_64", feature = "std")))]
    {
        false
    }
}

/// Whether this CPU also has AVX-512F and AVX-512VL, which give the 256-bit code of the
/// AVX2 path 32 vector registers instead of 16 and broadcasts folded into the
/// multiply-adds; always false off x86-64.
#[inline(always)]
pub fn has_avx512vl() -> bool {
    #[cfg(all(target_arch = "x86_64", feature = "std"))]
    {
        has_avx2_fma()
            && std::is_x86_feature_detected!("avx512f")
            && std::is_x86_feature_detected!("avx512vl")
    }
    #[cfg(not(all(target_arch = "x86_64", feature = "std")))]
    {
        false
    }
}

/// Defines a kernel from an `#[inline(always)]` body generic over a trailing
/// `const FMA: bool`, as three public functions:
/// - the kernel itself, which runs the fastest path this CPU has;
/// - the AVX2 path (`$fast`): the body with `FMA = true` compiled inside an AVX2+FMA
///   `#[target_feature]` wrapper when the CPU has those instructions (checked once and
///   cached, see [`has_avx2_fma`]), the portable path otherwise;
/// - the portable path (`$portable`): the body with `FMA = false`, what CPUs without those
///   instructions run.
///
/// With `+ avx512 (condition)`, CPUs with AVX-512F and AVX-512VL ([`has_avx512vl`]) run
/// the same body compiled with those features too when the condition (an expression of
/// the kernel's type parameters, such as `N::DIM <= 24`) holds: for kernels whose sums
/// outgrow 16 registers at the sizes where that was measured to pay. The multiply-adds
/// are the same, one by one and in the same order, so the two fused paths agree to
/// rounding. Tests compare each path with the portable one.
///
/// See the [module docs](crate::simd) for a compiling example.
#[macro_export]
macro_rules! fma_kernel {
    (
        $(#[$meta:meta])*
        $vis:vis fn $name:ident $(<$($g:ident : $b:path),*>)? ($($a:ident : $t:ty),* $(,)?)
            $(-> $r:ty)? = $body:ident / $fast:ident / $portable:ident
            $(+ avx512 ($wide:expr))?
        $(where $($w:tt)*)?
    ) => {
        $crate::fma_kernel! { @paths (false $(|| $wide)?), $(#[$meta])* $vis fn $name
            $(<$($g : $b),*>)? ($($a : $t),*) $(-> $r)? = $body / $fast / $portable
            $(where $($w)*)? }
    };
    (
        @paths ($wide:expr),
        $(#[$meta:meta])*
        $vis:vis fn $name:ident $(<$($g:ident : $b:path),*>)? ($($a:ident : $t:ty),* $(,)?)
            $(-> $r:ty)? = $body:ident / $fast:ident / $portable:ident
        $(where $($w:tt)*)?
    ) => {
        $(#[$meta])*
        $vis fn $name $(<$($g: $b),*>)? ($($a: $t),*) $(-> $r)? $(where $($w)*)? {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx2,fma,avx512f,avx512vl")]
                unsafe fn wide $(<$($g: $b),*>)? ($($a: $t),*) $(-> $r)?
                $(where $($w)*)? {
                    $body::<$($($g,)*)? true>($($a),*)
                }
                if $wide && $crate::simd::has_avx512vl() {
                    // SAFETY: the CPU has AVX2, FMA, AVX-512F and AVX-512VL (checked just
                    // above).
                    return unsafe { wide $(::<$($g),*>)? ($($a),*) };
                }
            }
            $fast $(::<$($g),*>)? ($($a),*)
        }

        #[doc = concat!("[`", stringify!($name), "`] on its AVX2/FMA path (the portable one ")]
        #[doc = "on CPUs without those instructions)."]
        #[allow(dead_code)] // the twins are for tests that compare paths
        $vis fn $fast $(<$($g: $b),*>)? ($($a: $t),*) $(-> $r)? $(where $($w)*)? {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx2,fma")]
                unsafe fn fused $(<$($g: $b),*>)? ($($a: $t),*) $(-> $r)?
                $(where $($w)*)? {
                    $body::<$($($g,)*)? true>($($a),*)
                }
                if $crate::simd::has_avx2_fma() {
                    // SAFETY: the CPU has AVX2 and FMA (checked just above).
                    return unsafe { fused $(::<$($g),*>)? ($($a),*) };
                }
            }
            $body::<$($($g,)*)? false>($($a),*)
        }

        #[doc = concat!("[`", stringify!($name), "`] without the AVX2/FMA path.")]
        #[allow(dead_code)]
        $vis fn $portable $(<$($g: $b),*>)? ($($a: $t),*) $(-> $r)? $(where $($w)*)? {
            $body::<$($($g,)*)? false>($($a),*)
        }
    };
}

/// `a·x + acc`, fused when `FMA`.
#[inline(always)]
pub fn madd<const FMA: bool>(x: f64, a: f64, acc: f64) -> f64 {
    if FMA {
        x.mul_add(a, acc)
    } else {
        acc + x * a
    }
}

/// `acc − a·x`, fused when `FMA` (one instruction: the negation folds into it).
#[inline(always)]
pub fn nmadd<const FMA: bool>(x: f64, a: f64, acc: f64) -> f64 {
    if FMA {
        (-x).mul_add(a, acc)
    } else {
        acc - x * a
    }
}
