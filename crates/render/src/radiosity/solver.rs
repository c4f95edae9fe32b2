//! Solvers of the radiosity system B_i = S_i + ρ_i Σ_j F_ij B_j, per RGB channel in f64.
//!
//! `S` is the source: emitted radiosity E plus, when the scene has lights that are not shapes,
//! the radiosity they reflect directly.
//!
//! - **Gauss–Seidel** (the lecture's method) sweeps the rows of (I − ρF)B = S, each update using
//!   the newest values, until the area-weighted residual
//!   Σ_i A_i |S_i + ρ_i Σ_j F_ij B_j − B_i|₁ / Σ_i A_i |S_i|₁ is below the threshold. It needs
//!   every row of F (computed in parallel, 8 bytes per non-zero form factor); when they exceed
//!   the memory limit the solve switches to progressive refinement.
//! - **Progressive refinement** (Cohen et al. 1988) in Southwell's order: the patch with the
//!   most unshot power A_i ΔB_i shoots it, ΔB_j += ρ_j F_ji ΔB_i with F_ji = A_i F_ij / A_j
//!   (reciprocity), so only row i is needed. The eight largest shooters are picked at a time and
//!   their rows computed in parallel (a fixed batch, so the result does not depend on the thread
//!   count); rows are kept in a cache of bounded size (default 256 MiB) and recomputed when
//!   evicted, never the whole matrix. It stops when the unshot power fraction
//!   Σ A_i |ΔB_i|₁ / Σ A_i |S_i|₁ (an upper bound of the residual above, since ρ < 1 and
//!   Σ_i A_i F_ij ≤ A_j) is below the threshold.

use super::formfactor::Engine;
use super::mesh::Patch;
use super::row::{reciprocity, Row, RowStats};
use std::collections::{HashMap, VecDeque};

/// What a solve found.
#[derive(Clone, Debug, Default)]
pub(crate) struct Solution {
    /// Radiosity per patch.
    pub b: Vec<[f64; 3]>,
    /// Sweeps (Gauss–Seidel) or shots (progressive).
    pub iterations: u64,
    /// Relative residual reached.
    pub residual: f64,
    /// Whether the residual reached the threshold.
    pub converged: bool,
    /// Form-factor rows computed.
    pub rows_computed: u64,
    /// Peak memory of stored rows, in bytes.
    pub row_bytes: usize,
    /// Row-sum statistics.
    pub stats: RowStats,
    /// Reciprocity: mean relative error, largest relative error, pairs checked.
    pub reciprocity: (f64, f64, u64),
    /// Gauss–Seidel fell back to progressive refinement (the matrix was too large).
    pub fell_back: bool,
    /// Per patch: [`Row::occluded`] of its row, or −1 when its row was not computed.
    pub occluded: Vec<f32>,
}

/// Σ_i A_i |x_i|₁.
fn weighted_norm(patches: &[Patch], x: &[[f64; 3]]) -> f64 {
    patches
        .iter()
        .zip(x)
        .map(|(p, v)| p.area * (v[0].abs() + v[1].abs() + v[2].abs()))
        .sum()
}

/// Computes all rows (Gauss–Seidel), or `None` when they would need more than `limit` bytes.
pub(crate) fn all_rows(engine: &Engine, n: usize, limit: usize) -> Option<Vec<Row>> {
    let mut rows = Vec::with_capacity(n);
    let mut bytes = 0usize;
    let chunk = 256usize;
    let ids: Vec<u32> = (0..n as u32).collect();
    for c in ids.chunks(chunk) {
        let part = engine.rows(c);
        bytes += part.iter().map(Row::bytes).sum::<usize>();
        if bytes > limit {
            return None;
        }
        rows.extend(part);
    }
    Some(rows)
}

/// The gathering coefficients G_ij = A_j F_ji / A_i from the rows F_j· computed at each patch
/// (reciprocity): row i of G lists what patch i receives from every patch j, per unit of B_j.
fn gathering(rows: &[Row], patches: &[Patch]) -> Vec<Row> {
    let n = rows.len();
    let mut count = vec![0usize; n];
    for r in rows {
        for &i in &r.cols {
            count[i as usize] += 1;
        }
    }
    let mut out: Vec<Row> = count
        .iter()
        .map(|&c| Row {
            cols: Vec::with_capacity(c),
            vals: Vec::with_capacity(c),
            occluded: 0.0,
        })
        .collect();
    for (j, r) in rows.iter().enumerate() {
        let aj = patches[j].area;
        for (&i, &f) in r.cols.iter().zip(&r.vals) {
            let g = out.get_mut(i as usize);
            if let Some(g) = g {
                g.cols.push(j as u32);
                g.vals
                    .push((f as f64 * aj / patches[i as usize].area) as f32);
            }
        }
    }
    out
}

/// Gauss–Seidel on the stored rows, starting from `b0` (or S).
///
/// The rows are those computed at each patch: F_ij from patch i's hemicube or rays. By default
/// patch i gathers with them (they sum to 1 in a closed room, so the furnace is exact). With
/// `reciprocal`, the gathering coefficient of B_j in row i is A_j F_ji / A_i instead, from the
/// row computed at j: the coefficients progressive refinement shoots with, so that both solvers
/// solve exactly the same system (and the power leaving a patch is conserved even when its
/// centre is hidden, e.g. under a box).
pub(crate) fn gauss_seidel(
    rows: Vec<Row>,
    patches: &[Patch],
    source: &[[f64; 3]],
    b0: Option<Vec<[f64; 3]>>,
    threshold: f64,
    max_sweeps: u64,
    reciprocal: bool,
) -> Solution {
    let n = patches.len();
    let mut b = b0
        .filter(|b| b.len() == n)
        .unwrap_or_else(|| source.to_vec());
    let norm = weighted_norm(patches, source);
    let mut stats = RowStats::default();
    for r in &rows {
        stats.add(r.sum());
    }
    let occluded: Vec<f32> = rows.iter().map(|r| r.occluded).collect();
    let area: Vec<f64> = patches.iter().map(|p| p.area).collect();
    let recip = {
        let refs: Vec<Option<&Row>> = rows.iter().map(Some).collect();
        reciprocity(&refs, &area)
    };
    let mut row_bytes = rows.iter().map(Row::bytes).sum::<usize>();
    let rows = if reciprocal {
        let g = gathering(&rows, patches);
        row_bytes += g.iter().map(Row::bytes).sum::<usize>();
        g
    } else {
        rows
    };
    let gather = |b: &[[f64; 3]], r: &Row| {
        let mut g = [0f64; 3];
        for (&j, &f) in r.cols.iter().zip(&r.vals) {
            let bj = &b[j as usize];
            let f = f as f64;
            g[0] += f * bj[0];
            g[1] += f * bj[1];
            g[2] += f * bj[2];
        }
        g
    };
    let mut sweeps = 0;
    let mut converged = norm == 0.0;
    if norm == 0.0 {
        b.iter_mut().for_each(|x| *x = [0.0; 3]);
    }
    while !converged && sweeps < max_sweeps {
        let mut delta = 0f64;
        for i in 0..n {
            let g = gather(&b, &rows[i]);
            let p = &patches[i];
            let mut d = 0f64;
            for c in 0..3 {
                let new = source[i][c] + p.rho[c] * g[c];
                d += (new - b[i][c]).abs();
                b[i][c] = new;
            }
            delta += p.area * d;
        }
        sweeps += 1;
        converged = delta / norm <= threshold;
        if !delta.is_finite() {
            // Non-finite input never converges: stop at once (reported as not converged).
            break;
        }
    }
    // The true residual of the final B.
    let mut res = 0f64;
    for i in 0..n {
        let g = gather(&b, &rows[i]);
        let p = &patches[i];
        let r: f64 = (0..3)
            .map(|c| (source[i][c] + p.rho[c] * g[c] - b[i][c]).abs())
            .sum();
        res += p.area * r;
    }
    let residual = if norm > 0.0 { res / norm } else { 0.0 };
    Solution {
        b,
        iterations: sweeps,
        residual,
        converged: residual <= threshold.max(1e-12) || converged,
        rows_computed: rows.len() as u64,
        row_bytes,
        stats,
        reciprocity: recip,
        fell_back: false,
        occluded,
    }
}

/// A bounded first-in first-out cache of rows.
struct RowCache {
    rows: HashMap<u32, Row>,
    order: VecDeque<u32>,
    bytes: usize,
    limit: usize,
    peak: usize,
}

impl RowCache {
    fn insert(&mut self, i: u32, r: Row) {
        let b = r.bytes();
        if b > self.limit {
            return;
        }
        while self.bytes + b > self.limit {
            let Some(old) = self.order.pop_front() else {
                break;
            };
            if let Some(o) = self.rows.remove(&old) {
                self.bytes -= o.bytes();
            }
        }
        self.bytes += b;
        self.peak = self.peak.max(self.bytes);
        self.order.push_back(i);
        self.rows.insert(i, r);
    }
}

/// Shooting patches picked per batch.
const BATCH: usize = 8;

/// Southwell's progressive refinement with rows computed on demand.
pub(crate) fn progressive(
    engine: &Engine,
    patches: &[Patch],
    source: &[[f64; 3]],
    threshold: f64,
    max_shots: u64,
    cache_limit: usize,
) -> Solution {
    let n = patches.len();
    let mut b = source.to_vec();
    let mut unshot = source.to_vec();
    let norm = weighted_norm(patches, source);
    let mut cache = RowCache {
        rows: HashMap::new(),
        order: VecDeque::new(),
        bytes: 0,
        limit: cache_limit,
        peak: 0,
    };
    let mut stats = RowStats::default();
    let mut shots = 0u64;
    let mut rows_computed = 0u64;
    let mut fraction = if norm > 0.0 { 1.0 } else { 0.0 };
    let mut power: Vec<(f64, u32)> = Vec::with_capacity(n);
    let mut occluded = vec![-1f32; n];
    while fraction > threshold && shots < max_shots {
        power.clear();
        let mut total = 0f64;
        for (i, (p, u)) in patches.iter().zip(&unshot).enumerate() {
            let w = p.area * (u[0] + u[1] + u[2]);
            total += w;
            if w > 0.0 {
                power.push((w, i as u32));
            }
        }
        fraction = total / norm;
        if fraction <= threshold || power.is_empty() || !fraction.is_finite() {
            break;
        }
        let k = BATCH.min(power.len());
        if power.len() > k {
            power.select_nth_unstable_by(k - 1, |a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        }
        let mut batch: Vec<(f64, u32)> = power[..k].to_vec();
        batch.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let missing: Vec<u32> = batch
            .iter()
            .map(|x| x.1)
            .filter(|i| !cache.rows.contains_key(i))
            .collect();
        let fresh = engine.rows(&missing);
        rows_computed += fresh.len() as u64;
        let mut local: HashMap<u32, Row> = HashMap::new();
        for (i, r) in missing.into_iter().zip(fresh) {
            stats.add(r.sum());
            occluded[i as usize] = r.occluded;
            local.insert(i, r);
        }
        for &(_, i) in &batch {
            let u = std::mem::replace(&mut unshot[i as usize], [0.0; 3]);
            let row = local.get(&i).or_else(|| cache.rows.get(&i));
            if let Some(row) = row {
                let ai = patches[i as usize].area;
                for (&j, &f) in row.cols.iter().zip(&row.vals) {
                    let pj = &patches[j as usize];
                    let k = f as f64 * ai / pj.area;
                    for c in 0..3 {
                        let d = pj.rho[c] * k * u[c];
                        b[j as usize][c] += d;
                        unshot[j as usize][c] += d;
                    }
                }
            }
            shots += 1;
        }
        for (i, r) in local {
            cache.insert(i, r);
        }
    }
    let rest = weighted_norm(patches, &unshot);
    let residual = if norm > 0.0 { rest / norm } else { 0.0 };
    let area: Vec<f64> = patches.iter().map(|p| p.area).collect();
    let refs: Vec<Option<&Row>> = (0..n as u32).map(|i| cache.rows.get(&i)).collect();
    let recip = reciprocity(&refs, &area);
    Solution {
        b,
        iterations: shots,
        residual,
        converged: residual <= threshold,
        rows_computed,
        row_bytes: cache.peak,
        stats,
        reciprocity: recip,
        fell_back: false,
        occluded,
    }
}
