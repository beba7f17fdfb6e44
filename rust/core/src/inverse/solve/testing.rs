//! Blocks the parts' tests share: a small factored block and the same rows given
//! explicitly.

use super::block::Block;
use crate::infra::csr::Csr;

/// A small factored block: nr × nc raw window over an nx × ny grid, each pixel's x and
/// y rows a contiguous run of 2–4 cells, some pixels not rows (weight 0).
pub(super) fn factored(nx: usize, ny: usize) -> (Block, Vec<Vec<f64>>, Vec<f64>, Vec<f64>) {
    let run = |n: usize, cols: usize, seed: usize| {
        let (mut indptr, mut indices, mut data) = (vec![0], vec![], vec![]);
        for i in 0..n {
            let len = 2 + (i + seed) % 3;
            let first = (i * (cols - len)) / n.max(1);
            for k in 0..len {
                indices.push((first + k) as u32);
                data.push(0.3 + 0.1 * ((i * 7 + k * 3 + seed) % 5) as f64);
            }
            indptr.push(indices.len());
        }
        Csr::new("test", indptr, indices, data, cols).unwrap()
    };
    let (nc, nr) = (7, 6);
    let px = run(nc, nx, 1);
    let py = run(nr, ny, 2);
    let w: Vec<f64> = (0..nr * nc)
        .map(|k| {
            if k % 5 == 3 {
                0.0
            } else {
                1.0 + (k % 4) as f64
            }
        })
        .collect();
    let y: Vec<f64> = (0..nr * nc).map(|k| ((k * 13) % 7) as f64 / 7.0).collect();
    // The explicit rows: norm · (py row b) ⊗ (px row a), dense over the cells.
    let norm = 1.5;
    let mut dense = vec![];
    for b in 0..nr {
        for a in 0..nc {
            let mut row = vec![0.0; nx * ny];
            let (js, vy) = py.row(b);
            let (is, vx) = px.row(a);
            for (&j, &u) in js.iter().zip(vy) {
                for (&i, &v) in is.iter().zip(vx) {
                    row[j as usize * nx + i as usize] += norm * u * v;
                }
            }
            dense.push(row);
        }
    }
    let block = Block::Factored {
        norm,
        px,
        py,
        w: w.clone(),
        y: y.clone(),
    };
    (block, dense, w, y)
}

pub(super) fn rows_of(dense: &[Vec<f64>], w: Vec<f64>, y: Vec<f64>) -> Block {
    let (mut indptr, mut indices, mut data) = (vec![0], vec![], vec![]);
    for row in dense {
        for (c, &v) in row.iter().enumerate() {
            if v != 0.0 {
                indices.push(c as u32);
                data.push(v);
            }
        }
        indptr.push(indices.len());
    }
    let a = Csr::new("test", indptr, indices, data, dense[0].len()).unwrap();
    Block::Rows { a, w, y }
}
