//! Why the lanes are our own: glam's 4-lane SSE2 types,
//! sample by sample (array of structures), against the SoA lane kernel with
//! run-time dispatch (the widest SIMD the CPU has), on identical pre-drawn inputs of S1
//! (one floor, Newton = the closed form, f32). Kernel only: no sampling, no
//! statistics. Both compute the support point, lever arm, normal velocity,
//! G, the impulse, v⁺, ω⁺ and T⁺; the lane kernel also computes its
//! recompute checks.
//!
//! `cargo bench --bench lanes_vs_glam`

use std::path::Path;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::{Mat3A, Vec3A};
use impactmc::config::{load_scene, Overrides};
use impactmc::engine::kernel_block;
use impactmc::kernel::{Consts, Geometry, LawOut};
use impactmc::lanes::dispatch::BLOCK;
use impactmc::physics::Law;
use impactmc::sampler::{Inputs, Sampler};

const BLOCKS: usize = 256;

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/floor.toml");
    let scene = load_scene(
        &path,
        &Overrides {
            precision: Some(impactmc::config::Precision::F32),
            ..Overrides::default()
        },
    )
    .unwrap();
    let sampler = Sampler::new(&scene);
    let blocks: Vec<Box<Inputs<f32>>> = (0..BLOCKS)
        .map(|b| {
            let mut x = Inputs::<f32>::new();
            sampler.fill((b * BLOCK) as u64, &mut x);
            x
        })
        .collect();
    // The same inputs as arrays of structures for glam.
    let aos: Vec<(Mat3A, Vec3A, Vec3A)> = blocks
        .iter()
        .flat_map(|x| {
            (0..BLOCK).map(move |s| {
                let r = |k: usize| x.a[k][s];
                let a = Mat3A::from_cols(
                    Vec3A::new(r(0), r(3), r(6)),
                    Vec3A::new(r(1), r(4), r(7)),
                    Vec3A::new(r(2), r(5), r(8)),
                );
                (
                    a,
                    Vec3A::new(x.v[0][s], x.v[1][s], x.v[2][s]),
                    Vec3A::new(x.w[0][s], x.w[1][s], x.w[2][s]),
                )
            })
        })
        .collect();
    let body = scene.body();
    let semi = Vec3A::from(body.semi_axes().as_vec3());
    let (a, b, cc) = (semi.x, semi.y, semi.z);
    let dsq = Vec3A::new((b - cc) * (b + cc), (cc - a) * (cc + a), (a - b) * (a + b));
    let inv_j = Vec3A::from(body.inertia().recip().as_vec3());
    let j = Vec3A::from(body.inertia().as_vec3());
    let m = body.mass() as f32;
    let n = Vec3A::Z;
    let k = scene.planes()[0].plane.restitution() as f32;

    let mut g = c.benchmark_group("kernel_only_s1_newton_f32");
    g.throughput(Throughput::Elements((BLOCKS * BLOCK) as u64));
    g.sample_size(20).measurement_time(Duration::from_secs(3));
    g.bench_function("glam_vec3a_aos", |bch| {
        bch.iter(|| {
            let mut acc = 0f32;
            for &(rot, v, w) in &aos {
                let u = rot.transpose() * n;
                let du = semi * u;
                let h = du.length();
                let rho = dsq * Vec3A::new(u.y * u.z, u.z * u.x, u.x * u.y) * (-1.0 / h);
                let vn = n.dot(v) + rho.dot(w);
                let gii = 1.0 / m + rho.dot(rho * inv_j);
                let lambda = if vn < 0.0 { -(1.0 + k) * vn / gii } else { 0.0 };
                let v1 = v + n * (lambda / m);
                let w1 = w + rho * inv_j * lambda;
                acc += 0.5 * m * v1.length_squared() + 0.5 * (j * w1).dot(w1);
            }
            acc
        })
    });
    let consts = Consts::<f32, 1>::new(&scene);
    let mut geo = Geometry::<f32, 1>::new();
    let mut out = LawOut::<f32, 1>::new();
    g.bench_function("soa_lanes_dispatched", |bch| {
        bch.iter(|| {
            let mut acc = 0f32;
            for x in &blocks {
                // S1's variant: rotational coupling, one contact (no LCP).
                kernel_block::<f32, 1, true, false>(&consts, Law::Newton, x, &mut geo, &mut out);
                acc += out.t_after.iter().sum::<f32>();
            }
            acc
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
