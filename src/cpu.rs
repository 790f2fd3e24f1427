//! What the CPU can do, asked once when a structure is built: hot loops compiled a second time
//! for AVX2 + FMA (ray traversal, light-tree descent) are chosen at run time by this answer, so
//! one binary runs on any x86-64.

/// Whether the CPU has AVX2 and FMA, and POPCNT (which every such CPU has; the light tree's
/// descent counts a node's interior lanes with it).
#[cfg(target_arch = "x86_64")]
pub fn has_avx2_fma() -> bool {
    is_x86_feature_detected!("avx2")
        && is_x86_feature_detected!("fma")
        && is_x86_feature_detected!("popcnt")
}

/// Whether the CPU has AVX2 and FMA (never, off x86-64).
#[cfg(not(target_arch = "x86_64"))]
pub fn has_avx2_fma() -> bool {
    false
}
