//! Figures of merit of one design over a set of depths (the quantities a design sweep
//! compares, docs/model.md §9): sharp fractions from the closed-form depth of field, and
//! the worst and median resolution (max gap, §6) of each channel and of the union, plus
//! each channel's lit fraction and light per lit pixel.

use crate::infra::error::Result;
use crate::infra::parallel::check_threads;
use crate::model::design::{Design, Grid};
use crate::model::optics::{check_design_depths, design_sharp_fractions};
use crate::sampling::line::Axis;
use crate::sampling::line::Line;
use crate::sampling::rayspace::{trace_line_threads, Sample};
use crate::sampling::samples::{check_tol, design_new_samples};
use crate::sampling::samples2d::{check_tol_2d, check_window, coverage};

/// Median as NumPy computes it: the middle value, or the mean of the two middle values.
fn median(values: &mut [f64]) -> f64 {
    let n = values.len();
    values.sort_unstable_by(|a, b| a.total_cmp(b));
    if n % 2 == 1 {
        values[n / 2]
    } else {
        (values[n / 2 - 1] + values[n / 2]) / 2.0
    }
}

/// Names of the figures of merit of a design with `channels` channels, in the order of
/// [`design_figures_of_merit`]: `sharp_fraction_channel1`, …, `sharp_fraction_union`,
/// `max_gap_worst_channel1`, …, `_union`, `max_gap_median_channel1`, …, `_union`,
/// `lit_fraction_channel1`, …, `light_per_pixel_channel1`, … (5 C + 3 names).
pub fn design_metrics(channels: usize) -> Vec<String> {
    let mut out = Vec::with_capacity(5 * channels + 3);
    for (prefix, union) in [
        ("sharp_fraction", true),
        ("max_gap_worst", true),
        ("max_gap_median", true),
        ("lit_fraction", false),
        ("light_per_pixel", false),
    ] {
        out.extend((1..=channels).map(|c| format!("{prefix}_channel{c}")));
        if union {
            out.push(format!("{prefix}_union"));
        }
    }
    out
}

/// Figures of merit of `design` over the depths `z` (at least one, each > F), named by
/// [`design_metrics`] (docs/optimise.md, "A Design base"):
/// - sharp fraction of each channel and of the union: the share of [min z, max z] (log
///   depth) where the channel (any channel) is sharp, closed form (§2, §9);
/// - worst and median max gap over the depths of each channel and of the union (§6 with
///   §9's δ(z) = μ_1 z/L_1, chief samples along x). The 1-D analysis needs rect grids:
///   when any channel is hex every max-gap merit is NaN (the union needs all channels);
/// - lit fraction of each channel: lit pixels over pixels of the channel's line along x
///   (K_x Q for the ideal layout, M_x for the sensor layout);
/// - light per lit pixel of each channel: share × the mean integration-polygon area of its
///   lit pixels along x divided by L_1, the area being in ray space referred to channel 1's
///   array plane (§9): the 1-D étendue of a pixel [mm·rad] (μ d / v for a fully lit pixel
///   in Ng's setting), 0 when no pixel is lit.
///
/// The lit fraction and light per pixel of a hex channel are NaN.
pub fn design_figures_of_merit(
    design: &Design,
    z: &[f64],
    threshold_px: f64,
    tol: f64,
    n_threads: Option<usize>,
) -> Result<Vec<f64>> {
    check_threads(n_threads)?;
    check_tol(tol)?;
    check_design_depths(design.f_main, z)?;
    let lo = z.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = z.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (_, channels, union, _) = design_sharp_fractions(design, threshold_px, lo, hi)?;
    let (c, m) = (design.channels.len(), z.len());
    let mut out = Vec::with_capacity(5 * c + 3);
    out.extend(channels);
    out.push(union);
    if design.channels.iter().all(|ch| ch.grid == Grid::Rect) {
        let ns = design_new_samples(design, z, tol, Sample::Chief, n_threads)?;
        let rows: Vec<&[f64]> = ns.max_gap.chunks(m).collect();
        out.extend(
            rows.iter()
                .map(|g| g.iter().copied().fold(f64::NEG_INFINITY, f64::max)),
        );
        out.extend(rows.iter().map(|g| median(&mut g.to_vec())));
    } else {
        out.resize(out.len() + 2 * (c + 1), f64::NAN);
    }
    let mut lit_fraction = Vec::with_capacity(c);
    let mut light = Vec::with_capacity(c);
    for (i, ch) in design.channels.iter().enumerate() {
        if ch.grid != Grid::Rect {
            lit_fraction.push(f64::NAN);
            light.push(f64::NAN);
            continue;
        }
        let line = Line::of_channel(design, i as i64 + 1, Axis::X)?;
        let tr = trace_line_threads(&line, n_threads)?;
        let (lit, area) = tr
            .lit
            .iter()
            .zip(&tr.area)
            .filter(|(&l, _)| l)
            .fold((0usize, 0.0), |(n, s), (_, &a)| (n + 1, s + a));
        lit_fraction.push(lit as f64 / tr.lit.len() as f64);
        light.push(if lit == 0 {
            0.0
        } else {
            line.share * (area / lit as f64) / line.v_ref
        });
    }
    out.extend(lit_fraction);
    out.extend(light);
    Ok(out)
}

/// Prefixes of the 2-D merits, in the order of [`design_figures_of_merit_2d`]: each is
/// followed by one name per row (channel, then the union).
pub const PREFIXES_2D: [&str; 3] = [
    "covering_radius_worst",
    "covering_radius_median",
    "distinct_2d_median",
];

/// The 2-D merit names for the rows `rows` (e.g. `channel1`, …, `union`): each prefix of
/// [`PREFIXES_2D`] followed by every row, prefix by prefix.
fn names_2d(rows: &[String]) -> Vec<String> {
    PREFIXES_2D
        .iter()
        .flat_map(|p| rows.iter().map(move |r| format!("{p}_{r}")))
        .collect()
}

/// Names of the 2-D merits of a design with `channels` channels, in the order of
/// [`design_figures_of_merit_2d`]: `covering_radius_worst_channel1`, …, `_union`,
/// `covering_radius_median_channel1`, …, `_union`, `distinct_2d_median_channel1`, …,
/// `_union` (3 (C + 1) names).
pub fn design_metrics_2d(channels: usize) -> Vec<String> {
    let mut rows: Vec<String> = (1..=channels).map(|c| format!("channel{c}")).collect();
    rows.push("union".into());
    names_2d(&rows)
}

/// Check the arguments only the 2-D merits have, before any work: `tol` as the 2-D
/// distinct samples take it ((0, [`crate::sampling::samples2d::MAX_TOL_2D`]]) and `window` (finite,
/// > 0).
pub fn check_merits_2d(tol: f64, window: f64) -> Result<()> {
    check_tol_2d(tol)?;
    check_window(window)?;
    Ok(())
}

/// The 2-D merits of `design` over the depths `z`, named by [`design_metrics_2d`]: per row
/// (channel 1, …, channel C, union) of [`coverage`] at (`tol`, `window`), the worst
/// (largest) covering radius over the depths, its median (as NumPy's), both in δ(z) = μ_1
/// z/L_1 (+∞ when a depth's field holds no sample), and the median number of distinct 2-D
/// samples inside the central field.
pub fn design_figures_of_merit_2d(
    design: &Design,
    z: &[f64],
    tol: f64,
    window: f64,
    n_threads: Option<usize>,
) -> Result<Vec<f64>> {
    let cov = coverage(design, z, tol, window, n_threads)?;
    let m = z.len();
    let rows = design.channels.len() + 1;
    let mut out = Vec::with_capacity(3 * rows);
    let radii: Vec<&[f64]> = cov.covering_radius.chunks(m).collect();
    out.extend(
        radii
            .iter()
            .map(|r| r.iter().copied().fold(f64::NEG_INFINITY, f64::max)),
    );
    out.extend(radii.iter().map(|r| median(&mut r.to_vec())));
    out.extend(
        cov.distinct
            .chunks(m)
            .map(|d| median(&mut d.iter().map(|&n| n as f64).collect::<Vec<_>>())),
    );
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_like_numpy() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 2.0, 3.0]), 2.5);
        assert_eq!(median(&mut [1.0, f64::INFINITY]), f64::INFINITY);
    }

    #[test]
    fn seed_design_merits() {
        let cam = crate::model::camera::Camera::paper();
        let design = cam.design();
        let z: Vec<f64> = (0..50)
            .map(|i| 150.0 * (10_000.0f64 / 150.0).powf(i as f64 / 49.0))
            .collect();
        let g = design_figures_of_merit(&design, &z, 0.5, 1e-6, Some(1)).unwrap();
        let names = design_metrics(2);
        assert_eq!(names.len(), g.len());
        let at = |n: &str| g[names.iter().position(|x| x == n).unwrap()];
        assert_eq!(at("sharp_fraction_union"), 1.0); // the split sensor is sharp everywhere
        assert!(at("sharp_fraction_channel1") < 1.0);
        // The union resolves at least as well as each channel.
        let union = at("max_gap_worst_union");
        assert!(union <= at("max_gap_worst_channel1") && union <= at("max_gap_worst_channel2"));
        assert_eq!(at("lit_fraction_channel2"), 11.0 / 15.0);
        assert_eq!(at("lit_fraction_channel1"), 1.0);
        // a fully lit pixel of half 1 (Ng's setting): share × μ d / v
        let light = 0.5 * cam.mu * cam.d / cam.v;
        assert!((at("light_per_pixel_channel1") - light).abs() <= 1e-12 * light);
        assert!(design_figures_of_merit(&design, &[50.0], 0.5, 1e-6, None).is_err());
    }

    #[test]
    fn merits_2d_are_coverage_rows() {
        let design = crate::model::presets::preset("split3").unwrap();
        let z: Vec<f64> = (0..6)
            .map(|i| 150.0 * (10_000.0f64 / 150.0).powf(i as f64 / 5.0))
            .collect();
        let names = design_metrics_2d(3);
        assert_eq!(names.len(), 12);
        assert_eq!(names[0], "covering_radius_worst_channel1");
        assert_eq!(names[7], "covering_radius_median_union");
        assert_eq!(names[11], "distinct_2d_median_union");
        let f = design_figures_of_merit_2d(&design, &z, 1e-6, 4.0, Some(1)).unwrap();
        let cov = coverage(&design, &z, 1e-6, 4.0, Some(1)).unwrap();
        for row in 0..4 {
            let r = &cov.covering_radius[row * 6..(row + 1) * 6];
            let mut s = r.to_vec();
            s.sort_by(f64::total_cmp);
            assert_eq!(f[row], s[5]);
            assert_eq!(f[4 + row], (s[2] + s[3]) / 2.0);
            let mut d: Vec<u64> = cov.distinct[row * 6..(row + 1) * 6].to_vec();
            d.sort();
            assert_eq!(f[8 + row], (d[2] as f64 + d[3] as f64) / 2.0);
        }
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let e = design_figures_of_merit_2d(&design, &z, 1e-6, bad, None).unwrap_err();
            assert_eq!(e.parameter_name().as_deref(), Some("window"));
            let e = check_merits_2d(1e-6, bad).unwrap_err();
            assert_eq!(e.parameter_name().as_deref(), Some("window"));
        }
        let e = check_merits_2d(0.0, 4.0).unwrap_err();
        assert_eq!(e.parameter_name().as_deref(), Some("tol"));
    }
}
