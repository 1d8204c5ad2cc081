//! Kernel throughput per scene, law and precision (criterion), on one thread
//! so the figures are per core. End-to-end multi-thread figures come from
//! `impactmc run` (README, "Performance").
//!
//! `cargo bench --bench kernel` (add `-- corner3` to filter).

use std::path::Path;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use impactmc::config::Keep;
use impactmc::config::{load_scene, Overrides, Scene};
use impactmc::engine::{run, sample_block, RunOptions};
use impactmc::lanes::dispatch::BLOCK;
use impactmc::physics::{solve_impact, Law, Pose, State};
use impactmc::sampler::{Inputs, Sampler};

const SAMPLES: u64 = 1 << 18;

fn scene(name: &str, law: &str, precision: &str) -> Scene {
    scene_of(name, law, precision, SAMPLES)
}

fn scene_of(name: &str, law: &str, precision: &str, samples: u64) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("configs/{name}.toml"));
    load_scene(
        &path,
        &Overrides {
            samples: Some(samples),
            seed: Some(1),
            laws: Some(vec![law.into()]),
            precision: Some(precision.parse().expect("f32 or f64")),
            ..Overrides::default()
        },
    )
    .expect("shipped scene")
}

fn kernel(c: &mut Criterion) {
    let mut g = c.benchmark_group("kernel");
    g.throughput(Throughput::Elements(SAMPLES));
    g.sample_size(10)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_millis(500));
    let cases: &[(&str, &[&str])] = &[
        ("floor", &["newton"]),
        ("corner2_paper", &["newton", "paper"]),
        ("corner3", &["newton", "paper", "poisson", "pgs8"]),
    ];
    for (name, laws) in cases {
        for law in *laws {
            for precision in ["f32", "f64"] {
                let s = scene(name, law, precision);
                let opts = RunOptions {
                    threads: 1,
                    progress: false,
                    ..Default::default()
                };
                g.bench_function(BenchmarkId::new(format!("{name}/{law}"), precision), |b| {
                    b.iter(|| run(&s, &opts).expect("pool"))
                });
            }
        }
    }
    g.finish();
}

/// What each effect costs: every scene through its specialised kernel and
/// through the kernel with every effect compiled in (`--all-effects`), end
/// to end on one thread. `cargo bench --bench kernel -- effects`.
fn effects(c: &mut Criterion) {
    let mut g = c.benchmark_group("effects");
    g.throughput(Throughput::Elements(SAMPLES));
    g.sample_size(10)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_millis(500));
    for name in ["floor_sphere", "floor", "corner2_paper", "corner3"] {
        let s = scene(name, "newton", "f32");
        for all_effects in [false, true] {
            let opts = RunOptions {
                threads: 1,
                keep: if all_effects { Keep::ALL } else { Keep::NONE },
                ..Default::default()
            };
            let id = if all_effects {
                "all_effects"
            } else {
                "specialised"
            };
            g.bench_function(BenchmarkId::new(name, id), |b| {
                b.iter(|| run(&s, &opts).expect("pool"))
            });
        }
    }
    g.finish();
}

/// Friction, end to end on one thread: the frictional floor (S1, μ = 0.5)
/// and S3 with μ = 0.3 on every wall under each lane law, and the
/// frictionless floor and S3 through their own kernel and with the
/// frictional kernel kept (`--keep friction`). S3 with friction under
/// `newton` runs thousands of samples per second (Gauss–Seidel to its
/// limit), so it takes 2¹⁰ samples. `cargo bench --bench kernel -- friction`.
fn friction(c: &mut Criterion) {
    let mut g = c.benchmark_group("friction");
    g.sample_size(10)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_millis(500));
    let one = RunOptions {
        threads: 1,
        ..Default::default()
    };
    let cases: &[(&str, &str, &str, u64)] = &[
        ("floor_friction", "newton", "f32", SAMPLES),
        ("floor_friction", "newton", "f64", SAMPLES),
        ("floor_friction", "paper", "f32", SAMPLES),
        ("accuracy_corner3_friction", "newton", "f32", 1 << 10),
        ("accuracy_corner3_friction", "paper", "f32", 1 << 16),
        ("accuracy_corner3_friction", "pgs8", "f32", 1 << 14),
    ];
    for &(name, law, precision, samples) in cases {
        let s = scene_of(name, law, precision, samples);
        g.throughput(Throughput::Elements(samples));
        g.bench_function(BenchmarkId::new(format!("{name}/{law}"), precision), |b| {
            b.iter(|| run(&s, &one).expect("pool"))
        });
    }
    let kept = RunOptions {
        keep: "friction".parse().expect("an effect"),
        ..one.clone()
    };
    g.throughput(Throughput::Elements(SAMPLES));
    for name in ["floor", "corner3"] {
        let s = scene(name, "newton", "f32");
        for (id, opts) in [("specialised", &one), ("friction_kept", &kept)] {
            g.bench_function(BenchmarkId::new(name, id), |b| {
                b.iter(|| run(&s, opts).expect("pool"))
            });
        }
    }
    g.finish();
}

/// The draws alone (orientation, v, ω of S1), per precision.
/// `cargo bench --bench kernel -- sampler`.
fn sampler(c: &mut Criterion) {
    let mut g = c.benchmark_group("sampler");
    let blocks = 1024u64;
    g.throughput(Throughput::Elements(blocks * BLOCK as u64));
    g.sample_size(10)
        .measurement_time(Duration::from_secs(2))
        .warm_up_time(Duration::from_millis(300));
    let s = scene("floor", "newton", "f32");
    let sm = Sampler::new(&s);
    let mut x32 = Inputs::<f32>::new();
    let mut x64 = Inputs::<f64>::new();
    g.bench_function(BenchmarkId::new("floor", "f32"), |b| {
        b.iter(|| {
            for k in 0..blocks {
                sample_block(&sm, k * BLOCK as u64, &mut x32);
            }
            x32.v[0][7]
        })
    });
    g.bench_function(BenchmarkId::new("floor", "f64"), |b| {
        b.iter(|| {
            for k in 0..blocks {
                sample_block(&sm, k * BLOCK as u64, &mut x64);
            }
            x64.v[0][7]
        })
    });
    g.finish();
}

/// The scalar f64 reference, one sample at a time: the baseline the SoA
/// kernel is measured against.
fn reference(c: &mut Criterion) {
    let mut g = c.benchmark_group("reference");
    let n = 1u64 << 12;
    g.throughput(Throughput::Elements(n));
    g.sample_size(10)
        .measurement_time(Duration::from_secs(2))
        .warm_up_time(Duration::from_millis(300));
    for name in ["floor", "corner3"] {
        let s = scene(name, "newton", "f64");
        let sampler = Sampler::new(&s);
        let planes: Vec<_> = s.planes().iter().map(|p| p.plane).collect();
        g.bench_function(BenchmarkId::new(name, "newton"), |b| {
            b.iter(|| {
                let mut acc = 0.0;
                for i in 0..n {
                    let (a, v, w) = sampler.reference(i);
                    let o = solve_impact(
                        s.body(),
                        Pose {
                            rotation: a,
                            centre: s.centre(a),
                        },
                        State {
                            velocity: v,
                            omega: w,
                        },
                        &planes,
                        Law::Newton,
                        s.tolerance(),
                    )
                    .expect("≤ 16 contacts");
                    acc += o.energy_after / o.energy_before;
                }
                acc
            })
        });
    }
    g.finish();
}

/// The torque-free attitude of a block of `drop_corner` flights at one time
/// per lane: in lanes (f32, f64; the constants set up by the reference
/// beforehand, outside the timing) against the reference's `at`, one
/// motion at a time. Elements are poses.
fn flight(c: &mut Criterion) {
    use impactmc::kernel::flight::{poses, PoseLanes, Poses};
    use impactmc::physics::TorqueFree;
    let mut g = c.benchmark_group("flight");
    g.throughput(Throughput::Elements(BLOCK as u64));
    g.sample_size(20)
        .measurement_time(Duration::from_secs(2))
        .warm_up_time(Duration::from_millis(300));
    let s = scene("drop_corner", "newton", "f64");
    let sampler = Sampler::new(&s);
    let motions: Vec<TorqueFree> = (0..BLOCK as u64)
        .map(|i| {
            let (a, _, w) = sampler.reference(i);
            TorqueFree::new(s.body().inertia(), a, w)
        })
        .collect();
    let times: Vec<f64> = (0..BLOCK).map(|i| 0.3 + 0.001 * i as f64).collect();
    // What the lanes take as given: the reference's set-up of each motion.
    let starts: Vec<_> = (0..BLOCK as u64)
        .map(|i| {
            let (a, _, w) = sampler.reference(i);
            (a, w)
        })
        .collect();
    g.bench_function("setup_reference_f64", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for &(a, w) in &starts {
                acc += TorqueFree::new(s.body().inertia(), a, w).at(0.0).1.x;
            }
            acc
        })
    });
    g.bench_function("reference_f64", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for (m, &t) in motions.iter().zip(&times) {
                acc += m.at(t).1.x;
            }
            acc
        })
    });
    fn lanes<T: impactmc::lanes::Real>(
        g: &mut criterion::BenchmarkGroup<criterion::measurement::WallTime>,
        motions: &[TorqueFree],
        times: &[f64],
    ) {
        let mut c = PoseLanes::<T>::new();
        let mut t = [T::ZERO; BLOCK];
        for (s, (m, &ts)) in motions.iter().zip(times).enumerate() {
            c.set(s, m);
            t[s] = T::from_f64(ts);
        }
        let mut out = Poses::<T>::new();
        g.bench_function(format!("lanes_{}", T::NAME), |b| {
            b.iter(|| {
                poses(&c, &t, &mut out);
                out.omega[0][0]
            })
        });
    }
    lanes::<f64>(&mut g, &motions, &times);
    lanes::<f32>(&mut g, &motions, &times);

    // The time of impact of the first flights of 192 samples: the
    // reference one flight at a time, and the lanes (set-up included:
    // the reference's TorqueFree::new per lane). Elements are flights.
    use impactmc::kernel::flight::{times_of_impact, FlightLanes, Times};
    use impactmc::physics::{time_of_impact, Rotation};
    let impactmc::config::Placement::Drop(start) = s.placement() else {
        panic!("drop_corner is a drop scene")
    };
    let flights: Vec<_> = (0..BLOCK as u64)
        .map(|i| impactmc::engine::drop::start_of(start, &sampler, i))
        .collect();
    let planes: Vec<_> = s.planes().iter().map(|p| p.plane).collect();
    let fx = s.effects();
    let gravity = glam::DVec3::new(0.0, 0.0, -fx.gravity);
    g.bench_function("toi_reference_f64", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for m in &flights {
                let hit = time_of_impact(
                    s.body(),
                    m,
                    &planes,
                    gravity,
                    Rotation::Elliptic,
                    fx.toi_tolerance,
                    fx.horizon,
                );
                acc += hit.map_or(0.0, |h| h.time);
            }
            acc
        })
    });
    fn toi<T: impactmc::lanes::Real>(
        g: &mut criterion::BenchmarkGroup<criterion::measurement::WallTime>,
        s: &Scene,
        flights: &[impactmc::physics::Motion],
        planes: &[impactmc::physics::Plane],
        gravity: glam::DVec3,
    ) {
        let fx = s.effects();
        let mut f =
            FlightLanes::<T, 3>::new(s.body(), planes, gravity, fx.toi_tolerance, fx.horizon);
        let (mut poses, mut times) = (Poses::<T>::new(), Times::<T>::new());
        g.bench_function(format!("toi_lanes_{}", T::NAME), |b| {
            b.iter(|| {
                for (k, m) in flights.iter().enumerate() {
                    f.set(k, s.body(), m);
                }
                times_of_impact(&f, 400, &mut poses, &mut times);
                times.time[0]
            })
        });
    }
    toi::<f64>(&mut g, &s, &flights, &planes, gravity);
    toi::<f32>(&mut g, &s, &flights, &planes, gravity);
    g.finish();
}

criterion_group!(benches, kernel, effects, friction, sampler, reference, flight);
criterion_main!(benches);
