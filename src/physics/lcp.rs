//! Exact solution of the small contact LCPs by active-set enumeration:
//! find `λ ≥ 0` with `w = q + Gλ ≥ 0` and `λ·w = 0` (physics.md, laws 2–3).
//!
//! For a symmetric positive semi-definite `G`, a solvable LCP has a basic
//! solution whose support `S` makes `G_SS` non-singular, so enumerating the
//! non-singular principal submatrices finds it. Every solution gives the same
//! `Gλ` (so the same velocities). Subsets are tried in (size, bitmask) order,
//! and the first whose violation of the conditions is at rounding level
//! ([`ACCEPT_RELATIVE`]) wins: the smallest support is also the best
//! conditioned one, so an ill-conditioned larger support cannot amplify
//! rounding into the velocities (two floors 1e-6 rad apart). Failing that, the
//! candidate with the smallest violation wins. The answer is deterministic.

use super::SymMatrix;

/// Pivot threshold of the scaled Cholesky below which a principal submatrix
/// counts as singular. The golden cases are insensitive to it anywhere between
/// 1e-10 and 1e-30.
pub const SINGULAR_PIVOT: f64 = 1e-14;

/// Relative tolerance, in units of the problem's velocity scale, within which
/// a candidate's violation of `λ ≥ 0, w ≥ 0` is accepted as rounding.
pub const FEASIBILITY_RELATIVE: f64 = 1e-9;

/// A candidate whose violation is at most this times the velocity scale is
/// taken as exact.
pub const ACCEPT_RELATIVE: f64 = 1e-12;

/// The most contacts the enumeration accepts (2^16 subsets).
pub const MAX_LCP_CONTACTS: usize = 16;

/// Result of [`solve_lcp`].
#[derive(Debug, Clone, PartialEq)]
pub struct LcpSolution {
    /// Impulses `λ ≥ 0` (clamped: rounding never leaves a negative impulse).
    pub lambda: Vec<f64>,
    /// True when a candidate met the conditions within tolerance; false when
    /// the LCP has no solution (the returned λ is then the least-violating
    /// candidate, still finite).
    pub feasible: bool,
    /// Largest violation of `λ ≥ 0` or `w ≥ 0`, as a velocity (m/s).
    pub violation: f64,
}

/// Solves LCP(q, G) exactly for `q.len() ≤ MAX_LCP_CONTACTS`.
///
/// Panics if the dimensions disagree or exceed [`MAX_LCP_CONTACTS`]; callers
/// validate contact counts before they get here.
pub fn solve_lcp(g: &SymMatrix, q: &[f64]) -> LcpSolution {
    let n = q.len();
    assert_eq!(g.dim(), n, "LCP dimensions");
    assert!(n <= MAX_LCP_CONTACTS, "at most {MAX_LCP_CONTACTS} contacts");
    let scale = q.iter().fold(0f64, |m, x| m.max(x.abs()));
    if n == 0 || q.iter().all(|&x| x >= 0.0) {
        // λ = 0 is a solution (and the first subset).
        return LcpSolution {
            lambda: vec![0.0; n],
            feasible: true,
            violation: 0.0,
        };
    }
    let tolerance = FEASIBILITY_RELATIVE * scale;
    let accept = ACCEPT_RELATIVE * scale;
    let mut masks: Vec<u32> = (1..(1u32 << n)).collect();
    masks.sort_by_key(|m| (m.count_ones(), *m));

    let mut best: Option<(f64, Vec<f64>)> = None;
    // λ = 0 is the first candidate.
    let zero_violation = q.iter().fold(0f64, |m, &x| m.max(-x));
    best = pick(best, zero_violation, vec![0.0; n]);

    for mask in masks {
        let idx: Vec<usize> = (0..n).filter(|i| mask & (1 << i) != 0).collect();
        let rhs: Vec<f64> = idx.iter().map(|&i| -q[i]).collect();
        let Some(sol) = g.principal(&idx).solve_spd(&rhs, SINGULAR_PIVOT) else {
            continue;
        };
        let mut lambda = vec![0.0; n];
        for (&i, &x) in idx.iter().zip(&sol) {
            lambda[i] = x;
        }
        let w: Vec<f64> = g
            .mul_vec(&lambda)
            .iter()
            .zip(q)
            .map(|(gl, qi)| gl + qi)
            .collect();
        // Violations as velocities: −λ_i G_ii and the residual |w_i| on the
        // support, −w_j elsewhere; each charged with its own rounding bound
        // 8ε·(|q_i| + Σ_j |G_ij λ_j|), so that a nearly singular support with
        // huge cancelling impulses cannot pass for an exact solution.
        let mut violation = 0f64;
        for i in 0..n {
            let noise = 8.0
                * f64::EPSILON
                * (q[i].abs() + (0..n).map(|j| (g.get(i, j) * lambda[j]).abs()).sum::<f64>());
            let v = if mask & (1 << i) != 0 {
                (-lambda[i] * g.get(i, i)).max(w[i].abs())
            } else {
                -w[i]
            };
            violation = violation.max(v + noise);
        }
        if !violation.is_finite() {
            continue;
        }
        if violation <= accept {
            best = Some((violation, lambda));
            break;
        }
        best = pick(best, violation, lambda);
    }
    let (violation, mut lambda) = best.expect("λ = 0 is always a candidate");
    for x in &mut lambda {
        *x = x.max(0.0);
    }
    LcpSolution {
        lambda,
        feasible: violation <= tolerance,
        violation,
    }
}

fn pick(
    best: Option<(f64, Vec<f64>)>,
    violation: f64,
    lambda: Vec<f64>,
) -> Option<(f64, Vec<f64>)> {
    match best {
        Some((v, l)) if v <= violation => Some((v, l)),
        _ => Some((violation, lambda)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_contact_closed_form() {
        let g = SymMatrix::from_rows(&[vec![0.5]]);
        let s = solve_lcp(&g, &[-3.0]);
        assert!(s.feasible);
        assert_eq!(s.lambda, vec![6.0]);
    }

    #[test]
    fn picks_the_complementary_solution() {
        // q = (-1, 2), G = [[1, 0.5], [0.5, 1]]: λ = (1, 0), w = (0, 2.5).
        let g = SymMatrix::from_rows(&[vec![1.0, 0.5], vec![0.5, 1.0]]);
        let s = solve_lcp(&g, &[-1.0, 2.0]);
        assert!(s.feasible);
        assert!((s.lambda[0] - 1.0).abs() < 1e-15 && s.lambda[1] == 0.0);
    }

    #[test]
    fn infeasible_lcp_is_reported_not_nan() {
        // G = [[1, -1], [-1, 1]] (opposite normals), q = (-1, -1): no λ ≥ 0
        // makes both w ≥ 0, since w1 + w2 = q1 + q2 < 0.
        let g = SymMatrix::from_rows(&[vec![1.0, -1.0], vec![-1.0, 1.0]]);
        let s = solve_lcp(&g, &[-1.0, -1.0]);
        assert!(!s.feasible);
        assert!(s.lambda.iter().all(|x| x.is_finite() && *x >= 0.0));
    }
}
