//! A sparse symmetric positive definite system in 3 x 3 blocks (a pose graph's
//! normal equations), solved by a block `L D L^T` factorisation.
//!
//! The nodes are eliminated in a minimum-degree order (each step takes the node
//! with the fewest remaining neighbours and joins those neighbours into a clique, the
//! fill), which keeps the factor of a trajectory with loop closures nearly as sparse
//! as the graph. The elimination also gives the factor's pattern: node `k`'s column
//! holds its neighbours at the moment it is eliminated. The same pattern serves the
//! Takahashi recursion for the marginal covariances (`Z = L^-T D^-1 L^-1` on the
//! factor's pattern), so every pose's covariance costs about one factorisation.

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap};

use nalgebra::{Matrix3, Vector3};

use crate::error::{LaserError, Result};

/// The elimination order and the factor's pattern of a graph.
#[derive(Debug, Clone, PartialEq)]
pub struct Pattern {
    /// `order[k]` is the node eliminated `k`-th.
    pub order: Vec<usize>,
    /// `position[node]` is its place in the order.
    pub position: Vec<usize>,
    /// For each place `k`, the places of the later nodes in its factor column, sorted.
    pub columns: Vec<Vec<usize>>,
}

fn insert_sorted(v: &mut Vec<usize>, x: usize) {
    if let Err(i) = v.binary_search(&x) {
        v.insert(i, x);
    }
}

fn remove_sorted(v: &mut Vec<usize>, x: usize) {
    if let Ok(i) = v.binary_search(&x) {
        v.remove(i);
    }
}

impl Pattern {
    /// The minimum-degree pattern of `n` nodes joined by `edges`.
    pub fn new(n: usize, edges: &[(usize, usize)]) -> Result<Self> {
        let mut adj: Vec<Vec<usize>> = vec![Vec::new(); n];
        for &(a, b) in edges {
            if a >= n || b >= n {
                return Err(LaserError::dimension(format!(
                    "edge ({a}, {b}) in a graph of {n} nodes"
                )));
            }
            if a != b {
                insert_sorted(&mut adj[a], b);
                insert_sorted(&mut adj[b], a);
            }
        }
        let mut heap: BinaryHeap<Reverse<(usize, usize)>> =
            (0..n).map(|v| Reverse((adj[v].len(), v))).collect();
        let mut done = vec![false; n];
        let (mut order, mut neighbours_at) = (Vec::with_capacity(n), Vec::with_capacity(n));
        while let Some(Reverse((degree, v))) = heap.pop() {
            if done[v] || degree != adj[v].len() {
                continue; // a stale entry: v's degree changed since it was pushed
            }
            done[v] = true;
            let nb = std::mem::take(&mut adj[v]);
            for (i, &a) in nb.iter().enumerate() {
                remove_sorted(&mut adj[a], v);
                for &b in &nb[i + 1..] {
                    insert_sorted(&mut adj[a], b);
                    insert_sorted(&mut adj[b], a);
                }
            }
            for &a in &nb {
                heap.push(Reverse((adj[a].len(), a)));
            }
            order.push(v);
            neighbours_at.push(nb);
        }
        let mut position = vec![0; n];
        for (k, &v) in order.iter().enumerate() {
            position[v] = k;
        }
        let columns = neighbours_at
            .into_iter()
            .map(|nb| {
                let mut c: Vec<usize> = nb.iter().map(|&v| position[v]).collect();
                c.sort_unstable();
                c
            })
            .collect();
        Ok(Pattern {
            order,
            position,
            columns,
        })
    }

    fn slot(&self, col: usize, row: usize) -> Option<usize> {
        self.columns[col].binary_search(&row).ok()
    }
}

/// The factor `L D L^T` of a system on a [`Pattern`].
#[derive(Debug, Clone)]
pub struct Factor<'p> {
    pattern: &'p Pattern,
    /// `l[k][s]`: the block of `L` at row `columns[k][s]`, column `k` (places).
    l: Vec<Vec<Matrix3<f64>>>,
    d: Vec<Matrix3<f64>>,
    d_inv: Vec<Matrix3<f64>>,
}

fn spd_inverse(m: &Matrix3<f64>, k: usize) -> Result<Matrix3<f64>> {
    let sym = (m + m.transpose()) * 0.5;
    sym.cholesky()
        .map(|c| c.inverse())
        .filter(|inv| inv.iter().all(|v| v.is_finite()))
        .ok_or_else(|| {
            LaserError::Numerical(format!(
                "the system is not positive definite at node block {k}"
            ))
        })
}

impl<'p> Factor<'p> {
    /// Factors the system whose diagonal blocks are `diag` (by node) and whose
    /// off-diagonal blocks are `off[(a, b)]` = block at row `a`, column `b` (by node;
    /// each pair once, either way round; pairs must be edges of the pattern).
    pub fn new(
        pattern: &'p Pattern,
        diag: &[Matrix3<f64>],
        off: &HashMap<(usize, usize), Matrix3<f64>>,
    ) -> Result<Self> {
        let n = pattern.order.len();
        if diag.len() != n {
            return Err(LaserError::dimension(format!(
                "{} diagonal blocks for {n} nodes",
                diag.len()
            )));
        }
        let mut work: Vec<Vec<Matrix3<f64>>> = pattern
            .columns
            .iter()
            .map(|c| vec![Matrix3::zeros(); c.len()])
            .collect();
        let mut d: Vec<Matrix3<f64>> = pattern.order.iter().map(|&v| diag[v]).collect();
        for (&(a, b), block) in off {
            let (pa, pb) = (pattern.position[a], pattern.position[b]);
            let (row, col, value) = if pa > pb {
                (pa, pb, *block)
            } else {
                (pb, pa, block.transpose())
            };
            let s = pattern
                .slot(col, row)
                .ok_or_else(|| LaserError::dimension(format!("block ({a}, {b}) is not an edge")))?;
            work[col][s] += value;
        }
        let mut d_inv = Vec::with_capacity(n);
        for k in 0..n {
            let inv = spd_inverse(&d[k], pattern.order[k])?;
            let col = std::mem::take(&mut work[k]);
            let rows = &pattern.columns[k];
            // Right-looking update of the later columns: A_ij -= A_ik D_k^-1 A_jk^T.
            for (si, &i) in rows.iter().enumerate() {
                let left = col[si] * inv;
                for (sj, &j) in rows.iter().enumerate().take(si + 1) {
                    let update = left * col[sj].transpose();
                    if i == j {
                        d[i] -= update;
                    } else {
                        // i > j: the block at row i of column j (a clique edge).
                        let s = pattern
                            .slot(j, i)
                            .expect("the elimination clique is in the pattern");
                        work[j][s] -= update;
                    }
                }
            }
            work[k] = col.iter().map(|a| a * inv).collect();
            d_inv.push(inv);
        }
        Ok(Factor {
            pattern,
            l: work,
            d,
            d_inv,
        })
    }

    /// Solves the system for `rhs` (by node).
    pub fn solve(&self, rhs: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
        let p = self.pattern;
        let n = p.order.len();
        let mut y: Vec<Vector3<f64>> = p.order.iter().map(|&v| rhs[v]).collect();
        for k in 0..n {
            let yk = y[k];
            for (s, &i) in p.columns[k].iter().enumerate() {
                y[i] -= self.l[k][s] * yk;
            }
        }
        for (yk, d_inv) in y.iter_mut().zip(&self.d_inv) {
            *yk = d_inv * *yk;
        }
        for k in (0..n).rev() {
            let mut acc = y[k];
            for (s, &i) in p.columns[k].iter().enumerate() {
                acc -= self.l[k][s].transpose() * y[i];
            }
            y[k] = acc;
        }
        let mut out = vec![Vector3::zeros(); n];
        for (k, &v) in p.order.iter().enumerate() {
            out[v] = y[k];
        }
        out
    }

    /// The diagonal blocks of the inverse (each node's marginal covariance), by the
    /// Takahashi recursion on the factor's pattern.
    pub fn marginals(&self) -> Vec<Matrix3<f64>> {
        let p = self.pattern;
        let n = p.order.len();
        let mut z_diag = vec![Matrix3::zeros(); n];
        let mut z_off: Vec<Vec<Matrix3<f64>>> = p
            .columns
            .iter()
            .map(|c| vec![Matrix3::zeros(); c.len()])
            .collect();
        // z(i, j) for places i, j > k, both in column k's rows (a clique).
        let get = |z_diag: &[Matrix3<f64>],
                   z_off: &[Vec<Matrix3<f64>>],
                   i: usize,
                   j: usize|
         -> Matrix3<f64> {
            match i.cmp(&j) {
                std::cmp::Ordering::Equal => z_diag[i],
                std::cmp::Ordering::Greater => z_off[j][p.slot(j, i).expect("clique")],
                std::cmp::Ordering::Less => z_off[i][p.slot(i, j).expect("clique")].transpose(),
            }
        };
        for k in (0..n).rev() {
            let rows = &p.columns[k];
            let mut col = vec![Matrix3::zeros(); rows.len()];
            for (si, &i) in rows.iter().enumerate() {
                let mut acc = Matrix3::zeros();
                for (sj, &j) in rows.iter().enumerate() {
                    acc -= get(&z_diag, &z_off, i, j) * self.l[k][sj];
                }
                col[si] = acc;
            }
            let mut zkk = self.d_inv[k];
            for (s, c) in col.iter().enumerate() {
                zkk -= self.l[k][s].transpose() * c;
            }
            z_diag[k] = (zkk + zkk.transpose()) * 0.5;
            z_off[k] = col;
        }
        let mut out = vec![Matrix3::zeros(); n];
        for (k, &v) in p.order.iter().enumerate() {
            out[v] = z_diag[k];
        }
        out
    }

    /// The factor's diagonal blocks `D` (by place), for tests.
    pub fn d(&self) -> &[Matrix3<f64>] {
        &self.d
    }
}
