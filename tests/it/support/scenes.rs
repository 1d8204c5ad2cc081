//! Proptest strategies for random impact cases, shared by every property test
//! (after nalgebra's `tests/proptest/mod.rs`), with a deterministic runner.

use glam::{DMat3, DQuat, DVec3};
use impactmc::physics::{ContactGeometry, Ellipsoid, Plane, Pose, State};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

/// A random case: body, pose, velocities and planes all touching the body.
#[derive(Debug, Clone)]
pub struct RandomCase {
    pub body: Ellipsoid,
    pub pose: Pose,
    pub state: State,
    pub planes: Vec<Plane>,
}

/// Runs `cases` cases from a fixed seed, so failures reproduce everywhere.
pub fn run<S: Strategy>(
    cases: u32,
    strategy: S,
    test: impl Fn(S::Value) -> Result<(), TestCaseError>,
) where
    S::Value: std::fmt::Debug,
{
    let config = Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    };
    let rng = TestRng::from_seed(RngAlgorithm::ChaCha, &[7u8; 32]);
    let mut runner = TestRunner::new_with_rng(config, rng);
    if let Err(e) = runner.run(&strategy, test) {
        panic!("{e}");
    }
}

pub fn unit_quaternion() -> impl Strategy<Value = DQuat> {
    // Four uniforms on [−1, 1], normalised: every unit quaternion can come
    // out, though not uniformly (this is not the Haar measure). The
    // properties tested hold for every orientation, so coverage is enough.
    prop::array::uniform4(-1.0f64..1.0)
        .prop_filter("non-degenerate", |q| {
            q.iter().map(|x| x * x).sum::<f64>() > 1e-3
        })
        .prop_map(|[w, x, y, z]| DQuat::from_xyzw(x, y, z, w).normalize())
}

pub fn unit_vector() -> impl Strategy<Value = DVec3> {
    prop::array::uniform3(-1.0f64..1.0)
        .prop_filter("non-degenerate", |v| {
            v.iter().map(|x| x * x).sum::<f64>() > 1e-3
        })
        .prop_map(|v| DVec3::from_array(v).normalize())
}

pub fn vec3(scale: f64) -> impl Strategy<Value = DVec3> {
    prop::array::uniform3(-scale..scale).prop_map(DVec3::from_array)
}

pub fn body() -> impl Strategy<Value = Ellipsoid> {
    (prop::array::uniform3(-1.0f64..1.0), -1.0f64..3.0).prop_map(|(e, m)| {
        Ellipsoid::new(e.map(|x| 10f64.powf(x)), 10f64.powf(m)).expect("valid body")
    })
}

/// `n_planes` planes with random normals, each placed tangent to the body,
/// and velocities scaled to the body.
pub fn case_with(planes: std::ops::RangeInclusive<usize>) -> impl Strategy<Value = RandomCase> {
    (
        body(),
        unit_quaternion(),
        vec3(2.0),
        prop::collection::vec((unit_vector(), 0.0f64..=1.0), planes),
        vec3(1.0),
        vec3(1.0),
    )
        .prop_map(|(body, q, centre, planes, v, w)| {
            let rotation = DMat3::from_quat(q);
            let planes = planes
                .into_iter()
                .map(|(n, k)| {
                    let probe = Plane::new(n.to_array(), 0.0, k).unwrap();
                    let h = ContactGeometry::new(&body, rotation, DVec3::ZERO, &probe).support;
                    Plane::new(n.to_array(), h - n.dot(centre), k).unwrap()
                })
                .collect();
            let l = body.length_scale();
            RandomCase {
                body,
                pose: Pose { rotation, centre },
                state: State {
                    velocity: v * l,
                    omega: w,
                },
                planes,
            }
        })
}
