//! Pieces shared by the rendering examples `lens_eval` and `render_set` (not an example itself:
//! Cargo builds only `examples/*.rs` and `examples/*/main.rs`).

use board_detect::synth::{Lens, Scene};

/// SplitMix64 uniform numbers: small, deterministic and the same on every platform, so a
/// population or a calibration set is reproduced from its seed.
pub struct Rng(pub u64);

impl Rng {
    /// Uniform in `[0, 1)`.
    pub fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in `[a, b)`.
    pub fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.next()
    }
}

/// Normalized radius of the fisheye ray at angle `theta` (radians) off the axis for a
/// Kannala-Brandt lens; `f64::MAX` for other lenses.
pub fn kb_radius(scene: &Scene, theta: f64) -> f64 {
    let Lens::KannalaBrandt(k) = scene.lens else {
        return f64::MAX;
    };
    let t = theta * theta;
    theta * (1.0 + t * (k[0] + t * (k[1] + t * (k[2] + t * k[3]))))
}
