//! RGB → smooth reflectance spectrum: Jakob & Hanika 2019, "A Low-Dimensional Function Space
//! for Efficient Spectral Upsampling".
//!
//! A reflectance is modelled as a sigmoid of a quadratic in λ,
//! R(λ) = S(c₀λ² + c₁λ + c₂) with S(x) = ½ + x / (2√(1 + x²)), which is smooth, bounded in
//! (0, 1) and needs three numbers. The coefficients of an sRGB colour are looked up in a table
//! computed offline by `examples/gen_rgb_to_spectrum.rs` (our own Levenberg–Marquardt fit in
//! CIELAB, with continuation from the grey axis): for every target colour the spectrum whose
//! colour *as a reflectance lit by D65* (Y-normalised, [`d65_normalized`](super::d65_normalized)),
//! seen by the CIE 1931 observer and converted to linear sRGB, is that colour.
//!
//! # The table (`srgb_sigmoid.bin`)
//!
//! pbrt-v4's parameterisation: the largest channel `l` of the colour chooses one of three
//! tables; its value z = rgb[l] is the third axis, on nodes spaced by smoothstep(smoothstep(k /
//! (N − 1))) (dense near 0 and 1, where the coefficients change fastest); the other two
//! channels divided by it, x = rgb[(l+1) % 3] / z and y = rgb[(l+2) % 3] / z, are uniform on
//! [0, 1]. Each node stores (c₀, c₁, c₂) for λ in nm, N = 32 (1.2 MB). Layout: a 16-byte
//! header (`b"CDLSIG01"`, N as u32 LE, 0u32), then f32 LE coefficients indexed
//! `[l][z][y][x][c]`. It is decoded once (a `OnceLock`) on first use.
//!
//! # Accuracy
//!
//! The nodes are exact (residual < 1e-7 ΔE), but trilinear interpolation of the coefficients
//! between them is not: at N = 32 the colour of [`RgbSigmoid::from_rgb_table`] is off by a few
//! 1e-4 typically, above 1e-3 for about a third of the gamut, up to 2e-2 in the cells next to
//! white (the coefficients grow without bound towards it). A finer table would exceed the size
//! budget (N = 64 is 9.4 MB), so [`RgbSigmoid::from_rgb`] polishes the interpolated guess with
//! Newton's method on the colour itself (the same 1 nm quadrature the renderer's colorimetry
//! uses): over a 49³ grid of the gamut plus 10⁵ random colours its colour is within 2.5e-4 of
//! the target (the largest errors are the exact greys, which are constant spectra: the sRGB
//! matrix's white (0.3127, 0.3290) and the tabulated D65's (0.31273, 0.32902) differ by that),
//! and every spectrum stays within [0, 1].

use std::sync::OnceLock;

use super::sampled::SampledSpectrum;
use super::wavelengths::SampledWavelengths;
use crate::color::Rgb;

/// The committed coefficient table.
static TABLE_BYTES: &[u8] = include_bytes!("srgb_sigmoid.bin");

/// The table file's magic bytes.
pub const TABLE_MAGIC: &[u8; 8] = b"CDLSIG01";

/// The sigmoid S(x) = ½ + x / (2√(1 + x²)), with S(±∞) = 1 or 0.
#[inline]
pub fn sigmoid(x: f32) -> f32 {
    if x.is_infinite() {
        return if x > 0.0 { 1.0 } else { 0.0 };
    }
    0.5 + x / (2.0 * (1.0 + x * x).sqrt())
}

/// The z-axis node k of an N-node table: smoothstep(smoothstep(k / (N − 1))).
pub fn table_z_node(k: usize, n: usize) -> f32 {
    let s = |t: f64| t * t * (3.0 - 2.0 * t);
    s(s(k as f64 / (n - 1) as f64)) as f32
}

/// A spectrum S(c₀λ² + c₁λ + c₂) (λ in nm), bounded in [0, 1].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RgbSigmoid {
    /// Coefficient of λ² (nm⁻²).
    pub c0: f32,
    /// Coefficient of λ (nm⁻¹).
    pub c1: f32,
    /// Constant term; ±∞ for the constant spectra 1 and 0.
    pub c2: f32,
}

impl RgbSigmoid {
    /// The constant spectrum `v` ∈ [0, 1] (S⁻¹(v) = (v − ½) / √(v (1 − v))).
    pub fn constant(v: f32) -> Self {
        let v = if v > 0.0 { v.min(1.0) } else { 0.0 };
        Self {
            c0: 0.0,
            c1: 0.0,
            c2: (v - 0.5) / (v * (1.0 - v)).sqrt(),
        }
    }

    /// The spectrum at `lambda` nm.
    #[inline]
    pub fn eval(&self, lambda: f32) -> f32 {
        sigmoid((self.c0 * lambda + self.c1) * lambda + self.c2)
    }

    /// The spectrum at four wavelengths.
    #[inline]
    pub fn eval4(&self, lambda: &SampledWavelengths) -> SampledSpectrum {
        if self.c2.is_infinite() {
            return SampledSpectrum::splat(sigmoid(self.c2));
        }
        // Branch-free lanes (four-wide square root and division).
        let (c0, c1, c2) = (self.c0, self.c1, self.c2);
        lambda.eval(|l| {
            let x = (c0 * l + c1) * l + c2;
            0.5 + 0.5 * x / (1.0 + x * x).sqrt()
        })
    }

    /// The maximum over 360–830 nm (at an end or at the vertex of the quadratic; S is
    /// increasing).
    pub fn max_value(&self) -> f32 {
        let mut m = self
            .eval(super::LAMBDA_MIN)
            .max(self.eval(super::LAMBDA_MAX));
        if self.c0 != 0.0 {
            let v = -self.c1 / (2.0 * self.c0);
            if (super::LAMBDA_MIN..=super::LAMBDA_MAX).contains(&v) {
                m = m.max(self.eval(v));
            }
        }
        m
    }

    /// The coefficients of the reflectance whose colour is `rgb` (each channel clamped to
    /// [0, 1]; NaN counts as 0), accurate: the table's guess ([`from_rgb_table`]) refined by
    /// Newton's method on the colour (at most three steps, each only if it helps), so that
    /// the spectrum's colour is `rgb` to ~1e-6 wherever the model can reach it. About 10 µs:
    /// for scene constants; per-texel lookups use [`from_rgb_table`].
    ///
    /// [`from_rgb_table`]: Self::from_rgb_table
    pub fn from_rgb(rgb: Rgb) -> Self {
        let c = [rgb.r, rgb.g, rgb.b].map(|v| if v > 0.0 { v.min(1.0) } else { 0.0 });
        if c[0] == c[1] && c[1] == c[2] {
            return Self::constant(c[0]);
        }
        let target = c.map(|v| v as f64);
        let (guess, corners) = lookup(c);
        let (mut best, mut e) = refine(guess, target, 4);
        // Next to white the interpolated guess can be far off (the coefficients grow without
        // bound towards white): start again from the cell's nodes, each exact at its colour.
        if e > 1e-6 {
            for corner in corners {
                let (s, ec) = refine(corner, target, 12);
                if ec < e {
                    (best, e) = (s, ec);
                }
                if e <= 1e-6 {
                    break;
                }
            }
        }
        best
    }

    /// The coefficients of the reflectance whose colour is `rgb` (clamped to [0, 1]³) by
    /// table lookup alone: exact greys analytically, others by trilinear interpolation of the
    /// table's coefficients (~0.2 µs). The colour is off by up to ~2e-2 next to white and
    /// typically ~5e-4 elsewhere (interpolation between the nodes; exact at them).
    pub fn from_rgb_table(rgb: Rgb) -> Self {
        let c = [rgb.r, rgb.g, rgb.b].map(|v| if v > 0.0 { v.min(1.0) } else { 0.0 });
        if c[0] == c[1] && c[1] == c[2] {
            return Self::constant(c[0]);
        }
        lookup(c).0
    }
}

/// Trilinear interpolation in the table for a colour in [0, 1]³ that is not grey; also the
/// coefficients of the cell's eight nodes.
fn lookup(c: [f32; 3]) -> (RgbSigmoid, [RgbSigmoid; 8]) {
    let l = if c[0] >= c[1] && c[0] >= c[2] {
        0
    } else if c[1] >= c[2] {
        1
    } else {
        2
    };
    let t = table();
    let n = t.res;
    let z = c[l];
    let scale = (n - 1) as f32 / z;
    let x = c[(l + 1) % 3] * scale;
    let y = c[(l + 2) % 3] * scale;
    let xi = (x as usize).min(n - 2);
    let yi = (y as usize).min(n - 2);
    let zi = t.z_nodes.partition_point(|&v| v <= z).clamp(1, n - 1) - 1;
    let dx = x - xi as f32;
    let dy = y - yi as f32;
    let dz = (z - t.z_nodes[zi]) / (t.z_nodes[zi + 1] - t.z_nodes[zi]);
    let at = |dzi: usize, dyi: usize, dxi: usize| {
        t.coeffs[((l * n + zi + dzi) * n + yi + dyi) * n + xi + dxi]
    };
    let mut r = [0f32; 3];
    let lerp = |a: f32, b: f32, w: f32| a + w * (b - a);
    for k in 0..3 {
        let y0 = lerp(
            lerp(at(0, 0, 0)[k], at(0, 0, 1)[k], dx),
            lerp(at(0, 1, 0)[k], at(0, 1, 1)[k], dx),
            dy,
        );
        let y1 = lerp(
            lerp(at(1, 0, 0)[k], at(1, 0, 1)[k], dx),
            lerp(at(1, 1, 0)[k], at(1, 1, 1)[k], dx),
            dy,
        );
        r[k] = lerp(y0, y1, dz);
    }
    let s = |c: [f32; 3]| RgbSigmoid {
        c0: c[0],
        c1: c[1],
        c2: c[2],
    };
    let corners = [0, 1, 2, 3, 4, 5, 6, 7].map(|i| s(at(i >> 2, (i >> 1) & 1, i & 1)));
    (s(r), corners)
}

/// The colour (linear sRGB, as a reflectance under D65 with Y = 1) of the spectrum with
/// nm coefficients `c` and its derivatives with respect to them, over the 1 nm CIE samples.
fn colour_and_jacobian(c: [f64; 3], w: &[[f64; 3]]) -> ([f64; 3], [[f64; 3]; 3]) {
    let mut rgb = [0.0; 3];
    let mut jac = [[0.0; 3]; 3];
    for (i, wi) in w.iter().enumerate() {
        let l = super::LAMBDA_MIN as f64 + i as f64;
        let x = (c[0] * l + c[1]) * l + c[2];
        let r = 1.0 + x * x;
        let sr = r.sqrt();
        let s = 0.5 + x / (2.0 * sr);
        let ds = 0.5 / (r * sr);
        let basis = [l * l, l, 1.0];
        for k in 0..3 {
            rgb[k] += wi[k] * s;
            for j in 0..3 {
                jac[k][j] += wi[k] * ds * basis[j];
            }
        }
    }
    (rgb, jac)
}

/// Per-sample weights mapping a reflectance's values at 360, 361, …, 830 nm to its linear
/// sRGB under D65 (Y = 1): trapezoid weight × D65ₙ × CMFs / ∫ȳ, through the sRGB matrix.
fn rgb_weights() -> &'static [[f64; 3]] {
    static W: OnceLock<Vec<[f64; 3]>> = OnceLock::new();
    W.get_or_init(|| {
        let n = (super::LAMBDA_MAX - super::LAMBDA_MIN) as usize + 1;
        (0..n)
            .map(|i| {
                let l = super::LAMBDA_MIN + i as f32;
                let q = if i == 0 || i == n - 1 { 0.5 } else { 1.0 };
                let d =
                    super::cie::d65_normalized(l) as f64 * q / super::cie::CIE_Y_NORMALIZER as f64;
                let xyz = super::cie::cie_xyz(l).map(|v| v as f64 * d);
                super::cie::xyz_to_linear_srgb_f64(xyz)
            })
            .collect()
    })
}

/// Newton's method on the colour from `guess` towards `target` (linear sRGB), at most `steps`
/// steps, each taken (or halved, up to four times) only when it reduces the largest channel
/// error; returns the result and that error.
fn refine(guess: RgbSigmoid, target: [f64; 3], steps: usize) -> (RgbSigmoid, f64) {
    let w = rgb_weights();
    let err = |rgb: [f64; 3]| {
        (0..3)
            .map(|k| (rgb[k] - target[k]).abs())
            .fold(0.0, f64::max)
    };
    let mut c = [guess.c0 as f64, guess.c1 as f64, guess.c2 as f64];
    if !c.iter().all(|v| v.is_finite()) {
        return (guess, f64::INFINITY);
    }
    let (mut rgb, mut jac) = colour_and_jacobian(c, w);
    let mut e = err(rgb);
    for _ in 0..steps {
        if e < 1e-7 {
            break;
        }
        let r = [target[0] - rgb[0], target[1] - rgb[1], target[2] - rgb[2]];
        let Some(delta) = solve3(jac, r) else { break };
        let mut step = 1.0;
        let mut improved = false;
        for _ in 0..5 {
            let trial = [
                c[0] + step * delta[0],
                c[1] + step * delta[1],
                c[2] + step * delta[2],
            ];
            let (rgb_t, jac_t) = colour_and_jacobian(trial, w);
            let e_t = err(rgb_t);
            if e_t < e {
                (c, rgb, jac, e) = (trial, rgb_t, jac_t, e_t);
                improved = true;
                break;
            }
            step *= 0.5;
        }
        if !improved {
            break;
        }
    }
    let s = RgbSigmoid {
        c0: c[0] as f32,
        c1: c[1] as f32,
        c2: c[2] as f32,
    };
    (s, e)
}

/// Solves a 3 × 3 linear system by Cramer's rule; `None` when (nearly) singular.
fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(a);
    if !(d.abs() > 1e-300) || !d.is_finite() {
        return None;
    }
    let mut x = [0.0; 3];
    for (k, xk) in x.iter_mut().enumerate() {
        let mut m = a;
        for row in 0..3 {
            m[row][k] = b[row];
        }
        *xk = det(m) / d;
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// The decoded table.
struct Table {
    res: usize,
    z_nodes: Vec<f32>,
    coeffs: Vec<[f32; 3]>,
}

fn table() -> &'static Table {
    static TABLE: OnceLock<Table> = OnceLock::new();
    TABLE.get_or_init(|| decode_table(TABLE_BYTES).expect("corrupt srgb_sigmoid.bin"))
}

/// Decodes a coefficient table (see the module documentation for the layout).
fn decode_table(bytes: &[u8]) -> Result<Table, String> {
    if bytes.len() < 16 || &bytes[..8] != TABLE_MAGIC {
        return Err("bad magic".into());
    }
    let res = u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize;
    let count = 3 * res * res * res;
    if res < 2 || bytes.len() != 16 + count * 12 {
        return Err(format!(
            "resolution {res} does not match {} bytes",
            bytes.len()
        ));
    }
    let f = |i: usize| f32::from_le_bytes(bytes[16 + 4 * i..20 + 4 * i].try_into().unwrap());
    let coeffs = (0..count)
        .map(|i| [f(3 * i), f(3 * i + 1), f(3 * i + 2)])
        .collect();
    Ok(Table {
        res,
        z_nodes: (0..res).map(|k| table_z_node(k, res)).collect(),
        coeffs,
    })
}

/// The resolution N of the committed table (N × N × N nodes per largest channel).
pub fn table_resolution() -> usize {
    table().res
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sigmoid_limits_and_constants() {
        assert_eq!(sigmoid(0.0), 0.5);
        assert_eq!(sigmoid(f32::INFINITY), 1.0);
        assert_eq!(sigmoid(f32::NEG_INFINITY), 0.0);
        assert!(sigmoid(1e30) <= 1.0 && sigmoid(-1e30) >= 0.0);
        for v in [0.0, 0.1, 0.5, 0.9, 1.0] {
            let s = RgbSigmoid::constant(v);
            assert!((s.eval(400.0) - v).abs() < 1e-6 && (s.eval(700.0) - v).abs() < 1e-6);
        }
        assert_eq!(RgbSigmoid::from_rgb(Rgb::BLACK).eval(550.0), 0.0);
        assert_eq!(RgbSigmoid::from_rgb(Rgb::WHITE).eval(550.0), 1.0);
    }

    #[test]
    fn table_decodes() {
        let t = table();
        assert!(t.res >= 16);
        assert_eq!(t.z_nodes[0], 0.0);
        assert_eq!(t.z_nodes[t.res - 1], 1.0);
        assert!(t.z_nodes.windows(2).all(|w| w[0] < w[1]));
        assert!(t.coeffs.iter().all(|c| c.iter().all(|v| v.is_finite())));
        assert!(decode_table(&TABLE_BYTES[..100]).is_err());
    }

    #[test]
    fn hues_go_where_expected() {
        // A red reflectance is high at long wavelengths, a blue one at short ones.
        let red = RgbSigmoid::from_rgb(Rgb::new(0.8, 0.1, 0.1));
        assert!(red.eval(650.0) > 0.6 && red.eval(450.0) < 0.2);
        let blue = RgbSigmoid::from_rgb(Rgb::new(0.1, 0.1, 0.8));
        assert!(blue.eval(450.0) > 0.6 && blue.eval(650.0) < 0.2);
        let green = RgbSigmoid::from_rgb(Rgb::new(0.1, 0.8, 0.1));
        assert!(green.eval(540.0) > 0.5 && green.max_value() <= 1.0);
    }
}
