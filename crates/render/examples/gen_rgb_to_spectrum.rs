//! Generates `crates/render/src/spectrum/srgb_sigmoid.bin`, the RGB → spectrum coefficient
//! table of Jakob & Hanika 2019 ("A Low-Dimensional Function Space for Efficient Spectral
//! Upsampling"), with our own optimiser.
//!
//! `cargo run --profile test -p candela-render --example gen_rgb_to_spectrum -- [N] [OUT]`
//! (N = 32 nodes per axis by default: 3 × 32³ × 3 f32 = 1.2 MB; OUT defaults to the committed
//! file; `GEN_VERBOSE=1` lists the nodes that did not converge). A few seconds; the output is
//! deterministic (the committed file is reproduced byte for byte). Only the white corner
//! (1, 1, 1), which no finite coefficients reach, stays above the tolerance (residual 7e-3
//! ΔE; lookups of exact greys never use the table).
//!
//! # The fit
//!
//! A reflectance R(λ) = S(a t² + b t + c), t = (λ − 360)/470 ∈ [0, 1] during the fit (better
//! conditioned than nm), S(x) = ½ + x/(2√(1 + x²)). Its colour is what the renderer computes:
//! XYZ = Σ wᵢ R(λᵢ) D65ₙ(λᵢ) (x̄, ȳ, z̄)(λᵢ) / ∫ȳ over the 1 nm CIE samples (trapezoid weights
//! wᵢ, D65ₙ the Y-normalised D65), then the sRGB matrix. For a target linear sRGB colour the
//! residual is the CIELAB difference (white = the XYZ of R ≡ 1) between the target and the
//! spectrum's colour; three residuals, three unknowns, solved by Levenberg–Marquardt with the
//! analytic Jacobian (Gauss–Newton steps once close).
//!
//! Continuation (the paper's, from the grey axis): in each of the three tables the slab nearest
//! z = ½ is solved first, from its grey point (z, z, z) (the constant spectrum S⁻¹(z)) outwards
//! over the (x, y) grid, each node starting from its already solved neighbour; then every
//! (x, y) column is followed along z, up to 1 and down towards 0, each node starting from the
//! previous one. When a step does not converge it is split in two (recursively, six levels)
//! along the straight line in RGB between the two colours. The z = 0 slab (black, unreachable
//! with finite coefficients) copies the next one: colours whose largest channel is below its
//! node (~3e-5) are off by at most that (and from_rgb refines them anyway).
//!
//! The coefficients are finally converted to λ in nm (c₀λ² + c₁λ + c₂) and written as f32:
//! header `b"CDLSIG01"`, N (u32 LE), 0 (u32), then `[l][z][y][x][c₀, c₁, c₂]`.

use std::io::Write;
use std::time::Instant;

use candela_render::spectrum::cie::{cie_xyz, linear_srgb_to_xyz_f64};
use candela_render::spectrum::{d65_normalized, table_z_node, CIE_Y_NORMALIZER, TABLE_MAGIC};
use rayon::prelude::*;

const SAMPLES: usize = 471;

/// A solved column of the table: (l, y index, x index), coefficients and residual per z node.
type Column = ((usize, usize, usize), Vec<[f64; 3]>, Vec<f64>);
/// Convergence: CIELAB residual norm.
const TOL: f64 = 1e-7;

struct Model {
    /// Normalised wavelength t of each sample.
    t: Vec<f64>,
    /// XYZ weight of each sample.
    w: Vec<[f64; 3]>,
    /// XYZ of the unit reflectance.
    white: [f64; 3],
}

impl Model {
    fn new() -> Self {
        let mut t = Vec::new();
        let mut w = Vec::new();
        let mut white = [0.0; 3];
        for i in 0..SAMPLES {
            let l = 360.0 + i as f32;
            let q = if i == 0 || i == SAMPLES - 1 { 0.5 } else { 1.0 };
            let c = cie_xyz(l);
            let d = d65_normalized(l) as f64 * q / CIE_Y_NORMALIZER as f64;
            let wi = [c[0] as f64 * d, c[1] as f64 * d, c[2] as f64 * d];
            for k in 0..3 {
                white[k] += wi[k];
            }
            t.push(i as f64 / (SAMPLES - 1) as f64);
            w.push(wi);
        }
        Self { t, w, white }
    }

    /// XYZ of the spectrum and its derivatives with respect to (a, b, c).
    fn xyz(&self, c: [f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
        let mut xyz = [0.0; 3];
        let mut d = [[0.0; 3]; 3]; // d[xyz][coef]
        for i in 0..SAMPLES {
            let t = self.t[i];
            let x = (c[0] * t + c[1]) * t + c[2];
            let r = 1.0 + x * x;
            let s = 0.5 + x / (2.0 * r.sqrt());
            let ds = 0.5 / (r * r.sqrt());
            let basis = [t * t, t, 1.0];
            for k in 0..3 {
                let wk = self.w[i][k];
                xyz[k] += wk * s;
                for j in 0..3 {
                    d[k][j] += wk * ds * basis[j];
                }
            }
        }
        (xyz, d)
    }

    /// CIELAB of an XYZ triple and its Jacobian d(L, a, b)/d(X, Y, Z).
    fn lab(&self, xyz: [f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
        let delta: f64 = 6.0 / 29.0;
        let f = |v: f64| -> (f64, f64) {
            if v > delta * delta * delta {
                let c = v.cbrt();
                (c, 1.0 / (3.0 * c * c))
            } else {
                let k = 1.0 / (3.0 * delta * delta);
                (v * k + 4.0 / 29.0, k)
            }
        };
        let (fx, dfx) = f(xyz[0] / self.white[0]);
        let (fy, dfy) = f(xyz[1] / self.white[1]);
        let (fz, dfz) = f(xyz[2] / self.white[2]);
        let (gx, gy, gz) = (
            dfx / self.white[0],
            dfy / self.white[1],
            dfz / self.white[2],
        );
        (
            [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)],
            [
                [0.0, 116.0 * gy, 0.0],
                [500.0 * gx, -500.0 * gy, 0.0],
                [0.0, 200.0 * gy, -200.0 * gz],
            ],
        )
    }

    /// Residual (spectrum's Lab − target Lab) and its Jacobian with respect to the coefficients.
    fn residual(&self, c: [f64; 3], target: [f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
        let (xyz, dxyz) = self.xyz(c);
        let (lab, dlab) = self.lab(xyz);
        let mut j = [[0.0; 3]; 3];
        for r in 0..3 {
            for k in 0..3 {
                j[r][k] = (0..3).map(|m| dlab[r][m] * dxyz[m][k]).sum();
            }
        }
        (
            [lab[0] - target[0], lab[1] - target[1], lab[2] - target[2]],
            j,
        )
    }

    fn target_lab(&self, rgb: [f64; 3]) -> [f64; 3] {
        self.lab(linear_srgb_to_xyz_f64(rgb)).0
    }

    /// Levenberg–Marquardt from `c` towards the colour `rgb`; returns the final residual norm.
    fn solve(&self, c: &mut [f64; 3], rgb: [f64; 3]) -> f64 {
        let target = self.target_lab(rgb);
        let norm = |r: [f64; 3]| (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
        let (mut r, mut j) = self.residual(*c, target);
        let mut mu = 1e-4;
        for _ in 0..300 {
            let f = norm(r);
            if f < TOL {
                return f;
            }
            // (JᵀJ + μ diag(JᵀJ)) δ = −Jᵀr.
            let mut a = [[0.0; 3]; 3];
            let mut g = [0.0; 3];
            for p in 0..3 {
                for q in 0..3 {
                    a[p][q] = (0..3).map(|m| j[m][p] * j[m][q]).sum();
                }
                g[p] = -(0..3).map(|m| j[m][p] * r[m]).sum::<f64>();
            }
            let mut improved = false;
            while mu < 1e10 {
                let mut am = a;
                for p in 0..3 {
                    am[p][p] += mu * a[p][p].max(1e-12);
                }
                let Some(delta) = solve3(am, g) else {
                    mu *= 10.0;
                    continue;
                };
                let trial = [c[0] + delta[0], c[1] + delta[1], c[2] + delta[2]];
                let (rt, jt) = self.residual(trial, target);
                if norm(rt) < f {
                    *c = trial;
                    r = rt;
                    j = jt;
                    mu = (mu * 0.2).max(1e-12);
                    improved = true;
                    break;
                }
                mu *= 8.0;
            }
            if !improved {
                break;
            }
        }
        norm(r)
    }

    /// Solves for `to`, starting from coefficients `c` that fit `from`; splits the step along
    /// the RGB segment when it does not converge.
    fn continue_to(&self, c: &mut [f64; 3], from: [f64; 3], to: [f64; 3], depth: u32) -> f64 {
        let mut trial = *c;
        let res = self.solve(&mut trial, to);
        if res < TOL || depth >= 6 {
            *c = trial;
            return res;
        }
        let mid = [
            0.5 * (from[0] + to[0]),
            0.5 * (from[1] + to[1]),
            0.5 * (from[2] + to[2]),
        ];
        let mut half = *c;
        self.continue_to(&mut half, from, mid, depth + 1);
        let res2 = self.continue_to(&mut half, mid, to, depth + 1);
        if res2 <= res {
            *c = half;
            res2
        } else {
            *c = trial;
            res
        }
    }
}

/// Solves the 3 × 3 system by Gaussian elimination with partial pivoting.
fn solve3(mut a: [[f64; 3]; 3], mut b: [f64; 3]) -> Option<[f64; 3]> {
    for col in 0..3 {
        let p = (col..3).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[p][col].abs() < 1e-300 {
            return None;
        }
        a.swap(col, p);
        b.swap(col, p);
        for row in col + 1..3 {
            let f = a[row][col] / a[col][col];
            for k in col..3 {
                a[row][k] -= f * a[col][k];
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = [0.0; 3];
    for row in (0..3).rev() {
        let s: f64 = (row + 1..3).map(|k| a[row][k] * x[k]).sum();
        x[row] = (b[row] - s) / a[row][row];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// The colour of table node (l, z, x, y).
fn node_rgb(l: usize, z: f64, x: f64, y: f64) -> [f64; 3] {
    let mut rgb = [0.0; 3];
    rgb[l] = z;
    rgb[(l + 1) % 3] = x * z;
    rgb[(l + 2) % 3] = y * z;
    rgb
}

/// Normalised-t coefficients (a t² + b t + c) → nm coefficients (c₀λ² + c₁λ + c₂).
fn to_nm(c: [f64; 3]) -> [f32; 3] {
    let s = 1.0 / 470.0;
    let o = -360.0 / 470.0;
    let (a, b, k) = (c[0], c[1], c[2]);
    [
        (a * s * s) as f32,
        (s * (2.0 * a * o + b)) as f32,
        (a * o * o + b * o + k) as f32,
    ]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n: usize = args.get(1).map(|s| s.parse().expect("N")).unwrap_or(32);
    let out = args.get(2).cloned().unwrap_or_else(|| {
        concat!(env!("CARGO_MANIFEST_DIR"), "/src/spectrum/srgb_sigmoid.bin").to_string()
    });
    let model = Model::new();
    eprintln!(
        "fitting 3 × {n}³ nodes; white XYZ = {:.5?}, its sRGB = {:.6?}",
        model.white,
        candela_render::spectrum::cie::xyz_to_linear_srgb_f64(model.white)
    );
    let start = Instant::now();

    let verbose = std::env::var_os("GEN_VERBOSE").is_some();
    let coord = |i: usize| i as f64 / (n - 1) as f64;
    let zs: Vec<f64> = (0..n).map(|k| table_z_node(k, n) as f64).collect();
    // The middle slab of each table (z ≈ ½), by 2D continuation from its grey corner.
    let mid = (0..n)
        .min_by(|&a, &b| (zs[a] - 0.5).abs().total_cmp(&(zs[b] - 0.5).abs()))
        .unwrap();
    let z = zs[mid];
    let middle: Vec<Vec<[f64; 3]>> = (0..3)
        .into_par_iter()
        .map(|l| {
            let mut coeffs = vec![[0.0; 3]; n * n];
            let mut grey = [0.0, 0.0, (z - 0.5) / (z * (1.0 - z)).sqrt()];
            let grey_rgb = [z; 3];
            model.solve(&mut grey, grey_rgb);
            for j in (0..n).rev() {
                for i in (0..n).rev() {
                    let (mut c, from) = if i == n - 1 && j == n - 1 {
                        (grey, grey_rgb)
                    } else if i == n - 1 {
                        (
                            coeffs[(j + 1) * n + i],
                            node_rgb(l, z, coord(i), coord(j + 1)),
                        )
                    } else {
                        (
                            coeffs[j * n + i + 1],
                            node_rgb(l, z, coord(i + 1), coord(j)),
                        )
                    };
                    model.continue_to(&mut c, from, node_rgb(l, z, coord(i), coord(j)), 0);
                    coeffs[j * n + i] = c;
                }
            }
            coeffs
        })
        .collect();

    // Then every (l, x, y) along z, up to 1 and down to the first node above 0.
    let columns: Vec<(usize, usize, usize)> = (0..3)
        .flat_map(|l| (0..n).flat_map(move |j| (0..n).map(move |i| (l, j, i))))
        .collect();
    let solved: Vec<Column> = columns
        .par_iter()
        .map(|&(l, j, i)| {
            let (x, y) = (coord(i), coord(j));
            let mut col = vec![[0.0; 3]; n];
            let mut res = vec![0.0; n];
            let at_mid = middle[l][j * n + i];
            let mut c = at_mid;
            res[mid] = model.solve(&mut c, node_rgb(l, zs[mid], x, y));
            col[mid] = c;
            for k in mid + 1..n {
                let from = node_rgb(l, zs[k - 1], x, y);
                res[k] = model.continue_to(&mut c, from, node_rgb(l, zs[k], x, y), 0);
                col[k] = c;
            }
            let mut c = at_mid;
            for k in (1..mid).rev() {
                let from = node_rgb(l, zs[k + 1], x, y);
                res[k] = model.continue_to(&mut c, from, node_rgb(l, zs[k], x, y), 0);
                col[k] = c;
            }
            // z = 0 copies z = z₁ (see the module documentation).
            col[0] = col[1];
            res[0] = 0.0;
            ((l, j, i), col, res)
        })
        .collect();

    let mut table = vec![[0f32; 3]; 3 * n * n * n];
    let (mut worst, mut unconverged) = (0f64, 0usize);
    for ((l, j, i), col, res) in &solved {
        for k in 0..n {
            table[((l * n + k) * n + j) * n + i] = to_nm(col[k]);
            worst = worst.max(res[k]);
            if res[k] >= TOL {
                unconverged += 1;
                if verbose {
                    eprintln!(
                        "  l={l} z={:.5} x={:.3} y={:.3}: residual {:.3e}, c = {:.3?}",
                        zs[k],
                        coord(*i),
                        coord(*j),
                        res[k],
                        col[k]
                    );
                }
            }
        }
    }
    eprintln!(
        "{:.1} s; worst Lab residual {worst:.3e}; {unconverged} of {} nodes above {TOL:e}",
        start.elapsed().as_secs_f64(),
        3 * (n - 1) * n * n
    );

    let mut bytes = Vec::with_capacity(16 + table.len() * 12);
    bytes.extend_from_slice(TABLE_MAGIC);
    bytes.extend_from_slice(&(n as u32).to_le_bytes());
    bytes.extend_from_slice(&0u32.to_le_bytes());
    for c in &table {
        for v in c {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    let mut f = std::fs::File::create(&out).expect("create output");
    f.write_all(&bytes).expect("write output");
    eprintln!("wrote {out} ({} bytes)", bytes.len());
}
