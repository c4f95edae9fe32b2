//! Rows of the form-factor matrix: one patch's non-zero F_ij as sorted column indices and f32
//! values (8 bytes per entry), the dense accumulator the form-factor methods fill them with,
//! and statistics of their quality (row sums, reciprocity).

/// One row of the form-factor matrix.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Row {
    /// Column indices j, sorted.
    pub cols: Vec<u32>,
    /// F_ij for each column.
    pub vals: Vec<f32>,
    /// The part of the patch's hemisphere covered by surfaces without a patch on the side it
    /// sees (the back of a one-sided surface, the inside of a solid) or closer than half the
    /// patch size: near 1 when the patch's centre is hidden (under a box standing on it,
    /// behind a light mounted just below it).
    pub occluded: f32,
}

impl Row {
    /// Σ_j F_ij.
    pub fn sum(&self) -> f64 {
        self.vals.iter().map(|&v| v as f64).sum()
    }

    /// F_ij (0 when absent).
    pub fn get(&self, j: u32) -> f32 {
        self.cols
            .binary_search(&j)
            .map(|k| self.vals[k])
            .unwrap_or(0.0)
    }

    /// Memory held, in bytes.
    pub fn bytes(&self) -> usize {
        self.cols.capacity() * 4 + self.vals.capacity() * 4 + std::mem::size_of::<Row>()
    }
}

/// A dense accumulator for one row (f64 sums) with the list of touched columns.
#[derive(Clone, Debug, Default)]
pub(crate) struct RowAcc {
    dense: Vec<f64>,
    touched: Vec<u32>,
}

impl RowAcc {
    /// An accumulator for `n` patches.
    pub fn new(n: usize) -> Self {
        Self {
            dense: vec![0.0; n],
            touched: Vec::new(),
        }
    }

    /// Adds `v` to column `j`.
    #[inline]
    pub fn add(&mut self, j: u32, v: f64) {
        let d = &mut self.dense[j as usize];
        if *d == 0.0 {
            self.touched.push(j);
        }
        *d += v;
        if *d == 0.0 {
            // Keep the entry marked as touched.
            *d = f64::MIN_POSITIVE;
        }
    }

    /// The row, resetting the accumulator.
    pub fn finish(&mut self) -> Row {
        self.touched.sort_unstable();
        let mut row = Row {
            cols: Vec::with_capacity(self.touched.len()),
            vals: Vec::with_capacity(self.touched.len()),
            occluded: 0.0,
        };
        for &j in &self.touched {
            let v = std::mem::take(&mut self.dense[j as usize]);
            if v > 1e-30 {
                row.cols.push(j);
                row.vals.push(v as f32);
            }
        }
        self.touched.clear();
        row
    }
}

/// Quality statistics of a set of rows.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct RowStats {
    /// Rows counted.
    pub rows: u64,
    /// Smallest row sum.
    pub sum_min: f64,
    /// Largest row sum.
    pub sum_max: f64,
    /// Sum of the row sums.
    pub sum_total: f64,
}

impl RowStats {
    /// Adds a row's sum.
    pub fn add(&mut self, s: f64) {
        if self.rows == 0 {
            self.sum_min = s;
            self.sum_max = s;
        } else {
            self.sum_min = self.sum_min.min(s);
            self.sum_max = self.sum_max.max(s);
        }
        self.sum_total += s;
        self.rows += 1;
    }
}

/// Reciprocity over the pairs (i, j) with i among at most 256 evenly spaced rows and j's row
/// known: (Σ|A_i F_ij − A_j F_ji| / Σ(A_i F_ij + A_j F_ji), the largest relative difference
/// among pairs whose larger F is ≥ 0.01, pairs checked).
pub(crate) fn reciprocity(rows: &[Option<&Row>], area: &[f64]) -> (f64, f64, u64) {
    let (mut num, mut den, mut worst, mut pairs) = (0f64, 0f64, 0f64, 0u64);
    let stride = rows.len().div_ceil(256).max(1);
    for i in (0..rows.len()).step_by(stride) {
        let Some(ri) = rows[i] else { continue };
        for (&j, &fij) in ri.cols.iter().zip(&ri.vals) {
            let j = j as usize;
            let Some(Some(rj)) = rows.get(j) else {
                continue;
            };
            let fji = rj.get(i as u32);
            let (a, b) = (area[i] * fij as f64, area[j] * fji as f64);
            num += (a - b).abs();
            den += a + b;
            pairs += 1;
            if (fij as f64).max(fji as f64) >= 0.01 && a + b > 0.0 {
                worst = worst.max((a - b).abs() / (0.5 * (a + b)));
            }
        }
    }
    (if den > 0.0 { num / den } else { 0.0 }, worst, pairs)
}
