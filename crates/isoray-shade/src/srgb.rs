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
///
/// Looked up, not computed: the code is the number of codes whose least
/// linear value ([`Codes`]) is at most `x`, found from a bucket of the
/// unit interval in a step or two. The same byte as the formula for every
/// `x` (the formula is monotonic; the tests compare both around every
/// code's threshold), five to ten times faster than its `powf`, which
/// matters for the serial tail of a render: a 1280×720 image is 2.8 million
/// conversions.
pub fn srgb8(x: f32) -> u8 {
    Codes::get().code(x)
}

/// The formula [`srgb8`] looks up.
fn srgb8_formula(x: f32) -> u8 {
    (linear_to_srgb(x) * 255.0 + 0.5) as u8
}

/// Buckets of the unit interval the lookup starts from.
const BUCKETS: usize = 4096;

/// The least linear value of each 8-bit code, and the code of each
/// bucket's start.
struct Codes {
    /// `start[k]`: the least x with code k + 1 (k < 255).
    start: [f32; 255],
    /// The code of the least value of each bucket [i/B, (i+1)/B).
    bucket: [u8; BUCKETS],
}

impl Codes {
    fn get() -> &'static Codes {
        static CODES: std::sync::OnceLock<Codes> = std::sync::OnceLock::new();
        CODES.get_or_init(Codes::new)
    }

    fn new() -> Codes {
        // Bisection over the bit patterns of [0, 1] (ordered as the values).
        let start = std::array::from_fn(|k| {
            let want = k as u8 + 1;
            let (mut lo, mut hi) = (0u32, 1.0f32.to_bits());
            while lo < hi {
                let mid = lo + (hi - lo) / 2;
                if srgb8_formula(f32::from_bits(mid)) >= want {
                    hi = mid;
                } else {
                    lo = mid + 1;
                }
            }
            f32::from_bits(lo)
        });
        let mut codes = Codes {
            start,
            bucket: [0; BUCKETS],
        };
        let mut code = 0;
        for i in 0..BUCKETS {
            code = codes.count_from(code, i as f32 / BUCKETS as f32);
            codes.bucket[i] = code;
        }
        codes
    }

    /// The code of `x`, counting thresholds up from code `from` (at most
    /// the code of x).
    fn count_from(&self, from: u8, x: f32) -> u8 {
        let mut c = from;
        while c < 255 && self.start[c as usize] <= x {
            c += 1;
        }
        c
    }

    fn code(&self, x: f32) -> u8 {
        // Zero, negatives and NaN encode as 0 (the formula clamps them).
        if x.is_nan() || x <= 0.0 {
            return 0;
        }
        if x >= 1.0 {
            return 255;
        }
        // x·B is exact (B is a power of two): bucket i starts at i/B ≤ x.
        let i = ((x * BUCKETS as f32) as usize).min(BUCKETS - 1);
        self.count_from(self.bucket[i], x)
    }
}

/// Linear RGB pixels to 8-bit sRGB bytes, three per pixel ([`srgb8`]).
pub fn to_srgb8(rgb: &[[f32; 3]]) -> Vec<u8> {
    let codes = Codes::get();
    rgb.iter().flat_map(|c| c.map(|x| codes.code(x))).collect()
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

    /// The lookup gives the formula's byte around every code's threshold
    /// (a few thousand values either side), at the bucket edges and at
    /// values spread over [−1, 2], NaN and infinities included.
    #[test]
    fn lookup_equals_the_formula() {
        let codes = Codes::get();
        for (k, &t) in codes.start.iter().enumerate() {
            assert_eq!(srgb8_formula(t), k as u8 + 1, "threshold of code {}", k + 1);
            let b = t.to_bits();
            for bits in b.saturating_sub(3000)..b + 3000 {
                let x = f32::from_bits(bits);
                assert_eq!(srgb8(x), srgb8_formula(x), "at {x:e}");
            }
        }
        for i in 0..=BUCKETS {
            let x = i as f32 / BUCKETS as f32;
            for y in [
                x,
                f32::from_bits(x.to_bits().saturating_sub(1)),
                f32::from_bits(x.to_bits() + 1),
            ] {
                assert_eq!(srgb8(y), srgb8_formula(y), "at {y:e}");
            }
        }
        for i in 0..300_000 {
            let x = -1.0 + 3.0 * i as f32 / 300_000.0;
            assert_eq!(srgb8(x), srgb8_formula(x), "at {x:e}");
        }
        for x in [
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            -0.0,
            f32::MIN_POSITIVE,
            1e-30,
        ] {
            assert_eq!(srgb8(x), srgb8_formula(x), "at {x:e}");
        }
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
