//! The kernels' run-time choice between their baseline build and an AVX2 build of the same
//! code. Rust never fuses a multiply and an add, and every kernel that goes through here
//! sums in a fixed order, so both builds give the same result bit for bit: AVX2 only does
//! four values at a time.

/// Whether the CPU has AVX2 (checked once).
#[cfg(target_arch = "x86_64")]
pub(crate) fn avx2() -> bool {
    static HAS: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *HAS.get_or_init(|| std::arch::is_x86_feature_detected!("avx2"))
}

/// Runs `f` compiled for AVX2 when the CPU has it, else in the baseline build; `f`'s
/// argument says which (so that it may call AVX2 intrinsics in the first case). Mark the
/// closure `#[inline(always)]`, and the functions it calls for its work too: only code
/// inlined into the AVX2 twin is compiled for AVX2 (without the mark LLVM left the
/// closures outside it, as a jump to baseline code, seen in the disassembly).
#[inline(always)]
pub(crate) fn dispatch<R>(f: impl FnOnce(bool) -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    if avx2() {
        // SAFETY: the CPU has AVX2 (checked at run time).
        return unsafe { with_avx2(f) };
    }
    f(false)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn with_avx2<R>(f: impl FnOnce(bool) -> R) -> R {
    f(true)
}
