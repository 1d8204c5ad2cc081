//! The SoA impact kernel: closed-form contact geometry and impulses for a
//! block of samples against the N ≤ 3 planes the placement makes touch.
//!
//! Every pass is a branch-free loop over the lanes of a block, written once
//! for [`Real`] and const N, so the loop vectoriser can use full-width SIMD
//! (see [`crate::lanes`]). Laws are chosen per pass, never per sample. Lanes whose
//! answer the fast path cannot vouch for are flagged [`Status::NEEDS_REFERENCE`] and solved
//! again by the f64 reference in `physics/`:
//! - G nearly singular: `det S < det_min` (S the unit-diagonal G; by
//!   Fischer's and Hadamard's inequalities every principal submatrix is then
//!   at least as well conditioned, so no subset solve can blow up);
//! - grazing contacts in f32 (`|v_n| < 1e-5 · (|v| + L|ω|)`), where the
//!   approaching test and the rebound ratio are not trustworthy (f32 rounds
//!   v_n to about 1e-7 of the scale, so above the margin the test cannot be
//!   misjudged; a misjudged lane would move v⁺ by only O(|v_n|) anyway,
//!   since every law is continuous in v_n);
//! - f32 energy changes within rounding of the `energy_gain` threshold;
//! - an LCP without an acceptable candidate (jammed, or rounding);
//! - a plane outside the placement that touches or is penetrated;
//! - with friction, a single-contact solve its certificate cannot vouch
//!   for, or Gauss–Seidel not converged (see `friction/`).

// Lane code indexes SoA arrays by lane and contact on purpose: the index
// form is what the loop vectoriser sees through.
#![allow(clippy::needless_range_loop, clippy::manual_memcpy)]

mod fallback;
pub mod flight;
mod friction;
mod geometry;
mod impulses;
mod lcp;
mod status;
mod strike;
mod variant;

use crate::config::Scene;
use crate::lanes::dispatch::BLOCK;
use crate::lanes::Real;

pub use fallback::{check_extra_planes, recompute, write_outcome, write_record, ContactRecord};
pub use friction::{frame, friction_impulses, Frame, FrictionConsts, Sweep};
pub use geometry::geometry;
pub use impulses::{impulses, post};
pub use status::Status;
pub use strike::Strike;
pub use variant::KernelVariant;

/// Constants of a scene for the kernel, in the lane type.
#[derive(Debug, Clone)]
pub struct Consts<T, const N: usize> {
    normal: [[T; 3]; N],
    k: [T; N],
    mass: T,
    inv_mass: T,
    inertia: [T; 3],
    inv_inertia: [T; 3],
    semi2: [T; 3],
    /// (b² − c², c² − a², a² − b²), for the lever arm in its sphere-exact form.
    dsq: [T; 3],
    nn: [[T; N]; N],
    /// G without rotational coupling (ρ = 0): `nn / m`, the same in every lane.
    g0: [[T; N]; N],
    length: T,
    det_min: T,
    graze: T,
    accept: T,
    feasible: T,
    /// When every touching plane's normal is ±e_k (exactly): k per plane.
    /// Then Aᵀn is ± row k of A and n·v is ±v_k, with no arithmetic.
    axes: Option<[usize; N]>,
    /// Coulomb friction of the touching planes.
    pub fr: FrictionConsts<T, N>,
}

impl<T: Real, const N: usize> Consts<T, N> {
    /// The rows of A the geometry passes read (bit r: row r): one per plane
    /// along an axis, else all.
    pub fn matrix_rows(&self) -> u8 {
        match self.axes {
            Some(rows) => rows.iter().fold(0, |m, &k| m | 1 << k),
            None => crate::sampler::ALL_ROWS,
        }
    }

    pub fn new(scene: &Scene) -> Self {
        assert_eq!(scene.touching().len(), N, "kernel width");
        let f32_lanes = T::EPSILON.to_f64() > 1e-10;
        let planes = scene.touching_planes();
        let body = scene.body();
        let s = body.semi_axes();
        let (a2, b2, c2) = (s.x * s.x, s.y * s.y, s.z * s.z);
        Self {
            normal: std::array::from_fn(|i| planes[i].normal().to_array().map(T::from_f64)),
            k: std::array::from_fn(|i| T::from_f64(planes[i].restitution())),
            mass: T::from_f64(body.mass()),
            inv_mass: T::from_f64(1.0 / body.mass()),
            inertia: body.inertia().to_array().map(T::from_f64),
            inv_inertia: body.inertia().recip().to_array().map(T::from_f64),
            semi2: [a2, b2, c2].map(T::from_f64),
            dsq: [
                (s.y - s.z) * (s.y + s.z),
                (s.z - s.x) * (s.z + s.x),
                (s.x - s.y) * (s.x + s.y),
            ]
            .map(T::from_f64),
            nn: std::array::from_fn(|i| {
                std::array::from_fn(|j| T::from_f64(planes[i].normal().dot(planes[j].normal())))
            }),
            g0: std::array::from_fn(|i| {
                std::array::from_fn(|j| {
                    T::from_f64(planes[i].normal().dot(planes[j].normal()))
                        * T::from_f64(1.0 / body.mass())
                })
            }),
            length: T::from_f64(body.length_scale()),
            det_min: T::from_f64(if f32_lanes { 1e-3 } else { 1e-8 }),
            graze: T::from_f64(if f32_lanes { 1e-5 } else { 0.0 }),
            accept: T::from_f64(if f32_lanes {
                1e-5
            } else {
                crate::physics::ACCEPT_RELATIVE
            }),
            feasible: T::from_f64(if f32_lanes {
                1e-3
            } else {
                crate::physics::FEASIBILITY_RELATIVE
            }),
            axes: {
                let axis = |n: [f64; 3]| {
                    let k = n.iter().position(|x| x.abs() == 1.0)?;
                    (n.iter().filter(|&&x| x == 0.0).count() == 2).then_some(k)
                };
                let ks: Vec<usize> = planes
                    .iter()
                    .filter_map(|p| axis(p.normal().to_array()))
                    .collect();
                (ks.len() == N).then(|| std::array::from_fn(|i| ks[i]))
            },
            fr: FrictionConsts::new(scene),
        }
    }
}

/// Contact geometry and pre-impact quantities of a block. Cache-line
/// aligned (as are [`LawOut`] and `sampler::Inputs`): every lane array then
/// starts on a 64-byte line, so full-width loads never split lines.
#[repr(C, align(64))]
pub struct Geometry<T, const N: usize> {
    pub vn: [[T; BLOCK]; N],
    pub rho: [[[T; BLOCK]; 3]; N],
    /// G per lane: only the upper triangle (`g[i][j]`, i ≤ j) is written.
    pub g: [[[T; BLOCK]; N]; N],
    pub t_before: [T; BLOCK],
    pub status: [Status; BLOCK],
}

/// Per-law results of a block.
#[repr(C, align(64))]
pub struct LawOut<T, const N: usize> {
    pub lambda: [[T; BLOCK]; N],
    pub vn_after: [[T; BLOCK]; N],
    pub v_after: [[T; BLOCK]; 3],
    pub w_after: [[T; BLOCK]; 3],
    pub t_after: [T; BLOCK],
    pub status: [Status; BLOCK],
    /// With friction, per contact: `|f_i|` (N·s) and `|c⁺_t,i|` (m/s).
    pub tangential: [[T; BLOCK]; N],
    pub sliding: [[T; BLOCK]; N],
}

impl<T: Real, const N: usize> Geometry<T, N> {
    pub fn new() -> Box<Self> {
        Box::new(Self {
            vn: [[T::ZERO; BLOCK]; N],
            rho: [[[T::ZERO; BLOCK]; 3]; N],
            g: [[[T::ZERO; BLOCK]; N]; N],
            t_before: [T::ZERO; BLOCK],
            status: [Status::NONE; BLOCK],
        })
    }
}

impl<T: Real, const N: usize> LawOut<T, N> {
    pub fn new() -> Box<Self> {
        Box::new(Self {
            lambda: [[T::ZERO; BLOCK]; N],
            vn_after: [[T::ZERO; BLOCK]; N],
            v_after: [[T::ZERO; BLOCK]; 3],
            w_after: [[T::ZERO; BLOCK]; 3],
            t_after: [T::ZERO; BLOCK],
            status: [Status::NONE; BLOCK],
            tangential: [[T::ZERO; BLOCK]; N],
            sliding: [[T::ZERO; BLOCK]; N],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::geometry::{geometry, well_conditioned};
    use super::lcp::{full_support, lane_g, lcp_block, lcp_lane};
    use super::*;
    use crate::config::{load_scene, Overrides};
    use crate::lanes::dispatch::BLOCK;
    use crate::sampler::rng::mix64;
    use crate::sampler::Inputs;

    fn consts<T: Real, const N: usize>(name: &str) -> Consts<T, N> {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("configs")
            .join(name);
        Consts::new(&load_scene(&path, &Overrides::default()).expect("shipped scene"))
    }

    /// `lcp_block` (certified empty and full supports, the rest enumerated
    /// in compacted chunks or, when many, in place) returns exactly what
    /// `lcp_lane` returns, lane by lane, on random SPD matrices: in blocks
    /// of mostly clear-cut LCPs (all contacts engaged, or none), and in
    /// blocks of LCPs built at and near the boundary between supports
    /// (impulses and slacks from 0 to 1 over ten decades), where the
    /// certificate must refuse.
    fn block_is_lane_by_lane<T: Real, const N: usize>(scene: &str) {
        let c = consts::<T, N>(scene);
        let mut state = 1u64;
        let mut next = || {
            state += 1;
            (mix64(state) >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut fast, mut slow, mut gathered, mut ill) = (0, 0, 0, 0);
        for block in 0..200 {
            let easy = block % 2 == 0;
            let mut geo = Geometry::<T, N>::new();
            let mut q = [[T::ZERO; BLOCK]; N];
            for s in 0..BLOCK {
                // G = BᵀB + εI with B random: symmetric positive definite;
                // in one lane of 32, B with two equal columns and ε = 0 (G
                // singular to rounding: ill-conditioned in both types).
                let mut b: [[f64; 3]; 3] =
                    std::array::from_fn(|_| std::array::from_fn(|_| next() - 0.5));
                let singular = s % 32 == 5;
                if singular {
                    for row in b.iter_mut() {
                        row[N - 1] = row[0];
                    }
                }
                let eps = if singular { 0.0 } else { 1e-3 };
                let g: [[f64; N]; N] = std::array::from_fn(|i| {
                    std::array::from_fn(|j| {
                        (0..3).map(|k| b[k][i] * b[k][j]).sum::<f64>()
                            + if i == j { eps } else { 0.0 }
                    })
                });
                for i in 0..N {
                    for j in i..N {
                        geo.g[i][j][s] = T::from_f64(g[i][j]);
                    }
                }
                // λ* ≥ 0 and w* ≥ 0, complementary, q = w* − Gλ*; or q at random.
                let tiny = |x: f64| 10f64.powf(-10.0 * x);
                let kind = next();
                let hard = !easy || kind >= 0.95;
                let lam: [f64; N] = std::array::from_fn(|_| {
                    if easy && kind < 0.9 {
                        0.05 + next()
                    } else if (easy && kind < 0.95) || next() < 0.3 {
                        0.0
                    } else {
                        tiny(next())
                    }
                });
                for i in 0..N {
                    let w = match (lam[i] > 0.0, hard) {
                        (true, _) => 0.0,
                        (false, true) => tiny(next()),
                        (false, false) => next(),
                    };
                    let glam: f64 = (0..N).map(|j| g[i][j] * lam[j]).sum();
                    let random = !easy && s % 4 == 0;
                    q[i][s] = T::from_f64(if random { next() - 0.7 } else { w - glam });
                }
            }
            let mut lam = [[T::ZERO; BLOCK]; N];
            let mut ok = [false; BLOCK];
            let mut conditioned = [false; BLOCK];
            lcp_block::<T, N, true>(&c, &geo, &q, &mut lam, &mut ok, &mut conditioned);
            let uncertain = (0..BLOCK)
                .filter(|&s| {
                    let qs: [T; N] = std::array::from_fn(|i| q[i][s]);
                    !full_support(&c, &lane_g::<T, N, true>(&c, &geo, s), &qs).1
                })
                .count();
            gathered += (uncertain > 0 && uncertain <= BLOCK / 4) as usize;
            for s in 0..BLOCK {
                let g = lane_g::<T, N, true>(&c, &geo, s);
                let qs: [T; N] = std::array::from_fn(|i| q[i][s]);
                let (want, want_ok) = lcp_lane(&c, &g, &qs);
                let got: [T; N] = std::array::from_fn(|i| lam[i][s]);
                assert_eq!((got, ok[s]), (want, want_ok), "lane {s}: G {g:?}, q {qs:?}");
                // The conditioning bit Newton's law takes from the LCP is
                // the geometry pass's.
                let want_conditioned = well_conditioned(&g, c.det_min);
                assert_eq!(conditioned[s], want_conditioned, "lane {s}: G {g:?}");
                ill += !want_conditioned as usize;
                if full_support(&c, &g, &qs).1 {
                    fast += 1;
                } else {
                    slow += 1;
                }
            }
        }
        // Every route was exercised: certified lanes, enumerated lanes, and
        // blocks whose few uncertain lanes were gathered.
        assert!(
            fast > 1000 && slow > 1000,
            "{fast} certified, {slow} enumerated"
        );
        assert!(gathered > 50, "{gathered} blocks gathered");
        assert!(ill > 0, "no ill-conditioned G drawn");
    }

    /// The geometry passes' axis route (rows of A, components of v) gives
    /// what the general one (products with the normals) gives, bit for bit,
    /// on drawn blocks: the corner's three planes, the same with walls
    /// facing −x and −y, and the floor alone, in both precisions.
    fn axis_geometry_is_the_general_one<T: Real, const N: usize>(text: &str) {
        let raw = Scene::parse("axes.toml", text).expect("toml");
        let scene = Scene::validate("axes.toml", text, raw).expect("valid scene");
        let fast = Consts::<T, N>::new(&scene);
        assert!(fast.axes.is_some(), "every normal is an axis");
        let general = Consts {
            axes: None,
            ..fast.clone()
        };
        let sampler = crate::sampler::Sampler::new(&scene);
        let mut x = Inputs::<T>::new();
        let (mut a, mut b) = (Geometry::<T, N>::new(), Geometry::<T, N>::new());
        let mut approaching = 0;
        for block in 0..50 {
            sampler.fill(block * BLOCK as u64, &mut x);
            geometry::<T, N, true>(&fast, &x, &mut a, true);
            geometry::<T, N, true>(&general, &x, &mut b, true);
            let bits = |g: &Geometry<T, N>| {
                let mut v: Vec<f64> = g.vn.iter().flatten().map(|t| t.to_f64()).collect();
                v.extend(g.rho.iter().flatten().flatten().map(|t| t.to_f64()));
                v.extend(
                    (0..N)
                        .flat_map(|i| (i..N).flat_map(move |j| g.g[i][j]))
                        .map(|t| t.to_f64()),
                );
                v.extend(g.t_before.iter().map(|t| t.to_f64()));
                v.extend(g.status.iter().map(|&s| s.bits() as f64));
                v.into_iter().map(f64::to_bits).collect::<Vec<u64>>()
            };
            assert_eq!(bits(&a), bits(&b), "block {block}");
            approaching += a
                .status
                .iter()
                .filter(|&&s| s.approaching_mask::<N>() != 0)
                .count();
        }
        assert!(
            approaching > 1000,
            "{approaching} lanes with an approaching contact"
        );
    }

    #[test]
    fn axis_geometry_is_the_general_one_on_axis_planes() {
        let corner = std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/corner3.toml"),
        )
        .expect("shipped scene");
        let facing_back = corner
            .replace("normal = [1.0, 0.0, 0.0]", "normal = [-1.0, 0.0, 0.0]")
            .replace("normal = [0.0, 1.0, 0.0]", "normal = [0.0, -1.0, 0.0]")
            .replace("mean = [-1.0, -1.0, -1.0]", "mean = [1.0, 1.0, -1.0]");
        assert_ne!(facing_back, corner);
        let floor = std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/floor.toml"),
        )
        .expect("shipped scene");
        for text in [&corner, &facing_back] {
            axis_geometry_is_the_general_one::<f32, 3>(text);
            axis_geometry_is_the_general_one::<f64, 3>(text);
        }
        axis_geometry_is_the_general_one::<f32, 1>(&floor);
        axis_geometry_is_the_general_one::<f64, 1>(&floor);
    }

    #[test]
    fn lcp_block_is_lcp_lane_f64_three_contacts() {
        block_is_lane_by_lane::<f64, 3>("corner3.toml");
    }

    #[test]
    fn lcp_block_is_lcp_lane_f32_three_contacts() {
        block_is_lane_by_lane::<f32, 3>("corner3.toml");
    }

    #[test]
    fn lcp_block_is_lcp_lane_two_contacts() {
        block_is_lane_by_lane::<f64, 2>("corner2_paper.toml");
        block_is_lane_by_lane::<f32, 2>("corner2_paper.toml");
    }
}
