"""Checks that the Kubernetes job files parse and agree with each other:
the Indexed Job's completions, parallelism and SHARDS are one number, each
pod runs the shard of its completion index, and the merge Job reads the
folder the shards write on the same volume. Called by tests/kubernetes.rs.

usage: check_kubernetes.py SHARDS_YAML MERGE_YAML
"""
import sys

import yaml


def job(path):
    docs = [d for d in yaml.safe_load_all(open(path)) if d is not None]
    assert len(docs) == 1, f"{path}: {len(docs)} documents, expected one Job"
    d = docs[0]
    assert d["apiVersion"] == "batch/v1" and d["kind"] == "Job", f"{path}: not a batch/v1 Job"
    return d


def main() -> int:
    shards, merge = job(sys.argv[1]), job(sys.argv[2])
    spec = shards["spec"]
    problems = []
    if spec.get("completionMode") != "Indexed":
        problems.append("the shards Job is not an Indexed Job")
    (pod,) = spec["template"]["spec"]["containers"]
    env = {e["name"]: e.get("value") for e in pod.get("env", [])}
    n = {"completions": spec.get("completions"), "parallelism": spec.get("parallelism"),
         "SHARDS": int(env["SHARDS"]) if "SHARDS" in env else None}
    if len(set(n.values())) != 1:
        problems.append(f"completions, parallelism and SHARDS disagree: {n}")
    script = " ".join(pod["command"] + pod["args"])
    for needle in ['--shard "${JOB_COMPLETION_INDEX}/${SHARDS}"', "/data/shards/shard-${JOB_COMPLETION_INDEX}"]:
        if needle not in script:
            problems.append(f"the shard pod does not run {needle!r}: {script}")
    (mpod,) = merge["spec"]["template"]["spec"]["containers"]
    mscript = " ".join(mpod["command"] + mpod["args"])
    if "impactmc merge /data/shards/shard-*" not in mscript:
        problems.append(f"the merge pod does not merge /data/shards/shard-*: {mscript}")
    claims = [sorted(v["persistentVolumeClaim"]["claimName"] for v in j["spec"]["template"]["spec"]["volumes"]
                     if "persistentVolumeClaim" in v) for j in (shards, merge)]
    if claims[0] != claims[1]:
        problems.append(f"the Jobs use different volume claims: {claims}")
    for p in problems:
        print(p, file=sys.stderr)
    if not problems:
        print(f"kubernetes job files agree: {n['SHARDS']} shards")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
