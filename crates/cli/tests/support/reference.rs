//! Comparing candela's renders with a high-sample Mitsuba reference, block by block: the
//! channel means over the image must agree within a relative tolerance, and each block's mean
//! over independent candela renders must agree with the reference's within candela's own noise
//! (Student's t over the renders), away from the film's border.

use candela_render::Image;

/// The means of the `b`×`b` blocks of `img`, row by row.
pub fn block_means(img: &Image, b: usize) -> Vec<[f64; 3]> {
    let (w, h) = (img.width(), img.height());
    let mut out = Vec::new();
    for by in 0..h / b {
        for bx in 0..w / b {
            let mut s = [0f64; 3];
            for y in by * b..(by + 1) * b {
                for x in bx * b..(bx + 1) * b {
                    for (c, v) in img.get(x, y).to_array().into_iter().enumerate() {
                        s[c] += v as f64 / (b * b) as f64;
                    }
                }
            }
            out.push(s);
        }
    }
    out
}

/// Checks `runs` (the block means of n ≥ 2 independent renders) against the block means of
/// `reference` (`bw` blocks per row): channel means within `mean_tolerance` (relative), and at
/// most `allowed` inner blocks outside `t`·(standard error) of the reference (`t`: Student's t
/// for n − 1 degrees of freedom at the chosen α). The standard error is that of the difference:
/// candela's mean over the runs, and the reference's own noise, estimated from candela's as
/// coming from `ref_ratio` times the samples of one run (0 for a noiseless reference); it is
/// floored at 1e-3 of the larger of the block's and the image's mean reference value (blocks
/// without noise; the two renderers' colour-matching tables differ at that level).
pub fn check_against_reference(
    what: &str,
    runs: &[Vec<[f64; 3]>],
    reference: &[[f64; 3]],
    bw: usize,
    (mean_tolerance, t, allowed, ref_ratio): (f64, f64, usize, f64),
) {
    let n = runs.len();
    let bh = reference.len() / bw;
    let image_mean: Vec<f64> = (0..3)
        .map(|c| reference.iter().map(|b| b[c]).sum::<f64>() / reference.len() as f64)
        .collect();
    let mut mean_ours = [0f64; 3];
    let mut mean_theirs = [0f64; 3];
    let (mut tested, mut failed) = (0, 0);
    for (k, theirs) in reference.iter().enumerate() {
        let (bx, by) = (k % bw, k / bw);
        for c in 0..3 {
            let xs: Vec<f64> = runs.iter().map(|b| b[k][c]).collect();
            let m = xs.iter().sum::<f64>() / n as f64;
            mean_ours[c] += m / reference.len() as f64;
            mean_theirs[c] += theirs[c] / reference.len() as f64;
            if bx == 0 || by == 0 || bx == bw - 1 || by == bh - 1 {
                continue;
            }
            let var = xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1) as f64;
            let ref_var = if ref_ratio > 0.0 {
                var / ref_ratio
            } else {
                0.0
            };
            let floor = 1e-3 * theirs[c].abs().max(image_mean[c].abs());
            let se = (var / n as f64 + ref_var).sqrt().max(floor);
            tested += 1;
            if (m - theirs[c]).abs() > t * se {
                failed += 1;
                eprintln!(
                    "{what}: block ({bx}, {by}) channel {c}: {m:.5} vs Mitsuba {:.5} (se {se:.5})",
                    theirs[c]
                );
            }
        }
    }
    for c in 0..3 {
        let r = mean_ours[c] / mean_theirs[c];
        eprintln!(
            "{what}: channel {c} mean {:.5} vs Mitsuba {:.5} (ratio {r:.4})",
            mean_ours[c], mean_theirs[c]
        );
        assert!(
            (r - 1.0).abs() < mean_tolerance,
            "{what}: channel {c}: mean {} vs Mitsuba {}",
            mean_ours[c],
            mean_theirs[c]
        );
    }
    assert!(
        failed <= allowed,
        "{what}: {failed} of {tested} block tests failed"
    );
}
