//! A run's own pictures: `plots/` in the run folder, well-formed SVG with
//! the laws, planes and sequences the run's summary names, one set per
//! sweep point; `inspect` names them.

use crate::support;

use std::path::Path;

use support::{bin, json_file, repo, succeeded, tmpdir};

/// Checks that `text` is well-formed XML with an `<svg>` root: every tag
/// closed in order, no stray `<` or `&` in text. Returns the text content.
fn well_formed_svg(name: &str, text: &str) -> String {
    let mut stack: Vec<&str> = Vec::new();
    let mut content = String::new();
    let mut rest = text;
    let mut root = None;
    while let Some(open) = rest.find('<') {
        let between = &rest[..open];
        assert!(!between.contains('>'), "{name}: stray '>' in text");
        for (i, _) in between.match_indices('&') {
            let ent = &between[i..];
            assert!(
                ["&amp;", "&lt;", "&gt;", "&quot;", "&apos;", "&#"]
                    .iter()
                    .any(|e| ent.starts_with(e)),
                "{name}: bare '&' in text"
            );
        }
        content.push_str(between);
        content.push(' ');
        let close = rest[open..].find('>').map(|c| open + c).unwrap_or_else(|| {
            panic!(
                "{name}: unclosed tag at byte {}",
                text.len() - rest.len() + open
            )
        });
        let tag = &rest[open + 1..close];
        rest = &rest[close + 1..];
        if tag.starts_with('?') || tag.starts_with('!') {
            continue;
        }
        if let Some(end) = tag.strip_prefix('/') {
            let top = stack.pop();
            assert_eq!(top, Some(end.trim()), "{name}: </{end}> closes {top:?}");
            continue;
        }
        let tag_name = tag
            .split_whitespace()
            .next()
            .unwrap_or("")
            .trim_end_matches('/');
        assert!(!tag_name.is_empty(), "{name}: empty tag");
        root.get_or_insert(tag_name.to_string());
        if !tag.ends_with('/') {
            stack.push(tag_name);
        }
    }
    assert!(rest.trim().is_empty(), "{name}: text after the root");
    assert!(stack.is_empty(), "{name}: unclosed {stack:?}");
    assert_eq!(root.as_deref(), Some("svg"), "{name}: root element");
    content
}

fn plot(dir: &Path, name: &str) -> String {
    let path = dir.join("plots").join(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    well_formed_svg(name, &text)
}

fn run(scene: &Path, out: &Path, extra: &[&str]) {
    succeeded(
        bin()
            .arg("run")
            .arg(scene)
            .arg("--out")
            .arg(out)
            .args(extra)
            .output()
            .unwrap(),
    );
}

#[test]
fn a_contact_run_draws_its_energy_ratios_and_active_sets() {
    let d = tmpdir("plots-contact");
    let out = d.join("run");
    run(
        &repo("configs/corner3.toml"),
        &out,
        &["--samples", "20000", "--law", "newton", "--law", "paper"],
    );
    let energy = plot(&out, "energy_ratio.svg");
    let sets = plot(&out, "active_sets.svg");
    for text in [&energy, &sets] {
        assert!(
            text.contains("newton") && text.contains("paper"),
            "a law's legend is missing"
        );
    }
    assert!(energy.contains("T⁺/T⁻"), "energy axis");
    // Every active set the summary reports with a non-zero share is a bar.
    let summary = json_file(&out.join("summary.json"));
    let all = &summary["laws"]["newton"]["groups"]["all"]["active_sets"];
    let named: Vec<&String> = all
        .as_object()
        .expect("active sets")
        .iter()
        .filter(|(_, v)| v.as_f64().unwrap_or(0.0) > 0.0)
        .map(|(k, _)| k)
        .collect();
    assert!(!named.is_empty());
    for set in named {
        assert!(sets.contains(set.as_str()), "active set {set} not drawn");
    }
    let listing = succeeded(bin().arg("inspect").arg(&out).output().unwrap());
    let text = String::from_utf8_lossy(&listing.stdout);
    assert!(
        text.contains("plots: plots/energy_ratio.svg, plots/active_sets.svg"),
        "inspect names the plots:\n{text}"
    );
}

#[test]
fn a_drop_run_draws_its_sequences() {
    let d = tmpdir("plots-drop");
    let out = d.join("run");
    run(
        &repo("configs/drop_corner.toml"),
        &out,
        &["--samples", "3000"],
    );
    let seq = plot(&out, "sequences.svg");
    plot(&out, "active_sets.svg");
    let summary = json_file(&out.join("summary.json"));
    let first = summary["drops"]["newton"]["sequences"][0]["sequence"]
        .as_str()
        .expect("the most frequent sequence");
    let escaped = first.replace('>', "&gt;");
    assert!(
        seq.contains(first) || seq.contains(&escaped),
        "the most frequent sequence {first} is not drawn"
    );
}

#[test]
fn a_sweep_draws_every_point() {
    let d = tmpdir("plots-sweep");
    let out = d.join("run");
    run(
        &repo("configs/sweep_aspect_ratio.toml"),
        &out,
        &["--samples", "5000"],
    );
    let manifest = json_file(&out.join("manifest.json"));
    let points = manifest["points"].as_u64().expect("point count") as usize;
    assert!(points > 1);
    for i in 0..points {
        plot(&out, &format!("active_sets-point{i}.svg"));
    }
    assert!(!out.join("plots/active_sets.svg").exists());
}

/// The well-formedness check can fail: a tag closed out of order, an
/// unclosed tag and a bare `&` are refused.
#[test]
fn the_svg_check_refuses_broken_files() {
    for bad in [
        "<svg><g></svg>",
        "<svg><text>a</text>",
        "<svg><text>a & b</text></svg>",
    ] {
        let r = std::panic::catch_unwind(|| well_formed_svg("bad", bad));
        assert!(r.is_err(), "{bad} was accepted");
    }
    well_formed_svg(
        "good",
        "<?xml version=\"1.0\"?><svg a=\"1\"><g/><text>a &amp; b</text></svg>",
    );
}
