//! Piecewise-constant distributions in 1D and 2D, sampled by inverting their CDFs.

/// A piecewise-constant density on [0, 1) with one value per bin.
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution1D {
    func: Vec<f32>,
    cdf: Vec<f32>,
    integral: f32,
    /// A guide table: entry g is the bin that holds g/n (n bins), from which a sample's bin
    /// is found in a step or two instead of a binary search.
    guide: Vec<u32>,
}

impl Distribution1D {
    /// The distribution proportional to `func` (negative or non-finite values count as 0; an
    /// all-zero function becomes uniform).
    pub fn new(func: &[f32]) -> Self {
        let n = func.len().max(1);
        let func: Vec<f32> = if func.is_empty() {
            vec![1.0]
        } else {
            func.iter()
                .map(|&f| if f.is_finite() && f > 0.0 { f } else { 0.0 })
                .collect()
        };
        let mut cdf = vec![0f32; n + 1];
        let mut acc = 0f64;
        for i in 0..n {
            acc += func[i] as f64 / n as f64;
            cdf[i + 1] = acc as f32;
        }
        let integral = acc as f32;
        if integral > 0.0 {
            for c in &mut cdf[1..] {
                *c /= integral;
            }
        } else {
            for (i, c) in cdf.iter_mut().enumerate() {
                *c = i as f32 / n as f32;
            }
        }
        cdf[n] = 1.0;
        let guide = (0..n)
            .map(|g| Self::search(&cdf, g as f32 / n as f32) as u32)
            .collect();
        Self {
            func,
            cdf,
            integral,
            guide,
        }
    }

    /// The last bin whose CDF start is ≤ u, by binary search.
    fn search(cdf: &[f32], u: f32) -> usize {
        let n = cdf.len() - 1;
        cdf[1..n].partition_point(|&c| c <= u).min(n - 1)
    }

    /// Number of bins.
    pub fn len(&self) -> usize {
        self.func.len()
    }

    /// True when there are no bins (never: an empty input gives one bin).
    pub fn is_empty(&self) -> bool {
        self.func.is_empty()
    }

    /// The integral of the function over [0, 1).
    pub fn integral(&self) -> f32 {
        self.integral
    }

    /// The bin holding `u`'s inverse-CDF position, with the remapped `u` inside the bin.
    #[inline]
    pub fn sample_discrete(&self, u: f32) -> (usize, f32) {
        let n = self.func.len();
        // The last bin whose CDF start is ≤ u (`search`). A few bins (a mesh light's
        // triangles, say): the count of bin starts past the first that are ≤ u (the CDF never
        // decreases), without a branch on u. More: between the guide entries of the bin below
        // u's (which no round-off of u·n can put past it) and of three bins up (which u cannot
        // pass), by binary search: a peaked map (a sun in a sky) puts hundreds of dim bins
        // between two guide entries, which a forward walk from the first one stepped through
        // for the numbers that land there (few: the frames of a 1024 × 512 sky with a sun
        // took the same time either way, to the same bytes).
        let i = if n <= FEW_BINS {
            self.cdf[1..n].iter().map(|&c| (c <= u) as usize).sum()
        } else {
            let g = ((u * n as f32) as usize).min(n - 1).saturating_sub(1);
            let lo = self.guide[g] as usize;
            let hi = self.guide.get(g + 3).map_or(n - 1, |&h| h as usize);
            lo + self.cdf[lo + 1..hi + 1].partition_point(|&c| c <= u)
        };
        let (lo, hi) = (self.cdf[i], self.cdf[i + 1]);
        let du = if hi > lo {
            ((u - lo) / (hi - lo)).clamp(0.0, super::sampler::ONE_MINUS_EPSILON)
        } else {
            0.5
        };
        (i, du)
    }

    /// The probability of bin `i`.
    #[inline]
    pub fn discrete_pdf(&self, i: usize) -> f32 {
        self.cdf[i + 1] - self.cdf[i]
    }

    /// A continuous sample in [0, 1) with its density.
    #[inline]
    pub fn sample_continuous(&self, u: f32) -> (f32, f32, usize) {
        let (i, du) = self.sample_discrete(u);
        let x = (i as f32 + du) / self.func.len() as f32;
        (x, self.pdf(i), i)
    }

    /// The density of bin `i` (as a density over [0, 1)).
    #[inline]
    pub fn pdf(&self, i: usize) -> f32 {
        self.discrete_pdf(i) * self.func.len() as f32
    }
}

/// Distributions of at most this many bins find a sample's bin by counting.
const FEW_BINS: usize = 16;

/// A piecewise-constant density on [0,1)² from a grid of values (row `v`, column `u`).
#[derive(Clone, Debug, PartialEq)]
pub struct Distribution2D {
    conditional: Vec<Distribution1D>,
    marginal: Distribution1D,
    /// The density of each cell (row-major), as [`Distribution2D::sample`] computes it: one
    /// lookup for [`Distribution2D::pdf`] instead of two distributions' (an environment map's
    /// MIS density of every escaped ray).
    density: Vec<f32>,
}

impl Distribution2D {
    /// The distribution proportional to `func` with `nu` columns and `nv` rows (row-major).
    pub fn new(func: &[f32], nu: usize, nv: usize) -> Self {
        let conditional: Vec<Distribution1D> = (0..nv)
            .map(|v| Distribution1D::new(&func[v * nu..(v + 1) * nu]))
            .collect();
        let marginal =
            Distribution1D::new(&conditional.iter().map(|c| c.integral()).collect::<Vec<_>>());
        let density = conditional
            .iter()
            .enumerate()
            .flat_map(|(v, c)| {
                let pdf_v = marginal.pdf(v);
                (0..c.len()).map(move |u| c.pdf(u) * pdf_v)
            })
            .collect();
        Self {
            conditional,
            marginal,
            density,
        }
    }

    /// A point (u, v) and its density.
    #[inline]
    pub fn sample(&self, u: [f32; 2]) -> ([f32; 2], f32) {
        let (v, pdf_v, iv) = self.marginal.sample_continuous(u[1]);
        let (x, pdf_u, _) = self.conditional[iv].sample_continuous(u[0]);
        ([x, v], pdf_u * pdf_v)
    }

    /// The density at (u, v).
    #[inline]
    pub fn pdf(&self, p: [f32; 2]) -> f32 {
        let nv = self.conditional.len();
        let nu = self.density.len() / nv;
        let iv = ((p[1] * nv as f32) as usize).min(nv - 1);
        let iu = ((p[0] * nu as f32) as usize).min(nu - 1);
        self.density[iv * nu + iu]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The table of cell densities holds what the two distributions give, bit for bit, in
    /// every cell (zero rows and zero cells included), and what sampling reports.
    #[test]
    fn two_dimensional_densities_are_the_distributions_products() {
        let (nu, nv) = (7usize, 5usize);
        let mut rng = crate::sampling::Pcg32::new(4, 9);
        let mut f: Vec<f32> = (0..nu * nv).map(|_| rng.next_f32() * 3.0).collect();
        f[3] = 0.0;
        for u in 0..nu {
            f[2 * nu + u] = 0.0;
        }
        let d = Distribution2D::new(&f, nu, nv);
        for v in 0..nv {
            for u in 0..nu {
                let p = [(u as f32 + 0.5) / nu as f32, (v as f32 + 0.5) / nv as f32];
                let two = d.conditional[v].pdf(u) * d.marginal.pdf(v);
                assert_eq!(d.pdf(p).to_bits(), two.to_bits(), "cell ({u}, {v})");
            }
        }
        for _ in 0..1000 {
            let (p, pdf) = d.sample([rng.next_f32(), rng.next_f32()]);
            let cell = [
                ((p[0] * nu as f32).floor() + 0.5) / nu as f32,
                ((p[1] * nv as f32).floor() + 0.5) / nv as f32,
            ];
            assert_eq!(pdf.to_bits(), d.pdf(cell).to_bits());
        }
    }

    #[test]
    fn one_dimensional_by_hand() {
        let d = Distribution1D::new(&[1.0, 3.0]);
        assert!((d.integral() - 2.0).abs() < 1e-6);
        assert!((d.discrete_pdf(0) - 0.25).abs() < 1e-6);
        assert!((d.pdf(1) - 1.5).abs() < 1e-6);
        assert_eq!(d.sample_discrete(0.1).0, 0);
        assert_eq!(d.sample_discrete(0.3).0, 1);
        let (x, pdf, _) = d.sample_continuous(0.625);
        assert!((x - 0.75).abs() < 1e-6 && (pdf - 1.5).abs() < 1e-6);
        // Zero bins are never chosen.
        let z = Distribution1D::new(&[0.0, 2.0, 0.0]);
        for u in [0.0, 0.3, 0.999] {
            assert_eq!(z.sample_discrete(u).0, 1);
        }
        // All zero: uniform.
        let u = Distribution1D::new(&[0.0, 0.0]);
        assert!((u.discrete_pdf(1) - 0.5).abs() < 1e-6);
    }

    /// The count (few bins) and the guide table (more) find the bin the binary search finds,
    /// for every u near the bins' edges and the guide's own, with zero bins and a few huge
    /// ones, and with a peak (a sun's few bins holding nearly all the mass, so that hundreds
    /// of dim bins lie between two guide entries).
    #[test]
    fn the_guide_table_finds_the_searched_bin() {
        let mut rng = crate::sampling::Pcg32::new(8, 1);
        let sizes = [1usize, 2, 3, 7, FEW_BINS, FEW_BINS + 1, 64, 257];
        for (n, peaked) in sizes.iter().map(|&n| (n, false)).chain([
            (FEW_BINS + 1, true),
            (512, true),
            (4099, true),
        ]) {
            let f: Vec<f32> = (0..n)
                .map(|i| match (peaked, i % 5) {
                    (true, _) if i % 97 == 3 => 1e6 * (1.0 + rng.next_f32()),
                    (true, _) => rng.next_f32(),
                    (false, 0) => 0.0,
                    (false, 1) => 1000.0 * rng.next_f32(),
                    _ => rng.next_f32(),
                })
                .collect();
            let d = Distribution1D::new(&f);
            let mut us: Vec<f32> = (0..2000).map(|_| rng.next_f32()).collect();
            for &c in &d.cdf {
                us.extend([c, c.next_down(), c.next_up()]);
            }
            us.extend((0..=n).map(|g| g as f32 / n as f32));
            for u in us.into_iter().filter(|u| (0.0..1.0).contains(u)) {
                let i = d.sample_discrete(u).0;
                assert_eq!(i, Distribution1D::search(&d.cdf, u), "{n} bins, u = {u}");
                assert!(
                    d.func[i] > 0.0 || f.iter().all(|&x| x == 0.0),
                    "zero bin {i}"
                );
            }
        }
    }

    #[test]
    fn two_dimensional_pdf_matches_sampling() {
        let f = [1.0, 2.0, 0.0, 5.0, 1.0, 1.0];
        let d = Distribution2D::new(&f, 3, 2);
        let mut rng = crate::sampling::Pcg32::new(1, 1);
        for _ in 0..100 {
            let (p, pdf) = d.sample([rng.next_f32(), rng.next_f32()]);
            assert!((pdf - d.pdf(p)).abs() < 1e-4 * pdf.max(1.0));
            assert!(pdf > 0.0);
        }
        // The density integrates to one: mean of f over the grid is 10/6.
        assert!((d.pdf([0.9, 0.25]) - 0.0).abs() < 1e-6);
        assert!((d.pdf([0.1, 0.75]) - 5.0 / (10.0 / 6.0)).abs() < 1e-4);
    }
}
