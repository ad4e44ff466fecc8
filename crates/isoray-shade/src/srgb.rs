//! sRGB encoding: colours are linear inside every renderer and encoded
//! once, at output (IEC 61966-2-1).

/// The sRGB transfer function of a linear value clamped to [0, 1]:
/// 12.92·x for x ≤ 0.0031308, else 1.055·x^(1/2.4) − 0.055.
pub fn linear_to_srgb(x: f32) -> f32 {
    let x = x.clamp(0.0, 1.0);
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// One linear value as an 8-bit sRGB code: ⌊255·[`linear_to_srgb`]`(x)` + ½⌋.
pub fn srgb8(x: f32) -> u8 {
    (linear_to_srgb(x) * 255.0 + 0.5) as u8
}

/// Linear RGB pixels to 8-bit sRGB bytes, three per pixel ([`srgb8`]).
pub fn to_srgb8(rgb: &[[f32; 3]]) -> Vec<u8> {
    rgb.iter().flat_map(|c| c.map(srgb8)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_known_values() {
        assert_eq!(linear_to_srgb(0.0), 0.0);
        assert!((linear_to_srgb(1.0) - 1.0).abs() < 1e-6);
        // 0.5 linear is 1.055·0.5^(1/2.4) − 0.055 = 0.73536 in sRGB (188 in 8 bits).
        assert!((linear_to_srgb(0.5) - 0.735_357).abs() < 1e-5);
        assert_eq!(to_srgb8(&[[0.5, 0.0, 1.0]]), vec![188, 0, 255]);
        // Out of range values are clamped.
        assert_eq!(linear_to_srgb(-1.0), 0.0);
        assert_eq!(linear_to_srgb(2.0), linear_to_srgb(1.0));
        assert_eq!(srgb8(f32::INFINITY), 255);
    }

    #[test]
    fn the_linear_segment_below_the_knee() {
        for x in [1e-6f32, 1e-4, 0.001, 0.003] {
            assert_eq!(linear_to_srgb(x), 12.92 * x);
        }
        // The two pieces meet at the knee 0.0031308 (0.04045 encoded).
        let knee = 0.003_130_8f32;
        assert!((linear_to_srgb(knee) - 0.040_45).abs() < 1e-5);
        let above = linear_to_srgb(knee * 1.0001);
        assert!((above - linear_to_srgb(knee)).abs() < 1e-5, "{above}");
        // 1 in 8 bits is 1/255 encoded: linear 0.000304.
        assert_eq!(srgb8(0.000_304), 1);
        assert_eq!(srgb8(0.000_1), 0);
    }
}
