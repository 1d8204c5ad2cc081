//! The Kubernetes job files parse, and the Indexed Job's `completions`,
//! `parallelism` and `SHARDS` agree with each other and with the merge Job
//! (`tests/python/check_kubernetes.py`, PyYAML). No cluster is needed.
//! Skipped without PyYAML, unless `IMPACTMC_REQUIRE_READERS=1` (set by
//! `.ci/run`, which installs it).

use crate::support;

use std::process::Command;

use support::repo;

#[test]
fn kubernetes_job_files_agree() {
    let has_yaml = Command::new("python3")
        .args(["-c", "import yaml"])
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false);
    if !support::available_or_skip(
        has_yaml,
        "IMPACTMC_REQUIRE_READERS",
        "PyYAML",
        "pip install -r .ci/requirements-readers.txt",
    ) {
        return;
    }
    let o = Command::new("python3")
        .arg(repo("tests/python/check_kubernetes.py"))
        .arg(repo("deploy/kubernetes/impactmc-shards.yaml"))
        .arg(repo("deploy/kubernetes/impactmc-merge.yaml"))
        .output()
        .unwrap();
    support::assert_succeeded(&o);
}
