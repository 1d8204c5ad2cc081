//! How lane code is compiled and entered: the block size, the one list of
//! SIMD targets, and the stack-frame alignment every entry point starts
//! with.
//!
//! A lane function is compiled once per target in `multiversioned!` and
//! the best the CPU supports is chosen at run time (no
//! `-C target-cpu=native`). The entry points are the block functions of the
//! engine, the statistics pass and the moments' masked sums; each is a thin
//! `multiversioned!` wrapper whose body calls `#[inline(always)]` lane code,
//! which is then compiled for the wrapper's target.
//!
//! multiversion 0.9 picks its AVX-512 version only on CPUs with Ice Lake's
//! AVX-512 set, so Skylake-era AVX-512 (and its clock penalty) takes the
//! AVX2+FMA version; results are the same on every target.

use crate::lanes::X16;

/// Samples per SoA block: the kernel's unit of vectorised work (a multiple
/// of 16). Chosen by measurement, end to end on Zen 4 (2026-11-24): 256
/// made S3 f64 14 % slower (its blocks hold about 640 bytes per lane) and
/// 128 made f32 about 3 % slower; 192 is within noise of the best for S1
/// and S3 in both precisions.
pub const BLOCK: usize = 192;

/// Compiles each function it wraps for AVX-512, AVX2+FMA and the baseline
/// x86-64, dispatching at run time. The one place the target list is
/// written.
macro_rules! multiversioned {
    ($($item:item)*) => {
        $(
            #[multiversion::multiversion(targets(
                "x86_64+avx512f+avx512bw+avx512cd+avx512dq+avx512vl+avx2+fma",
                "x86_64+avx2+fma",
            ))]
            $item
        )*
    };
}
pub(crate) use multiversioned;

/// Makes the calling function's stack frame 64-byte aligned (an inlined
/// cache-line-aligned local forces LLVM to realign it), so the register
/// spills of a large lane kernel are aligned and never straddle cache
/// lines. Without it a kernel's speed depended on its caller's stack depth,
/// by up to 6 %.
#[inline(always)]
pub fn align_frame() {
    let mut line = X16([0u32; 16]);
    std::hint::black_box(&mut line);
}
