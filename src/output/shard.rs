//! Shards and their merge.
//!
//! `impactmc run SCENE --shard I/N` runs the contiguous share
//! `[⌊I·B/N⌋, ⌊(I+1)·B/N⌋)` of each grid point's B batches and saves, next to
//! the usual outputs for its share, the accumulator state of the merge-tree
//! nodes it completed ([`crate::stats::tree::Node`]). `impactmc merge` rebuilds
//! every point's tree from the shards' nodes, so N shards give the single
//! run's summary to the last bit, whatever N.
//!
//! A shard folder holds, besides the run outputs:
//! - `shard.json`: [`ShardInfo`] (what must match across shards, and the
//!   shard's index and batch range);
//! - `scene.toml`: the scene as run (command-line overrides applied);
//! - `state_counts.parquet`: `point u32, level u32, index u64, key str,
//!   count u64`: every integer counter of every node (zeros included, so
//!   each node is listed);
//! - `state_moments.parquet`: `point, level, index, key, n u64, mean f64,
//!   m2 f64, min f64, max f64`: merged moments (M2 is the sum of squared
//!   deviations from the mean); empty ones are omitted;
//! - `state_histograms.parquet`: `point, level, index, key, sign i32,
//!   bin u32, count u64`: non-zero histogram counts (sign 1: positive
//!   values in log-linear bin `bin`; −1 negative; 0 exact zeros);
//! - `state_clusters.parquet`: `point u32, batch u64, cluster u32, law
//!   u32, estimate u32, a f64, b f64`: an MC sweep's cluster sums
//!   ([`crate::stats::clusters`]), cluster `cluster` of batch `batch`, the
//!   sums `A_c`, `B_c` of the law's estimate in `walk_law` order (empty
//!   when the run records none).
//!
//! Keys are the paths of [`RunAcc::visit`] (`law0.groups.3.energy_ratio`).

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use polars::prelude::*;
use serde::{Deserialize, Serialize};

use crate::stats::accumulators::{LawAcc, RunAcc, Shape};
use crate::stats::clusters::ClusterSums;
use crate::stats::tree::{reduce_tree, Node, Shard};
use crate::stats::Moments;
use crate::stats::RunResult;
use crate::stats::Slot;

/// Version of the state files' layout.
pub const STATE_VERSION: u32 = 6;

/// `shard.json`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct ShardInfo {
    pub state_version: u32,
    pub impactmc_version: String,
    pub git_commit: String,
    pub scene: String,
    pub seed: u64,
    /// Samples per grid point.
    pub samples: u64,
    pub shard_index: u64,
    pub shard_count: u64,
    /// Batches per grid point, and this shard's range of them.
    pub batches: u64,
    pub batch_start: u64,
    pub batch_end: u64,
    pub points: usize,
    /// Per grid point.
    pub wall_seconds: Vec<f64>,
    pub cpu_seconds: Vec<Option<f64>>,
    pub threads: usize,
}

/// The fields of two shards that must agree for a merge, with their names.
fn identity(i: &ShardInfo) -> [(&'static str, String); 8] {
    [
        ("state_version", i.state_version.to_string()),
        ("impactmc_version", i.impactmc_version.clone()),
        ("git_commit", i.git_commit.clone()),
        ("scene", i.scene.clone()),
        ("seed", i.seed.to_string()),
        ("samples", i.samples.to_string()),
        ("shard_count", i.shard_count.to_string()),
        ("batches", i.batches.to_string()),
    ]
}

type NodeKey = (u32, u32, u64);

#[derive(Default)]
struct StateColumns {
    c_node: Vec<NodeKey>,
    c_key: Vec<String>,
    c_count: Vec<u64>,
    m_node: Vec<NodeKey>,
    m_key: Vec<String>,
    m: [Vec<f64>; 4],
    m_n: Vec<u64>,
    h_node: Vec<NodeKey>,
    h_key: Vec<String>,
    h_sign: Vec<i32>,
    h_bin: Vec<u32>,
    h_count: Vec<u64>,
}

fn node_columns(nodes: &[NodeKey]) -> Vec<Column> {
    vec![
        Column::new(
            "point".into(),
            nodes.iter().map(|n| n.0).collect::<Vec<_>>(),
        ),
        Column::new(
            "level".into(),
            nodes.iter().map(|n| n.1).collect::<Vec<_>>(),
        ),
        Column::new(
            "index".into(),
            nodes.iter().map(|n| n.2).collect::<Vec<_>>(),
        ),
    ]
}

/// The three state tables of the given points' nodes.
pub fn state_frames(points: &[&[(Node, RunAcc)]]) -> PolarsResult<[DataFrame; 3]> {
    let mut c = StateColumns::default();
    for (p, nodes) in points.iter().enumerate() {
        for (node, acc) in nodes.iter() {
            let key = (p as u32, node.level, node.index);
            let mut acc = acc.clone();
            acc.visit(&mut |path, slot| match slot {
                Slot::Count(n) => {
                    c.c_node.push(key);
                    c.c_key.push(path.to_string());
                    c.c_count.push(*n);
                }
                Slot::Moments(m) => {
                    let (n, mean, m2, min, max) = m.state();
                    if n > 0 {
                        c.m_node.push(key);
                        c.m_key.push(path.to_string());
                        c.m_n.push(n);
                        for (col, x) in c.m.iter_mut().zip([mean, m2, min, max]) {
                            col.push(x);
                        }
                    }
                }
                Slot::Histogram(h) => {
                    for (sign, bin, count) in h.entries() {
                        c.h_node.push(key);
                        c.h_key.push(path.to_string());
                        c.h_sign.push(sign as i32);
                        c.h_bin.push(bin as u32);
                        c.h_count.push(count);
                    }
                }
            });
        }
    }
    let lens = [c.c_node.len(), c.m_node.len(), c.h_node.len()];
    let mut counts = node_columns(&c.c_node);
    counts.push(Column::new("key".into(), c.c_key));
    counts.push(Column::new("count".into(), c.c_count));
    let mut moments = node_columns(&c.m_node);
    moments.push(Column::new("key".into(), c.m_key));
    moments.push(Column::new("n".into(), c.m_n));
    for (name, col) in ["mean", "m2", "min", "max"].into_iter().zip(c.m) {
        moments.push(Column::new(name.into(), col));
    }
    let mut hists = node_columns(&c.h_node);
    hists.push(Column::new("key".into(), c.h_key));
    hists.push(Column::new("sign".into(), c.h_sign));
    hists.push(Column::new("bin".into(), c.h_bin));
    hists.push(Column::new("count".into(), c.h_count));
    Ok([
        DataFrame::new(lens[0], counts)?,
        DataFrame::new(lens[1], moments)?,
        DataFrame::new(lens[2], hists)?,
    ])
}

/// The cluster table of the given points' cluster sums (`state_clusters.parquet`).
pub fn cluster_frame(points: &[Option<&ClusterSums>]) -> PolarsResult<DataFrame> {
    let (mut point, mut batch, mut cluster, mut law, mut estimate, mut a, mut b) = (
        Vec::<u32>::new(),
        Vec::<u64>::new(),
        Vec::<u32>::new(),
        Vec::<u32>::new(),
        Vec::<u32>::new(),
        Vec::<f64>::new(),
        Vec::<f64>::new(),
    );
    for (p, sums) in points.iter().enumerate() {
        let Some(sums) = sums else { continue };
        let keys = sums.keys.len();
        let per_cluster = sums.laws * keys;
        for (bt, s) in sums.per_batch() {
            for (k, pair) in s.chunks_exact(2).enumerate() {
                point.push(p as u32);
                batch.push(bt);
                cluster.push((k / per_cluster) as u32);
                law.push(((k % per_cluster) / keys) as u32);
                estimate.push((k % keys) as u32);
                a.push(pair[0]);
                b.push(pair[1]);
            }
        }
    }
    let n = point.len();
    DataFrame::new(
        n,
        vec![
            Column::new("point".into(), point),
            Column::new("batch".into(), batch),
            Column::new("cluster".into(), cluster),
            Column::new("law".into(), law),
            Column::new("estimate".into(), estimate),
            Column::new("a".into(), a),
            Column::new("b".into(), b),
        ],
    )
}

/// Column `name`'s values, nulls dropped, or why there is no such column
/// of type `T`.
fn numeric<T: PolarsNumericType>(df: &DataFrame, name: &str) -> PolarsResult<Vec<T::Native>> {
    Ok(df
        .column(name)?
        .as_materialized_series()
        .unpack::<T>()?
        .into_no_null_iter()
        .collect())
}

/// A point's cluster sums, per batch: the rows `(cluster, law, estimate,
/// a, b)`.
pub type BatchClusters = BTreeMap<u64, Vec<(u32, u32, u32, f64, f64)>>;

/// One shard's cluster sums of every point.
pub type ShardClusters = Vec<BatchClusters>;

/// Reads a shard's `state_clusters.parquet`.
pub fn read_clusters(dir: &Path, points: usize) -> Result<ShardClusters, MergeError> {
    let f = "state_clusters.parquet";
    let bad = |message: String| MergeError::State {
        path: dir.join(f).display().to_string(),
        message,
    };
    let df = read_frame(&dir.join(f))?;
    let u32s = |name: &str| numeric::<UInt32Type>(&df, name).map_err(|e| bad(e.to_string()));
    let f64s = |name: &str| numeric::<Float64Type>(&df, name).map_err(|e| bad(e.to_string()));
    let batch = numeric::<UInt64Type>(&df, "batch").map_err(|e| bad(e.to_string()))?;
    let (point, cluster, law, estimate, a, b) = (
        u32s("point")?,
        u32s("cluster")?,
        u32s("law")?,
        u32s("estimate")?,
        f64s("a")?,
        f64s("b")?,
    );
    let mut out: ShardClusters = vec![BTreeMap::new(); points];
    for r in 0..point.len() {
        let p = point[r] as usize;
        let per_point = out
            .get_mut(p)
            .ok_or_else(|| bad(format!("point {p} out of range (the scene has {points})")))?;
        per_point
            .entry(batch[r])
            .or_default()
            .push((cluster[r], law[r], estimate[r], a[r], b[r]));
    }
    Ok(out)
}

/// A point's cluster sums from every shard's rows: None where the shards
/// recorded none, or some batch of `0..batches` has none (a partial merge).
pub fn merge_clusters(
    rows: BatchClusters,
    samples: u64,
    batch_size: u64,
    batches: u64,
    laws: &[LawAcc],
) -> Result<Option<ClusterSums>, String> {
    if rows.len() as u64 != batches {
        return Ok(None);
    }
    let (nl, nk) = (laws.len(), crate::stats::clusters::keys(laws).len());
    let mut per_batch = Vec::with_capacity(rows.len());
    for (batch, r) in rows {
        let clusters = r.len() / (nl * nk).max(1);
        if clusters * nl * nk != r.len() {
            return Err(format!(
                "batch {batch} has {} sums, not a whole number of clusters",
                r.len()
            ));
        }
        let mut sums = vec![0.0; 2 * r.len()];
        let mut seen = vec![false; r.len()];
        for (c, l, e, a, b) in r {
            let (c, l, e) = (c as usize, l as usize, e as usize);
            if c >= clusters || l >= nl || e >= nk {
                return Err(format!(
                    "batch {batch}: cluster {c}, law {l}, estimate {e} out of range"
                ));
            }
            let at = (c * nl + l) * nk + e;
            (sums[2 * at], sums[2 * at + 1]) = (a, b);
            seen[at] = true;
        }
        if seen.contains(&false) {
            return Err(format!(
                "batch {batch} lists a cluster sum twice or not at all"
            ));
        }
        per_batch.push((batch, sums));
    }
    Ok(Some(ClusterSums::from_batches(
        samples, batch_size, laws, per_batch,
    )))
}

/// Why shards could not be merged. Every message names the shard folder or
/// the shard indices at fault.
#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    #[error("{dir}: not a shard folder ({reason})")]
    NotShard { dir: String, reason: String },
    #[error("{dir}: {field} is {got:?}, but {first_dir} has {want:?}; shards of different scenes, seeds or versions cannot be merged")]
    Mismatch {
        dir: String,
        field: &'static str,
        got: String,
        first_dir: String,
        want: String,
    },
    #[error(
        "{dir}: scene.toml differs from {first_dir}'s; shards of different scenes cannot be merged"
    )]
    SceneDiffers { dir: String, first_dir: String },
    #[error("duplicate shard index {index} of {count}: {a} and {b} (pass --allow-partial to keep the first)")]
    Duplicate {
        index: u64,
        count: u64,
        a: String,
        b: String,
    },
    #[error("missing shard indices {missing:?} of {count} (pass --allow-partial to merge the others; the result is then marked partial)")]
    Missing { missing: Vec<u64>, count: u64 },
    #[error("{path}: {message}")]
    State { path: String, message: String },
    #[error("no shard folders given")]
    Empty,
}

/// A shard folder's description and where it is.
pub struct ShardDir {
    pub dir: PathBuf,
    pub info: ShardInfo,
}

pub fn read_info(dir: &Path) -> Result<ShardInfo, MergeError> {
    let not = |reason: String| MergeError::NotShard {
        dir: dir.display().to_string(),
        reason,
    };
    let path = dir.join("shard.json");
    let text = std::fs::read_to_string(&path).map_err(|e| not(format!("shard.json: {e}")))?;
    serde_json::from_str(&text).map_err(|e| not(format!("shard.json: {e}")))
}

/// The outcome of checking a set of shard folders.
pub struct Checked {
    /// One folder per index present, in index order.
    pub shards: Vec<ShardDir>,
    pub count: u64,
    pub missing: Vec<u64>,
    /// Indices given more than once (only with `allow_partial`).
    pub duplicates: Vec<u64>,
}

/// Checks that the folders are shards of one study, and that every index is
/// there exactly once (unless `allow_partial`).
pub fn check(dirs: &[PathBuf], allow_partial: bool) -> Result<Checked, MergeError> {
    let mut all = Vec::new();
    for d in dirs {
        all.push(ShardDir {
            dir: d.clone(),
            info: read_info(d)?,
        });
    }
    let first = all.first().ok_or(MergeError::Empty)?;
    let want = identity(&first.info);
    for s in &all[1..] {
        for ((field, got), (_, want)) in identity(&s.info).into_iter().zip(want.iter()) {
            if &got != want {
                return Err(MergeError::Mismatch {
                    dir: s.dir.display().to_string(),
                    field,
                    got,
                    first_dir: first.dir.display().to_string(),
                    want: want.clone(),
                });
            }
        }
    }
    let scene_text = |d: &Path| {
        std::fs::read_to_string(d.join("scene.toml")).map_err(|e| MergeError::NotShard {
            dir: d.display().to_string(),
            reason: format!("scene.toml: {e}"),
        })
    };
    let first_scene = scene_text(&first.dir)?;
    for s in &all[1..] {
        let got = scene_text(&s.dir)?;
        if got != first_scene {
            return Err(MergeError::SceneDiffers {
                dir: s.dir.display().to_string(),
                first_dir: first.dir.display().to_string(),
            });
        }
    }
    let count = first.info.shard_count;
    let mut by_index: BTreeMap<u64, ShardDir> = BTreeMap::new();
    let mut duplicates = Vec::new();
    for s in all {
        let i = s.info.shard_index;
        if let Some(prev) = by_index.get(&i) {
            if !allow_partial {
                return Err(MergeError::Duplicate {
                    index: i,
                    count,
                    a: prev.dir.display().to_string(),
                    b: s.dir.display().to_string(),
                });
            }
            duplicates.push(i);
            continue;
        }
        by_index.insert(i, s);
    }
    let missing: Vec<u64> = (0..count).filter(|i| !by_index.contains_key(i)).collect();
    if !missing.is_empty() && !allow_partial {
        return Err(MergeError::Missing { missing, count });
    }
    Ok(Checked {
        shards: by_index.into_values().collect(),
        count,
        missing,
        duplicates,
    })
}

fn read_frame(path: &Path) -> Result<DataFrame, MergeError> {
    let err = |message: String| MergeError::State {
        path: path.display().to_string(),
        message,
    };
    let f = std::fs::File::open(path).map_err(|e| err(e.to_string()))?;
    ParquetReader::new(f)
        .finish()
        .map_err(|e| err(e.to_string()))
}

type NodeMap<T> = HashMap<NodeKey, HashMap<String, T>>;

/// Reads a shard's nodes: per grid point, each node's accumulators, built
/// in that point's shape.
pub fn read_nodes(dir: &Path, shapes: &[Shape]) -> Result<Vec<Vec<(Node, RunAcc)>>, MergeError> {
    let points = shapes.len();
    let bad = |file: &str, message: String| MergeError::State {
        path: dir.join(file).display().to_string(),
        message,
    };
    let pe = |file: &'static str| move |e: PolarsError| bad(file, e.to_string());
    let nodes_of = |df: &DataFrame, file: &'static str| -> Result<Vec<NodeKey>, MergeError> {
        let p = df
            .column("point")
            .and_then(|c| c.u32().cloned())
            .map_err(pe(file))?;
        let l = df
            .column("level")
            .and_then(|c| c.u32().cloned())
            .map_err(pe(file))?;
        let i = df
            .column("index")
            .and_then(|c| c.u64().cloned())
            .map_err(pe(file))?;
        Ok(p.into_no_null_iter()
            .zip(l.into_no_null_iter())
            .zip(i.into_no_null_iter())
            .map(|((p, l), i)| (p, l, i))
            .collect())
    };
    let keys_of = |df: &DataFrame, file: &'static str| -> Result<Vec<String>, MergeError> {
        let k = df
            .column("key")
            .and_then(|c| c.str().cloned())
            .map_err(pe(file))?;
        k.iter()
            .map(|x| x.map(str::to_string))
            .collect::<Option<Vec<_>>>()
            .ok_or_else(|| bad(file, "null key".into()))
    };
    let u64s = |df: &DataFrame, name: &str, file: &'static str| -> Result<Vec<u64>, MergeError> {
        let c = df
            .column(name)
            .and_then(|c| c.u64().cloned())
            .map_err(pe(file))?;
        Ok(c.into_no_null_iter().collect())
    };
    let f64s = |df: &DataFrame, name: &str, file: &'static str| -> Result<Vec<f64>, MergeError> {
        let c = df
            .column(name)
            .and_then(|c| c.f64().cloned())
            .map_err(pe(file))?;
        Ok(c.into_no_null_iter().collect())
    };

    let f = "state_counts.parquet";
    let df = read_frame(&dir.join(f))?;
    let mut counts: NodeMap<u64> = HashMap::new();
    for ((node, key), c) in nodes_of(&df, f)?
        .into_iter()
        .zip(keys_of(&df, f)?)
        .zip(u64s(&df, "count", f)?)
    {
        counts.entry(node).or_default().insert(key, c);
    }
    let f = "state_moments.parquet";
    let df = read_frame(&dir.join(f))?;
    let mut moments: NodeMap<Moments> = HashMap::new();
    let (n, mean, m2, min, max) = (
        u64s(&df, "n", f)?,
        f64s(&df, "mean", f)?,
        f64s(&df, "m2", f)?,
        f64s(&df, "min", f)?,
        f64s(&df, "max", f)?,
    );
    for (r, (node, key)) in nodes_of(&df, f)?
        .into_iter()
        .zip(keys_of(&df, f)?)
        .enumerate()
    {
        let m = Moments::from_state(n[r], mean[r], m2[r], min[r], max[r]);
        moments.entry(node).or_default().insert(key, m);
    }
    let f = "state_histograms.parquet";
    let df = read_frame(&dir.join(f))?;
    let mut hists: NodeMap<Vec<(i8, u16, u64)>> = HashMap::new();
    let sign = df
        .column("sign")
        .and_then(|c| c.i32().cloned())
        .map_err(pe(f))?;
    let bin = df
        .column("bin")
        .and_then(|c| c.u32().cloned())
        .map_err(pe(f))?;
    for ((((node, key), s), b), c) in nodes_of(&df, f)?
        .into_iter()
        .zip(keys_of(&df, f)?)
        .zip(sign.into_no_null_iter())
        .zip(bin.into_no_null_iter())
        .zip(u64s(&df, "count", f)?)
    {
        hists
            .entry(node)
            .or_default()
            .entry(key)
            .or_default()
            .push((s as i8, b.min(u16::MAX as u32) as u16, c));
    }

    let mut out: Vec<Vec<(Node, RunAcc)>> = (0..points).map(|_| Vec::new()).collect();
    let mut node_keys: Vec<NodeKey> = counts.keys().copied().collect();
    node_keys.sort();
    for key in node_keys {
        let (p, level, index) = key;
        if p as usize >= points {
            return Err(bad(
                "state_counts.parquet",
                format!("point {p} out of range (the scene has {points})"),
            ));
        }
        let mut acc = RunAcc::shaped(shapes[p as usize]);
        let mut c = counts.remove(&key).unwrap_or_default();
        let mut m = moments.remove(&key).unwrap_or_default();
        let mut h = hists.remove(&key).unwrap_or_default();
        let mut problem: Option<String> = None;
        acc.visit(&mut |path, slot| match slot {
            Slot::Count(x) => match c.remove(path) {
                Some(v) => *x = v,
                None => problem = Some(format!("node {key:?} has no count {path:?}")),
            },
            Slot::Moments(x) => {
                if let Some(v) = m.remove(path) {
                    *x = v;
                }
            }
            Slot::Histogram(x) => {
                for (s, b, n) in h.remove(path).unwrap_or_default() {
                    if let Err(e) = x.add_entry(s, b, n) {
                        problem = Some(format!("node {key:?} {path:?}: {e}"));
                    }
                }
            }
        });
        let extra: Vec<&String> = c.keys().chain(m.keys()).chain(h.keys()).collect();
        if let Some(first) = extra.first() {
            problem = Some(format!(
                "node {key:?} has a key this scene does not: {first:?}"
            ));
        }
        if let Some(message) = problem {
            return Err(bad("state_*.parquet", message));
        }
        out[p as usize].push((Node { level, index }, acc));
    }
    if let Some(k) = moments.keys().chain(hists.keys()).next() {
        return Err(bad(
            "state_*.parquet",
            format!("node {k:?} has moments or histograms but no counts"),
        ));
    }
    Ok(out)
}

/// One grid point's merged result: the shards' nodes reduced along the
/// merge tree, finished. Batches of missing shards count as empty.
#[allow(clippy::too_many_arguments)]
pub fn merge_point(
    nodes: Vec<(Node, RunAcc)>,
    batches: u64,
    shape: Shape,
    replicate_level: Option<u32>,
    wall_seconds: f64,
    cpu_seconds: Option<f64>,
    threads: usize,
) -> RunResult {
    let reduced = reduce_tree(nodes, batches, shape, replicate_level);
    let (mut acc, mut replicates, missing) = (reduced.acc, reduced.replicates, reduced.missing);
    acc.finish();
    replicates.iter_mut().for_each(RunAcc::finish);
    RunResult {
        acc,
        replicates,
        clusters: None,
        nodes: Vec::new(),
        batches,
        batches_run: batches - missing,
        wall_seconds,
        cpu_seconds,
        threads,
    }
}

/// The description of a shard run.
pub fn info_of(
    scene_name: &str,
    seed: u64,
    samples: u64,
    shard: Shard,
    results: &[&RunResult],
) -> ShardInfo {
    let first = results[0];
    let range = shard.batches(first.batches);
    ShardInfo {
        state_version: STATE_VERSION,
        impactmc_version: env!("CARGO_PKG_VERSION").into(),
        git_commit: env!("IMPACTMC_GIT_COMMIT").into(),
        scene: scene_name.into(),
        seed,
        samples,
        shard_index: shard.index,
        shard_count: shard.count,
        batches: first.batches,
        batch_start: range.start,
        batch_end: range.end,
        points: results.len(),
        wall_seconds: results.iter().map(|r| r.wall_seconds).collect(),
        cpu_seconds: results.iter().map(|r| r.cpu_seconds).collect(),
        threads: first.threads,
    }
}
