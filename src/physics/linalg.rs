//! Small dense symmetric linear algebra for the contact LCPs: a pivot-guarded
//! Cholesky solve on a principal submatrix and the Jacobi eigenvalue method.

/// A dense symmetric n×n matrix, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct SymMatrix {
    n: usize,
    data: Vec<f64>,
}

impl SymMatrix {
    pub fn zeros(n: usize) -> Self {
        Self {
            n,
            data: vec![0.0; n * n],
        }
    }

    pub fn from_rows(rows: &[Vec<f64>]) -> Self {
        let n = rows.len();
        let mut m = Self::zeros(n);
        for (i, row) in rows.iter().enumerate() {
            assert_eq!(row.len(), n, "row {i} of a {n}x{n} matrix");
            for (j, &x) in row.iter().enumerate() {
                m.set(i, j, x);
            }
        }
        m
    }

    pub fn dim(&self) -> usize {
        self.n
    }

    pub fn get(&self, i: usize, j: usize) -> f64 {
        self.data[i * self.n + j]
    }

    pub fn set(&mut self, i: usize, j: usize, value: f64) {
        self.data[i * self.n + j] = value;
    }

    /// `(M x)_i`.
    pub fn mul_vec(&self, x: &[f64]) -> Vec<f64> {
        (0..self.n)
            .map(|i| (0..self.n).map(|j| self.get(i, j) * x[j]).sum())
            .collect()
    }

    /// The principal submatrix on `idx`.
    pub fn principal(&self, idx: &[usize]) -> SymMatrix {
        let mut m = SymMatrix::zeros(idx.len());
        for (a, &i) in idx.iter().enumerate() {
            for (b, &j) in idx.iter().enumerate() {
                m.set(a, b, self.get(i, j));
            }
        }
        m
    }

    /// The unit-diagonal scaling `S = D^-½ M D^-½` with `D = diag M`.
    /// A zero diagonal entry leaves its row and column at zero.
    pub fn unit_diagonal(&self) -> SymMatrix {
        let s: Vec<f64> = (0..self.n)
            .map(|i| {
                let d = self.get(i, i);
                if d > 0.0 {
                    1.0 / d.sqrt()
                } else {
                    0.0
                }
            })
            .collect();
        let mut m = self.clone();
        for i in 0..self.n {
            for j in 0..self.n {
                m.set(i, j, self.get(i, j) * s[i] * s[j]);
            }
        }
        m
    }

    /// Solves `M x = b` for a symmetric positive (semi-)definite `M` by
    /// Cholesky on the unit-diagonal scaling of `M`. Returns `None` when a
    /// pivot of the scaled matrix falls below `pivot_threshold`: the
    /// submatrix is then treated as singular.
    pub fn solve_spd(&self, b: &[f64], pivot_threshold: f64) -> Option<Vec<f64>> {
        let n = self.n;
        let diag: Vec<f64> = (0..n).map(|i| self.get(i, i)).collect();
        if diag.iter().any(|&d| !(d > 0.0)) {
            return None;
        }
        if n == 1 {
            // Exact closed form for one contact.
            return Some(vec![b[0] / diag[0]]);
        }
        let scale: Vec<f64> = diag.iter().map(|d| 1.0 / d.sqrt()).collect();
        // L Lᵀ = S, stored in the lower triangle.
        let mut l = vec![0.0; n * n];
        for j in 0..n {
            let mut pivot = self.get(j, j) * scale[j] * scale[j];
            for k in 0..j {
                pivot -= l[j * n + k] * l[j * n + k];
            }
            if !(pivot > pivot_threshold) {
                return None;
            }
            let root = pivot.sqrt();
            l[j * n + j] = root;
            for i in j + 1..n {
                let mut x = self.get(i, j) * scale[i] * scale[j];
                for k in 0..j {
                    x -= l[i * n + k] * l[j * n + k];
                }
                l[i * n + j] = x / root;
            }
        }
        // S y = D^-½ b, x = D^-½ y.
        let mut y: Vec<f64> = (0..n).map(|i| b[i] * scale[i]).collect();
        for i in 0..n {
            for k in 0..i {
                y[i] -= l[i * n + k] * y[k];
            }
            y[i] /= l[i * n + i];
        }
        for i in (0..n).rev() {
            for k in i + 1..n {
                y[i] -= l[k * n + i] * y[k];
            }
            y[i] /= l[i * n + i];
        }
        Some((0..n).map(|i| y[i] * scale[i]).collect())
    }

    /// All eigenvalues of a symmetric matrix by cyclic Jacobi rotations,
    /// ascending. Accurate to about `eps · ‖M‖` in absolute terms.
    pub fn eigenvalues(&self) -> Vec<f64> {
        let n = self.n;
        let mut a = self.data.clone();
        for _sweep in 0..64 {
            let off: f64 = (0..n)
                .flat_map(|i| (0..n).filter(move |&j| j != i).map(move |j| (i, j)))
                .map(|(i, j)| a[i * n + j] * a[i * n + j])
                .sum();
            let diag: f64 = (0..n).map(|i| a[i * n + i] * a[i * n + i]).sum();
            // Converged when the off-diagonal mass is below ε² of the
            // diagonal's: further rotations change no eigenvalue by more
            // than rounding. (Exact zero is rarely reached in floating point.)
            if off <= 1e-34 * diag || !off.is_finite() {
                break;
            }
            for p in 0..n {
                for q in p + 1..n {
                    let apq = a[p * n + q];
                    if apq == 0.0 {
                        continue;
                    }
                    let app = a[p * n + p];
                    let aqq = a[q * n + q];
                    let theta = (aqq - app) / (2.0 * apq);
                    let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                    let t = if theta == 0.0 { 1.0 } else { t };
                    let c = 1.0 / (t * t + 1.0).sqrt();
                    let s = t * c;
                    for k in 0..n {
                        let akp = a[k * n + p];
                        let akq = a[k * n + q];
                        a[k * n + p] = c * akp - s * akq;
                        a[k * n + q] = s * akp + c * akq;
                    }
                    for k in 0..n {
                        let apk = a[p * n + k];
                        let aqk = a[q * n + k];
                        a[p * n + k] = c * apk - s * aqk;
                        a[q * n + k] = s * apk + c * aqk;
                    }
                    // The rotation annihilates a_pq; storing its rounding
                    // residue instead would keep `off` near ε²·diag and the
                    // sweeps from ever meeting the stopping test.
                    a[p * n + q] = 0.0;
                    a[q * n + p] = 0.0;
                }
            }
        }
        let mut ev: Vec<f64> = (0..n).map(|i| a[i * n + i]).collect();
        ev.sort_by(f64::total_cmp);
        ev
    }
}

/// Smallest eigenvalue of `S = D^-½ M D^-½` (`S_ii = 1`), the conditioning
/// measure behind the `degenerate` flag (tests/data/golden/README.md). For an
/// empty matrix it is 1.
pub fn smallest_eigenvalue_scaled(m: &SymMatrix) -> f64 {
    match m.dim() {
        0 | 1 => 1.0,
        2 => {
            // Closed form, exact to rounding: eigenvalues 1 ± |s12|.
            let s = m.unit_diagonal();
            1.0 - s.get(0, 1).abs()
        }
        _ => m.unit_diagonal().eigenvalues()[0],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jacobi_matches_known_spectrum() {
        // [[2,1,0],[1,2,1],[0,1,2]] has eigenvalues 2-√2, 2, 2+√2.
        let m = SymMatrix::from_rows(&[
            vec![2.0, 1.0, 0.0],
            vec![1.0, 2.0, 1.0],
            vec![0.0, 1.0, 2.0],
        ]);
        let ev = m.eigenvalues();
        let want = [2.0 - 2f64.sqrt(), 2.0, 2.0 + 2f64.sqrt()];
        for (g, w) in ev.iter().zip(want) {
            assert!((g - w).abs() < 1e-14, "{g} vs {w}");
        }
    }

    #[test]
    fn cholesky_solves_and_refuses_singular() {
        let m = SymMatrix::from_rows(&[vec![4.0, 2.0], vec![2.0, 3.0]]);
        let x = m.solve_spd(&[2.0, 1.0], 1e-14).unwrap();
        let r = m.mul_vec(&x);
        assert!((r[0] - 2.0).abs() < 1e-15 && (r[1] - 1.0).abs() < 1e-15);
        let sing = SymMatrix::from_rows(&[vec![1.0, 1.0], vec![1.0, 1.0]]);
        assert!(sing.solve_spd(&[1.0, 1.0], 1e-14).is_none());
    }

    #[test]
    fn near_parallel_pair_eigenvalue() {
        // Two unit normals 1e-6 rad apart: 1 - cos(1e-6) ≈ 5e-13.
        let c = 1e-6f64.cos();
        let m = SymMatrix::from_rows(&[vec![1.0, c], vec![c, 1.0]]);
        let ev = smallest_eigenvalue_scaled(&m);
        assert!((ev - 5e-13).abs() < 1e-16, "{ev}");
    }
}
