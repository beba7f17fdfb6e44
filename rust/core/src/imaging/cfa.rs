//! A Bayer colour filter array on the sensor (docs/model.md §12): which colour each raw
//! pixel records, the mosaic of one render per colour, and the grey raw of a mosaic.
//!
//! A pixel in raw row r, column c (row 0 at the top, the channel's own raw indices: the
//! whole Q K_y × Q K_x pixel array on the ideal layout, the sensor grid's on the sensor
//! layout) records colour `P[r mod 2][c mod 2]` of its pattern P, times that colour's
//! quantum efficiency (a plain factor). Colours are numbered 0 (red), 1 (green), 2 (blue).

use crate::infra::error::{Error, Result};

/// The colours' names, by index.
pub const COLOURS: [&str; 3] = ["red", "green", "blue"];

/// The four phases of the Bayer pattern, named by their top-left 2 × 2 block read row by
/// row (RGGB: red at (0, 0), green at (0, 1) and (1, 0), blue at (1, 1)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pattern {
    Rggb,
    Grbg,
    Gbrg,
    Bggr,
}

/// The patterns' names, as [`Pattern::parse`] takes them.
pub const PATTERNS: [&str; 4] = ["RGGB", "GRBG", "GBRG", "BGGR"];

impl Pattern {
    /// The pattern named `name` (one of [`PATTERNS`]), else an invalid `cfa` parameter.
    pub fn parse(name: &str) -> Result<Pattern> {
        match name {
            "RGGB" => Ok(Pattern::Rggb),
            "GRBG" => Ok(Pattern::Grbg),
            "GBRG" => Ok(Pattern::Gbrg),
            "BGGR" => Ok(Pattern::Bggr),
            _ => Err(Error::param("cfa", name, "one of RGGB, GRBG, GBRG, BGGR")),
        }
    }

    /// The 2 × 2 block's colours, row by row.
    fn block(self) -> [[usize; 2]; 2] {
        match self {
            Pattern::Rggb => [[0, 1], [1, 2]],
            Pattern::Grbg => [[1, 0], [2, 1]],
            Pattern::Gbrg => [[1, 2], [0, 1]],
            Pattern::Bggr => [[2, 1], [1, 0]],
        }
    }

    /// The colour (0 red, 1 green, 2 blue) of the pixel in raw row `r`, column `c`.
    pub fn colour(self, r: usize, c: usize) -> usize {
        self.block()[r % 2][c % 2]
    }
}

/// Checked quantum efficiencies: three finite factors in (0, 1].
pub fn check_qe(qe: [f64; 3]) -> Result<[f64; 3]> {
    for (k, &q) in qe.iter().enumerate() {
        if !(q > 0.0 && q <= 1.0) {
            return Err(Error::param(
                ["qe[0]", "qe[1]", "qe[2]"][k],
                q,
                format!("a quantum efficiency of {} in (0, 1]", COLOURS[k]),
            ));
        }
    }
    Ok(qe)
}

/// The colour of every pixel of a `rows` × `cols` raw, row-major.
pub fn colours(pattern: Pattern, rows: usize, cols: usize) -> Vec<u8> {
    (0..rows)
        .flat_map(|r| (0..cols).map(move |c| pattern.colour(r, c) as u8))
        .collect()
}

/// `values` holds one value per pixel of a `rows` × `cols` raw, or an error naming `name`.
fn check_len(name: &'static str, values: &[f64], rows: usize, cols: usize) -> Result<()> {
    if values.len() != rows.saturating_mul(cols) {
        return Err(Error::param(
            name,
            format!("{} values", values.len()),
            format!("the raw's {rows} x {cols} values"),
        ));
    }
    Ok(())
}

/// The mosaic of one raw per colour (`planes[k]`: colour k's noise-free raw, row-major
/// `rows` × `cols`): each pixel takes its colour's plane times that colour's QE.
pub fn mosaic(
    planes: [&[f64]; 3],
    rows: usize,
    cols: usize,
    pattern: Pattern,
    qe: [f64; 3],
) -> Result<Vec<f64>> {
    let qe = check_qe(qe)?;
    let n = rows
        .checked_mul(cols)
        .ok_or_else(|| Error::param("planes", format!("{rows} x {cols}"), "a raw's shape"))?;
    for (k, p) in planes.iter().enumerate() {
        check_len(["planes[0]", "planes[1]", "planes[2]"][k], p, rows, cols)?;
    }
    Ok((0..n)
        .map(|i| {
            let k = pattern.colour(i / cols, i % cols);
            planes[k][i] * qe[k]
        })
        .collect())
}

/// The grey raw of a mosaic: each pixel divided by its colour's QE (exact for a grey
/// scene, whose every colour has the same albedo).
pub fn grey(
    raw: &[f64],
    rows: usize,
    cols: usize,
    pattern: Pattern,
    qe: [f64; 3],
) -> Result<Vec<f64>> {
    let qe = check_qe(qe)?;
    check_len("raw", raw, rows, cols)?;
    Ok(raw
        .iter()
        .enumerate()
        .map(|(i, &v)| v / qe[pattern.colour(i / cols, i % cols)])
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each phase's 2 × 2 block by its name's letters, and the block repeating.
    #[test]
    fn phases_read_as_their_names() {
        for name in PATTERNS {
            let p = Pattern::parse(name).unwrap();
            for (i, ch) in name.chars().enumerate() {
                let want = "RGB".find(ch).unwrap();
                assert_eq!(p.colour(i / 2, i % 2), want, "{name} at {i}");
                assert_eq!(p.colour(i / 2 + 6, i % 2 + 4), want, "{name} repeated");
            }
        }
        assert!(Pattern::parse("rggb").is_err());
    }

    #[test]
    fn mosaic_and_grey_invert_for_a_grey_scene() {
        let (rows, cols) = (3, 5);
        let plane: Vec<f64> = (0..rows * cols).map(|i| 0.1 + i as f64).collect();
        let qe = [0.5, 0.8, 0.25];
        let m = mosaic([&plane, &plane, &plane], rows, cols, Pattern::Gbrg, qe).unwrap();
        assert_eq!(m[0], plane[0] * 0.8); // green at (0, 0)
        assert_eq!(m[1], plane[1] * 0.25); // blue at (0, 1)
        assert_eq!(m[cols], plane[cols] * 0.5); // red at (1, 0)
        let g = grey(&m, rows, cols, Pattern::Gbrg, qe).unwrap();
        for (a, b) in g.iter().zip(&plane) {
            assert!((a - b).abs() <= 1e-15 * b.abs());
        }
    }

    #[test]
    fn bad_qe_and_shapes_are_refused() {
        let p = vec![1.0; 4];
        for qe in [[0.0, 1.0, 1.0], [1.0, 1.5, 1.0], [1.0, 1.0, f64::NAN]] {
            assert!(mosaic([&p, &p, &p], 2, 2, Pattern::Rggb, qe).is_err());
        }
        assert!(mosaic([&p, &p, &p[..3]], 2, 2, Pattern::Rggb, [1.0; 3]).is_err());
        assert!(grey(&p, 2, 3, Pattern::Rggb, [1.0; 3]).is_err());
    }
}
