//! Drops in lanes against the f64 reference, impact by impact. A drop is
//! chaotic (a rattle in a corner, a spinning die): rounding differences of
//! 1e-16 grow from bounce to bounce, in the reference itself as much as in
//! the lanes. So each impact of the lanes is checked against the reference
//! started where the lanes' previous impact left the body (the release, for
//! the first): the same planes, the same time to the impact and the same
//! state after it. The walks as a whole are checked by their statistics
//! (`drop_runs`).

use crate::support::shipped_scene;

use glam::{DMat3, DQuat, DVec3};
use impactmc::config::{Keep, Placement, Scene};
use impactmc::engine::drop::{start_of, DropCtx};
use impactmc::output::columns::RowLayout;
use impactmc::output::samples::{Floats, SampleRows};
use impactmc::physics::{solve_impact, time_of_impact, Law, Motion, Pose, Rotation, State};
use impactmc::sampler::Sampler;
use impactmc::stats::accumulators::{RunAcc, Shape};
use impactmc::stats::drops::Ending;

/// One impact's row: the walk (sample, law), bounce, planes, and the float
/// columns the comparison reads (`output::columns`, the drop table), in
/// [`READ`] order.
struct Row {
    walk: (u64, u32),
    planes: u16,
    f: Vec<f64>,
}

/// The drop-row float columns a [`Row`] keeps, by name.
const READ: [&str; 20] = [
    "interval",
    "centre_x",
    "centre_y",
    "centre_z",
    "q_w",
    "q_x",
    "q_y",
    "q_z",
    "v_x",
    "v_y",
    "v_z",
    "omega_x",
    "omega_y",
    "omega_z",
    "v_after_x",
    "v_after_y",
    "v_after_z",
    "omega_after_x",
    "omega_after_y",
    "omega_after_z",
];

impl Row {
    fn interval(&self) -> f64 {
        self.f[0]
    }
    fn motion(&self) -> Motion {
        let v3 = |k: usize| DVec3::new(self.f[k], self.f[k + 1], self.f[k + 2]);
        let q = DQuat::from_xyzw(self.f[5], self.f[6], self.f[7], self.f[4]);
        Motion {
            centre: v3(1),
            rotation: DMat3::from_quat(q),
            velocity: v3(8),
            omega: v3(11),
        }
    }
    /// The state after the impact.
    fn after(&self) -> (DVec3, DVec3) {
        let v3 = |k: usize| DVec3::new(self.f[k], self.f[k + 1], self.f[k + 2]);
        (v3(14), v3(17))
    }
}

fn rows(scene: &Scene, count: u64) -> (RunAcc, Vec<Row>) {
    let Placement::Drop(start) = *scene.placement() else {
        panic!("a drop scene")
    };
    let ctx = DropCtx::new(scene, start, Keep::default());
    let mut acc = RunAcc::shaped(Shape::of(scene));
    let mut rows = SampleRows::of_scene(scene);
    ctx.run(0, count, &mut acc, Some(&mut rows));
    acc.flush();
    let Floats::F64(cols) = &rows.floats else {
        panic!("drop rows are f64")
    };
    let layout = RowLayout::of(scene);
    let at = |name: &str| {
        layout
            .floats
            .iter()
            .position(|c| c.name == name)
            .unwrap_or_else(|| panic!("no drop column {name}"))
    };
    let read: Vec<usize> = READ.iter().map(|n| at(n)).collect();
    let planes = layout
        .ints
        .iter()
        .position(|c| c.name == "planes")
        .expect("planes");
    let out = (0..rows.index.len())
        .map(|r| Row {
            walk: (rows.index[r], rows.law[r]),
            planes: rows.ints[planes][r],
            f: read.iter().map(|&k| cols[k][r]).collect(),
        })
        .collect();
    (acc, out)
}

/// The reference's next impact from `start` under `law`: the time to it
/// (over touches without an impulse), the planes that took an impulse and
/// the state after. `None` if it flies away or cannot be solved.
fn reference_impact(scene: &Scene, start: Motion, law: Law) -> Option<(f64, u16, DVec3, DVec3)> {
    let fx = scene.effects();
    let planes: Vec<_> = scene.planes().iter().map(|p| p.plane).collect();
    let gravity = DVec3::new(0.0, 0.0, -fx.gravity);
    let rotation = Rotation::exact_for(scene.body());
    let tol = scene.tolerance().max(fx.toi_tolerance);
    let (mut m, mut time) = (start, 0.0);
    for _ in 0..8 {
        let hit = time_of_impact(
            scene.body(),
            &m,
            &planes,
            gravity,
            rotation,
            fx.toi_tolerance,
            fx.horizon,
        )?;
        time += hit.time;
        m = hit.motion;
        let pose = Pose {
            rotation: m.rotation,
            centre: m.centre,
        };
        let state = State {
            velocity: m.velocity,
            omega: m.omega,
        };
        let solve = |law| solve_impact(scene.body(), pose, state, &planes, law, tol);
        let o = solve(law).or_else(|_| solve(Law::Newton)).ok()?;
        let mask = o
            .contacts
            .iter()
            .enumerate()
            .filter(|(_, c)| c.impulse > 0.0)
            .fold(0u16, |s, (i, _)| s | 1 << i);
        if mask != 0 {
            return Some((time, mask, o.after.velocity, o.after.omega));
        }
    }
    None
}

/// What the impact-by-impact comparison found.
#[derive(Debug, Default)]
struct Agreement {
    impacts: usize,
    /// Impacts whose planes differ from the reference's (or where the
    /// reference, from the same state, finds no impact).
    other_planes: usize,
    /// The largest differences where the planes agree: the time to the
    /// impact (s), and the state after relative to the velocity scale
    /// |v| + a_max |ω| before it.
    time: f64,
    after: f64,
    /// The same at the 99th percentile.
    time_p99: f64,
    after_p99: f64,
}

fn agreement(scene: &Scene, samples: u64) -> Agreement {
    let (_, rows) = rows(scene, samples);
    let Placement::Drop(start) = *scene.placement() else {
        unreachable!()
    };
    let sampler = Sampler::new(scene);
    let reach = scene.body().semi_axes().max_element();
    let mut a = Agreement::default();
    let (mut times, mut afters) = (Vec::new(), Vec::new());
    for (k, row) in rows.iter().enumerate() {
        let law = scene.laws()[row.walk.1 as usize];
        let from = match k.checked_sub(1).map(|j| &rows[j]) {
            Some(prev) if prev.walk == row.walk => {
                let (v, w) = prev.after();
                Motion {
                    velocity: v,
                    omega: w,
                    ..prev.motion()
                }
            }
            _ => start_of(&start, &sampler, row.walk.0),
        };
        a.impacts += 1;
        let want = reference_impact(scene, from, law);
        let Some((time, mask, v, w)) = want else {
            a.other_planes += 1;
            continue;
        };
        if mask != row.planes {
            a.other_planes += 1;
            continue;
        }
        let m = row.motion();
        let scale = m.velocity.length() + reach * m.omega.length();
        let (gv, gw) = row.after();
        let dv = (gv - v)
            .abs()
            .max_element()
            .max((gw - w).abs().max_element() * reach);
        times.push((row.interval() - time).abs());
        afters.push(dv / scale);
    }
    for (v, worst, p99) in [
        (&mut times, &mut a.time, &mut a.time_p99),
        (&mut afters, &mut a.after, &mut a.after_p99),
    ] {
        v.sort_by(f64::total_cmp);
        *worst = v.last().copied().unwrap_or(0.0);
        *p99 = v.get(v.len() * 99 / 100).copied().unwrap_or(0.0);
    }
    a
}

const SCENES: [&str; 3] = ["drop_corner", "drop_dice", "drop_dice_frictionless"];

/// f64 lanes: over 10⁴ samples of every shipped drop scene, every impact
/// on the reference's planes, at its time to 1e-9 s and with its state
/// after to 1e-9 of the velocity scale (measured 2026-12-04: at most
/// 5e-13 s and 2e-11).
#[test]
fn f64_lanes_are_the_reference_impact_by_impact() {
    for name in SCENES {
        let a = agreement(&shipped_scene(name, "f64"), 10_000);
        assert!(a.impacts > 40_000, "{name}: {a:?}");
        assert_eq!(a.other_planes, 0, "{name}: {a:?}");
        assert!(a.time <= 1e-9 && a.after <= 1e-9, "{name}: {a:?}");
    }
}

/// f32 lanes: the search stops within the f32 floor of contact (256 ulp of
/// the largest semi-axis), and each impact is then located at contact in
/// f64 from the lanes' attitude (or, where another plane is within what
/// that attitude resolves, by the reference). So every impact is on the
/// reference's planes, at its time and with its state after but for the
/// f32 rounding of the attitude and of the impulses. The documented
/// tolerance, over 10⁴ samples of every shipped drop scene (measured
/// 2026-12-06 in brackets): no impact on other planes (none); at the 99th
/// percentile, times to 1e-6 s and states after to 1e-5 of the velocity
/// scale for the corner (6e-8 s, 8e-7), 2e-5 s and 5e-4 for the dice,
/// whose late bounces rock with normal speeds of mm/s (2e-6 s, 6e-5).
#[test]
fn f32_lanes_agree_with_the_reference_within_the_documented_tolerance() {
    for (name, time, after) in [
        ("drop_corner", 1e-6, 1e-5),
        ("drop_dice", 2e-5, 5e-4),
        ("drop_dice_frictionless", 2e-5, 5e-4),
    ] {
        let a = agreement(&shipped_scene(name, "f32"), 10_000);
        assert!(a.impacts > 40_000, "{name}: {a:?}");
        assert_eq!(a.other_planes, 0, "{name}: {a:?}");
        assert!(a.time_p99 <= time && a.after_p99 <= after, "{name}: {a:?}");
    }
}

/// The lanes' walks and the reference's, run as whole runs, give the same
/// statistics within Monte Carlo error, drop_corner and drop_dice in both
/// precisions: every ending's
/// and the first impact's plane fractions within 4 standard errors, and the
/// mean energy ratio of each of the first three bounces within 4 standard
/// errors.
#[test]
fn lane_statistics_agree_with_the_reference() {
    for (name, precision) in [
        ("drop_corner", "f64"),
        ("drop_corner", "f32"),
        ("drop_dice", "f64"),
        ("drop_dice", "f32"),
    ] {
        {
            let s = shipped_scene(name, precision);
            let n = 20_000;
            let (lanes, _) = rows(&s, n);
            let reference = {
                let Placement::Drop(start) = *s.placement() else {
                    unreachable!()
                };
                let ctx = DropCtx::new(&s, start, Keep::default()).by_reference();
                let mut acc = RunAcc::shaped(Shape::of(&s));
                ctx.run(0, n, &mut acc, None);
                acc.flush();
                acc
            };
            let (a, b) = (&lanes.drops[0], &reference.drops[0]);
            let close = |what: &str, x: u64, y: u64| {
                let (p, q) = (x as f64 / n as f64, y as f64 / n as f64);
                let se = ((p * (1.0 - p) + q * (1.0 - q)) / n as f64)
                    .sqrt()
                    .max(1.0 / n as f64);
                assert!(
                    (p - q).abs() <= 4.0 * se,
                    "{name} {precision} {what}: {p} vs {q}"
                );
            };
            for (k, (x, y)) in a.endings.iter().zip(&b.endings).enumerate() {
                if k == Ending::Stalled as usize && precision == "f32" {
                    // The documented exception: f32 walks that rock within
                    // the lanes' floor are flown on by the reference from
                    // a state up to a floor's width off, and a few of
                    // those may stall in a rolling contact (measured
                    // 2026-12-04 over 20,000 walks: none of the corner's
                    // or the die's under newton, 2 of the die's under
                    // stronge; the reference's own: none).
                    assert!(*x as f64 <= 1e-3 * n as f64, "{name} f32 stalled: {x}");
                    continue;
                }
                close(&format!("ending {k}"), *x, *y);
            }
            for (m, (x, y)) in a.bounces[0].sets.iter().zip(&b.bounces[0].sets).enumerate() {
                close(&format!("first planes {m}"), *x, *y);
            }
            for k in 0..3 {
                let (x, y) = (&a.bounces[k].energy_ratio, &b.bounces[k].energy_ratio);
                let se =
                    (x.sd().powi(2) / x.count() as f64 + y.sd().powi(2) / y.count() as f64).sqrt();
                assert!(
                    (x.mean() - y.mean()).abs() <= 4.0 * se,
                    "{name} {precision} bounce {k}: {} vs {}",
                    x.mean(),
                    y.mean()
                );
            }
        }
    }
}
