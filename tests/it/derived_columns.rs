//! The per-sample columns people used to compute by hand: each swept
//! field's value, the pose as Bryan angles and whether the sample impacted
//! under a law, against what the same rows and summary say otherwise.

use arrow_array::cast::AsArray;
use arrow_array::types::{Float32Type, Float64Type, UInt16Type, UInt32Type};
use glam::{DMat3, DQuat, DVec3};

use crate::support::{assert_succeeded, bin, column, json_file, read_parquet, repo, tmpdir};

/// Rx(ψ)·Ry(θ)·Rz(φ) from the paper's eq. 8–11, written out here.
fn bryan_matrix(psi: f64, theta: f64, phi: f64) -> DMat3 {
    let (sx, cx) = psi.sin_cos();
    let (sy, cy) = theta.sin_cos();
    let (sz, cz) = phi.sin_cos();
    let rx = DMat3::from_cols(DVec3::X, DVec3::new(0.0, cx, sx), DVec3::new(0.0, -sx, cx));
    let ry = DMat3::from_cols(DVec3::new(cy, 0.0, -sy), DVec3::Y, DVec3::new(sy, 0.0, cy));
    let rz = DMat3::from_cols(DVec3::new(cz, sz, 0.0), DVec3::new(-sz, cz, 0.0), DVec3::Z);
    rx * ry * rz
}

/// On a sweep of S1 (f32): `sweep_PATH` holds each point's value as the
/// summary gives it; the Bryan angles rebuild the quaternion's rotation
/// (to f32 rounding) within their ranges; `impacted_LAW` is the approach
/// bits of `flags_LAW` without `penetrating`, and its mean per point is the
/// summary's `impacting`.
#[test]
fn derived_columns_agree_with_the_rows_and_the_summary() {
    let d = tmpdir("derived-columns");
    let out = d.join("out");
    let o = bin()
        .args([
            "run",
            "--samples",
            "2000",
            "--per-sample",
            "--format",
            "json",
        ])
        .arg("--out")
        .arg(&out)
        .arg(repo("configs/sweep_aspect_ratio.toml"))
        .output()
        .unwrap();
    assert_succeeded(&o);
    let summary = json_file(&out.join("summary.json"));
    let rows = read_parquet(&out.join("samples.parquet"));
    let f32s = |name: &str| -> Vec<f64> {
        column::<Float32Type>(&rows, name)
            .into_iter()
            .map(f64::from)
            .collect()
    };
    let f64s = |name: &str| column::<Float64Type>(&rows, name);
    let point = column::<UInt32Type>(&rows, "point");
    let impacted: Vec<bool> = rows
        .iter()
        .flat_map(|b| {
            b.column_by_name("impacted_newton")
                .unwrap()
                .as_boolean()
                .iter()
                .map(|x| x.unwrap())
                .collect::<Vec<_>>()
        })
        .collect();
    let flags = column::<UInt16Type>(&rows, "flags_newton");
    let points = summary["points"].as_array().unwrap();
    for axis in summary["sweep"]["axes"].as_array().unwrap() {
        let path = axis["path"].as_str().unwrap();
        let name = impactmc::output::sweep_column(path);
        for (p, v) in point.iter().zip(f64s(&name)) {
            assert_eq!(
                points[*p as usize]["values"][path].as_f64(),
                Some(v),
                "{name}"
            );
        }
    }
    let (psi, theta, phi) = (f32s("psi_deg"), f32s("theta_deg"), f32s("phi_deg"));
    let q: Vec<Vec<f64>> = ["q_w", "q_x", "q_y", "q_z"]
        .iter()
        .map(|c| f32s(c))
        .collect();
    for s in 0..psi.len() {
        assert!((-180.0..=180.0).contains(&psi[s]) && (-180.0..=180.0).contains(&phi[s]));
        assert!((-90.0..=90.0).contains(&theta[s]));
        let a = bryan_matrix(
            psi[s].to_radians(),
            theta[s].to_radians(),
            phi[s].to_radians(),
        );
        let b = DMat3::from_quat(DQuat::from_xyzw(q[1][s], q[2][s], q[3][s], q[0][s]).normalize());
        let err = (a - b)
            .to_cols_array()
            .iter()
            .fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(err < 1e-5, "sample {s}: {err}");
    }
    let mut per_point = vec![(0u64, 0u64); points.len()];
    for ((&p, &i), &f) in point.iter().zip(&impacted).zip(&flags) {
        assert_eq!(i, f & 0b111 != 0 && f & (1 << 13) == 0, "flags {f:#b}");
        per_point[p as usize].0 += i as u64;
        per_point[p as usize].1 += 1;
    }
    for (k, (hit, n)) in per_point.iter().enumerate() {
        let all = &points[k]["summary"]["laws"]["newton"]["groups"]["all"];
        assert_eq!(all["samples"].as_u64(), Some(*n));
        assert_eq!(all["impacts"].as_u64(), Some(*hit), "point {k}");
    }
}
