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
use impactmc::drop::{start_of, DropCtx};
use impactmc::output::samples::{Floats, SampleRows};
use impactmc::physics::{solve_impact, time_of_impact, Law, Motion, Pose, Rotation, State};
use impactmc::sampler::Sampler;
use impactmc::stats::accumulators::{RunAcc, Shape};

/// One impact's row: the walk (sample, law), bounce, planes, and the float
/// columns (`samples::drop_columns`).
struct Row {
    walk: (u64, u32),
    planes: u16,
    f: Vec<f64>,
}

impl Row {
    fn interval(&self) -> f64 {
        self.f[1]
    }
    fn motion(&self) -> Motion {
        let v3 = |k: usize| DVec3::new(self.f[k], self.f[k + 1], self.f[k + 2]);
        let q = DQuat::from_xyzw(self.f[6], self.f[7], self.f[8], self.f[5]);
        Motion {
            centre: v3(2),
            rotation: DMat3::from_quat(q),
            velocity: v3(9),
            omega: v3(12),
        }
    }
    /// The state after the impact.
    fn after(&self) -> (DVec3, DVec3) {
        let v3 = |k: usize| DVec3::new(self.f[k], self.f[k + 1], self.f[k + 2]);
        (v3(18), v3(21))
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
    let out = (0..rows.index.len())
        .map(|r| Row {
            walk: (rows.index[r], rows.law[r]),
            planes: rows.ints[1][r],
            f: cols.iter().map(|c| c[r]).collect(),
        })
        .collect();
    (acc, out)
}

/// The reference's next impact from `start` under `law`: the time to it
/// (over touches without an impulse), the planes that took an impulse and
/// the state after. `None` if it flies away or cannot be solved.
fn reference_impact(
    scene: &Scene,
    start: Motion,
    law: Law,
) -> Option<(f64, u16, DVec3, DVec3, DMat3)> {
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
            return Some((time, mask, o.after.velocity, o.after.omega, m.rotation));
        }
    }
    None
}

/// What the impact-by-impact comparison found.
#[derive(Debug, Default)]
struct Agreement {
    impacts: usize,
    /// Impacts whose planes differ from the reference's, and those among
    /// them where a second plane was within `near` of contact.
    other_planes: usize,
    other_planes_near: usize,
    /// The largest differences where the planes agree: the time to the
    /// impact (s), and the state after relative to the velocity scale
    /// |v| + a_max |ω| before it.
    time: f64,
    after: f64,
    /// The same at the 99th percentile.
    time_p99: f64,
    after_p99: f64,
}

fn agreement(scene: &Scene, samples: u64, near: f64) -> Agreement {
    let (_, rows) = rows(scene, samples);
    let Placement::Drop(start) = *scene.placement() else {
        unreachable!()
    };
    let sampler = Sampler::new(scene);
    let boxes = impactmc::sampler::rng::drop_start_rng(scene.seed());
    let reach = scene.body().semi_axes().max_element();
    let mut a = Agreement::default();
    let (mut times, mut afters, mut rots) = (Vec::new(), Vec::new(), Vec::new());
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
            _ => start_of(&start, &sampler, &boxes, row.walk.0),
        };
        a.impacts += 1;
        let want = reference_impact(scene, from, law);
        let Some((time, mask, v, w, r)) = want else {
            a.other_planes += 1;
            if a.other_planes < 6 {
                println!(
                    "none: walk {:?} interval {} energy {} d0 {} vn {}",
                    row.walk,
                    row.interval(),
                    row.f[15],
                    row.f[24],
                    row.f[25]
                );
                let fx = scene.effects();
                let planes: Vec<_> = scene.planes().iter().map(|p| p.plane).collect();
                let hit = time_of_impact(
                    scene.body(),
                    &from,
                    &planes,
                    DVec3::new(0.0, 0.0, -fx.gravity),
                    Rotation::exact_for(scene.body()),
                    fx.toi_tolerance,
                    fx.horizon,
                );
                println!(
                    "   ref hit: {:?}",
                    hit.map(|h| (h.time, h.distances, h.iterations))
                );
            }
            continue;
        };
        if mask != row.planes {
            a.other_planes += 1;
            let mut d: Vec<f64> = (0..scene.planes().len())
                .map(|i| row.f[24 + 4 * i])
                .collect();
            d.sort_by(f64::total_cmp);
            a.other_planes_near += (d.len() > 1 && d[1] <= near) as usize;
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
        let rel = m.rotation.transpose() * r;
        let angle = ((rel.x_axis.x + rel.y_axis.y + rel.z_axis.z - 1.0) / 2.0)
            .clamp(-1.0, 1.0)
            .acos();
        rots.push(angle);
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
    rots.sort_by(f64::total_cmp);
    if !rots.is_empty() {
        println!(
            "rotation: median {:e} p99 {:e} max {:e}",
            rots[rots.len() / 2],
            rots[rots.len() * 99 / 100],
            rots[rots.len() - 1]
        );
    }
    a
}

#[test]
fn explore() {
    for name in ["drop_corner", "drop_dice", "drop_dice_frictionless"] {
        for precision in ["f64", "f32"] {
            let s = shipped_scene(name, precision);
            let a = agreement(&s, 2000, 1e-3);
            println!("{name} {precision}: {a:?}");
        }
    }
}
