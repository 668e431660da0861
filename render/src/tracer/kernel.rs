//! The integrator's kernels: one monomorphized copy per combination of optional code groups.
//!
//! The integrator and the tile loop are generic over an [`EffectSet`] whose associated consts
//! are [`KernelBits`]; `dispatch_kernel!` instantiates one kernel per bit combination. Code for
//! an absent group sits behind `if E::GLASS { … }` with a constant condition, so the compiler
//! removes it from that kernel. Which kernel a scene needs is decided from its effects
//! ([`crate::tracer::effects`]); this module sits below lights, materials and the effect
//! analysis, which all use it.

/// Which groups of optional code a kernel contains.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct KernelBits(pub u8);

impl KernelBits {
    /// GGX and Phong BSDFs, texture lookups (every slot, emissive textures in light samples
    /// too) and normal maps (without it: Lambert with constant albedo, flat emission).
    pub const SURFACES: u8 = 1 << 0;
    /// Transmission through dielectrics and Beer–Lambert absorption inside them.
    pub const GLASS: u8 = 1 << 1;
    /// Alpha-tested geometry (closest-hit and shadow rays skip cut-out hits).
    pub const ALPHA: u8 = 1 << 2;
    /// Thin-lens camera rays.
    pub const DOF: u8 = 1 << 3;
    /// The kernel with every effect compiled in.
    pub const ALL: KernelBits = KernelBits(0b1111);
    /// The kernel for Lambert surfaces and lights only.
    pub const MATTE: KernelBits = KernelBits(0);
}

/// The effect groups compiled into a kernel, as constants.
pub trait EffectSet: Send + Sync + 'static {
    const SURFACES: bool;
    const GLASS: bool;
    const ALPHA: bool;
    const DOF: bool;
}

/// The kernel for one combination of [`KernelBits`].
pub struct Kernel<const B: u8>;

impl<const B: u8> EffectSet for Kernel<B> {
    const SURFACES: bool = B & KernelBits::SURFACES != 0;
    const GLASS: bool = B & KernelBits::GLASS != 0;
    const ALPHA: bool = B & KernelBits::ALPHA != 0;
    const DOF: bool = B & KernelBits::DOF != 0;
}

/// Every effect compiled in (tests, and the "forced on" comparison).
pub type AllEffects = Kernel<0b1111>;

/// `dispatch_kernel!(bits, f(args…))` calls `f::<Kernel<bits>>(args…)`, one arm per kernel.
#[macro_export]
macro_rules! dispatch_kernel {
    ($bits:expr, $f:ident ( $($arg:expr),* $(,)? )) => {{
        use $crate::tracer::kernel::Kernel;
        match $bits.0 & 0b1111 {
            0 => $f::<Kernel<0>>($($arg),*),
            1 => $f::<Kernel<1>>($($arg),*),
            2 => $f::<Kernel<2>>($($arg),*),
            3 => $f::<Kernel<3>>($($arg),*),
            4 => $f::<Kernel<4>>($($arg),*),
            5 => $f::<Kernel<5>>($($arg),*),
            6 => $f::<Kernel<6>>($($arg),*),
            7 => $f::<Kernel<7>>($($arg),*),
            8 => $f::<Kernel<8>>($($arg),*),
            9 => $f::<Kernel<9>>($($arg),*),
            10 => $f::<Kernel<10>>($($arg),*),
            11 => $f::<Kernel<11>>($($arg),*),
            12 => $f::<Kernel<12>>($($arg),*),
            13 => $f::<Kernel<13>>($($arg),*),
            14 => $f::<Kernel<14>>($($arg),*),
            _ => $f::<Kernel<15>>($($arg),*),
        }
    }};
}
