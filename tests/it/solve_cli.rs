//! `impactmc solve` as a user meets it: the paper's example from configs/,
//! stdin, TOML, and one clear message with exit code 2 for each kind of bad
//! input (snapshots of the messages people read).

use crate::support;

use support::bin;

use std::io::Write;
use std::process::Stdio;

fn solve_stdin(input: &str) -> (i32, String, String) {
    let mut child = bin()
        .args(["solve", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("binary runs");
    child
        .stdin
        .take()
        .unwrap()
        .write_all(input.as_bytes())
        .unwrap();
    let out = child.wait_with_output().unwrap();
    (
        out.status.code().expect("exited, not killed by a signal"),
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    )
}

const GOOD: &str = r#"{"body": {"semi_axes": [1, 1, 2], "mass": 500},
 "orientation": {"bryan_deg": [45, 30, 90]},
 "position": [1.3228756555322954, 1.4577379737113252, 0.0],
 "velocity": [-1, -1, 0], "angular_velocity": [0.1, 0.2, 0.3],
 "planes": [{"normal": [1, 0, 0], "offset": 0, "restitution": 0.5},
            {"normal": [0, 1, 0], "offset": 0, "restitution": 0.9}],
 "law": "newton", "contact_tolerance": 1e-9}"#;

#[test]
fn paper_example_from_configs_solves() {
    let out = bin()
        .args([
            "solve",
            concat!(env!("CARGO_MANIFEST_DIR"), "/configs/paper_example.json"),
        ])
        .output()
        .unwrap();
    support::assert_succeeded(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let contacts = v["contacts"].as_array().unwrap();
    assert_eq!(contacts.len(), 2);
    // Newton: both contacts approach and rebound at −k v_n (k = 0.5, 0.9).
    for (c, k) in contacts.iter().zip([0.5, 0.9]) {
        let before = c["normal_velocity_before"].as_f64().unwrap();
        let after = c["normal_velocity_after"].as_f64().unwrap();
        assert!(before < 0.0 && (after + k * before).abs() < 1e-12);
    }
    assert_eq!(v["energy_before"].as_f64().unwrap(), 521.5);
}

#[test]
fn stdin_json_and_toml_and_pgs_law() {
    let (code, out, err) = solve_stdin(&GOOD.replace(r#""newton""#, r#"{"pgs": {"sweeps": 8}}"#));
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("\"law\": \"pgs8\""));
    let toml = r#"
law = "paper"
position = [0.0, 0.0, 1.0]
velocity = [0.0, 0.0, -1.0]
angular_velocity = [0.0, 0.0, 0.0]
[body]
semi_axes = [1.0, 1.0, 1.0]
mass = 2.0
[orientation]
quaternion = [1.0, 0.0, 0.0, 0.0]
[[planes]]
normal = [0.0, 0.0, 1.0]
offset = 0.0
restitution = 0.5
"#;
    let (code, out, err) = solve_stdin(toml);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["velocity"][2].as_f64().unwrap(), 0.5);
}

/// Each bad input: exit 2, one line on stderr naming the field and value,
/// nothing on stdout.
#[test]
fn bad_input_messages() {
    let cases: &[(&str, &str, &str)] = &[
        (
            r#""mass": 500"#,
            r#""mass": -1"#,
            "body.mass: mass must be a finite number > 0, got -1",
        ),
        (
            r#""semi_axes": [1, 1, 2]"#,
            r#""semi_axes": [1, 0, 2]"#,
            "body.semi_axes: semi-axis 1 must be a finite number > 0, got 0",
        ),
        (
            r#""normal": [1, 0, 0]"#,
            r#""normal": [0, 0, 0]"#,
            "planes[0].normal: normal must be a finite non-zero vector, got [0, 0, 0]",
        ),
        (
            r#""restitution": 0.9"#,
            r#""restitution": 1.5"#,
            "planes[1].restitution: restitution must be in [0, 1], got 1.5",
        ),
        (
            r#""law": "newton""#,
            r#""law": "newtonian""#,
            "unknown variant `newtonian`",
        ),
        (
            r#""law": "newton""#,
            r#""law": "newton", "colour": 1"#,
            "unknown field `colour`",
        ),
        (
            r#""velocity": [-1, -1, 0]"#,
            r#""velocity": [-1, -1]"#,
            "invalid length 2",
        ),
        (
            r#""contact_tolerance": 1e-9"#,
            r#""contact_tolerance": -1"#,
            "contact_tolerance: must be a finite number ≥ 0 (metres), got -1",
        ),
        (
            r#"{"bryan_deg": [45, 30, 90]}"#,
            r#"{"matrix": [[1, 0, 0], [0, 1, 0], [0, 0, 2]]}"#,
            "orientation.matrix: must be a rotation",
        ),
        (
            r#"{"bryan_deg": [45, 30, 90]}"#,
            r#"{"quaternion": [0, 0, 0, 0]}"#,
            "orientation.quaternion: must be a finite non-zero quaternion, got [0, 0, 0, 0]",
        ),
        (
            r#""law": "newton""#,
            r#""law": {"pgs": {"sweeps": 0}}"#,
            "law.pgs.sweeps: must be ≥ 1, got 0",
        ),
    ];
    for (from, to, want) in cases {
        let input = GOOD.replace(from, to);
        assert_ne!(input, GOOD, "substitution {from} did not apply");
        let (code, out, err) = solve_stdin(&input);
        assert_eq!(code, 2, "{to}: exit code, stderr {err}");
        assert!(out.is_empty(), "{to}: stdout {out}");
        assert!(err.contains(want), "{to}: stderr {err:?} lacks {want:?}");
        assert!(!err.contains("panicked"), "{to}: {err}");
        assert_eq!(
            err.trim_end().lines().count(),
            1,
            "{to}: one message, got {err:?}"
        );
    }
    // NaN cannot be written in JSON, but TOML has it.
    let toml_nan = "law = \"paper\"\nposition = [0.0, 0.0, 1.0]\nvelocity = [0.0, 0.0, nan]\nangular_velocity = [0.0, 0.0, 0.0]\n[body]\nsemi_axes = [1.0, 1.0, 1.0]\nmass = 2.0\n[orientation]\nbryan_deg = [0.0, 0.0, 0.0]\n[[planes]]\nnormal = [0.0, 0.0, 1.0]\noffset = 0.0\nrestitution = 0.5\n";
    let (code, _, err) = solve_stdin(toml_nan);
    assert_eq!(code, 2);
    assert!(
        err.contains("velocity: must be finite, got [0, 0, NaN]"),
        "{err}"
    );
}
