//! The fixed merge tree over batch indices, and shards as contiguous ranges
//! of it. Accumulators are merged along this tree whoever computed them (the
//! threads of one run, or the shards of a study merged later), so the answer
//! depends neither on the thread count nor on the sharding.

use crate::stats::accumulators::{RunAcc, Shape};

/// The maximal merge-tree nodes inside `range` up to level `max_level`, in
/// batch order (what a [`TreeStack`] of that `max_level` holds after
/// pushing the range's batches one by one).
pub(crate) fn aligned_nodes(range: std::ops::Range<u64>, max_level: u32) -> Vec<Node> {
    let mut nodes = Vec::new();
    let mut b = range.start;
    while b < range.end {
        let mut level = 0;
        while level < max_level && b % (2 << level) == 0 && b + (2 << level) <= range.end {
            level += 1;
        }
        nodes.push(Node {
            level,
            index: b >> level,
        });
        b += 1 << level;
    }
    nodes
}

/// A node of the fixed merge tree over batch indices: the batches
/// `[index·2^level, (index + 1)·2^level)`.
///
/// A run's accumulators are merged along this tree, whatever computed
/// them: node = merge(left child, right child), with missing batches past the
/// end empty (merging an empty accumulator is exact: it changes no bit).
/// A shard holds the maximal nodes inside its batch range, and merging
/// shards rebuilds the same tree, so N shards give the single run's answer to
/// the last bit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Node {
    pub level: u32,
    pub index: u64,
}

impl Node {
    /// The batches this node covers.
    pub fn batches(&self) -> std::ops::Range<u64> {
        let lo = self.index << self.level;
        lo..lo + (1u64 << self.level)
    }
}

/// Batch results in batch order, merged as soon as both children of a tree
/// node are complete, up to `max_level`: what remains are the maximal
/// nodes inside the range seen, none above that level.
pub(crate) struct TreeStack {
    pub(crate) nodes: Vec<(Node, RunAcc)>,
    max_level: u32,
}

impl TreeStack {
    /// Nodes merged up to `max_level` (a replicate's level keeps
    /// replicates whole for the final reduction: [`reduce_tree`]).
    pub(crate) fn new(max_level: u32) -> Self {
        Self {
            nodes: Vec::new(),
            max_level,
        }
    }

    pub(crate) fn push(&mut self, batch: u64, acc: RunAcc) {
        self.push_node(
            Node {
                level: 0,
                index: batch,
            },
            acc,
        );
    }

    /// Pushes a complete node (its batches merged along the tree); nodes
    /// come in batch order.
    pub(crate) fn push_node(&mut self, mut node: Node, mut acc: RunAcc) {
        while let Some(&(top, _)) = self.nodes.last() {
            let siblings = top.level == node.level
                && node.level < self.max_level
                && top.index % 2 == 0
                && top.index + 1 == node.index;
            if !siblings {
                break;
            }
            let (_, mut left) = self.nodes.pop().expect("checked above");
            left.merge(&mut acc);
            acc = left;
            node = Node {
                level: node.level + 1,
                index: top.index / 2,
            };
        }
        self.nodes.push((node, acc));
    }
}

/// The root of the merge tree over `batches` batches from nodes that do not
/// overlap, and with `replicate_level` a copy of every node of that level
/// on the way (an RQMC run's replicates, in order). Batches no node covers
/// count as empty; their number is returned with the (unfinished)
/// accumulators.
pub fn reduce_tree(
    nodes: Vec<(Node, RunAcc)>,
    batches: u64,
    shape: Shape,
    replicate_level: Option<u32>,
) -> Reduced {
    let map: std::collections::HashMap<Node, RunAcc> = nodes.into_iter().collect();
    let mut levels = 0;
    while (1u64 << levels) < batches {
        levels += 1;
    }
    let mut r = Reduction {
        batches,
        map,
        missing: 0,
        replicate_level,
        replicates: Vec::new(),
        shape,
    };
    let root = r.node(Node {
        level: levels,
        index: 0,
    });
    Reduced {
        acc: root,
        replicates: r.replicates,
        missing: r.missing,
    }
}

/// What [`reduce_tree`] gives.
pub struct Reduced {
    pub acc: RunAcc,
    pub replicates: Vec<RunAcc>,
    pub missing: u64,
}

struct Reduction {
    batches: u64,
    map: std::collections::HashMap<Node, RunAcc>,
    missing: u64,
    replicate_level: Option<u32>,
    replicates: Vec<RunAcc>,
    shape: Shape,
}

impl Reduction {
    fn node(&mut self, node: Node) -> RunAcc {
        let acc = self.merged(node);
        if Some(node.level) == self.replicate_level && node.batches().start < self.batches {
            self.replicates.push(acc.clone());
        }
        acc
    }

    fn merged(&mut self, node: Node) -> RunAcc {
        let range = node.batches();
        if range.start >= self.batches {
            return RunAcc::shaped(self.shape);
        }
        if let Some(acc) = self.map.remove(&node) {
            return acc;
        }
        if node.level == 0 {
            self.missing += 1;
            return RunAcc::shaped(self.shape);
        }
        let child = |i| Node {
            level: node.level - 1,
            index: i,
        };
        let mut left = self.node(child(2 * node.index));
        let mut right = self.node(child(2 * node.index + 1));
        left.merge(&mut right);
        left
    }
}

/// Shard `index` of `count`: a contiguous share of the batch indices.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This shard, from 0.
    pub index: u64,
    /// Shards in the run.
    pub count: u64,
}

impl std::str::FromStr for Shard {
    type Err = String;

    /// Parses `I/N` (0 ≤ I < N).
    fn from_str(s: &str) -> Result<Self, String> {
        let (i, n) = s
            .split_once('/')
            .ok_or_else(|| format!("must be I/N (e.g. 3/8), got {s:?}"))?;
        let (index, count): (u64, u64) = match (i.trim().parse(), n.trim().parse()) {
            (Ok(i), Ok(n)) => (i, n),
            _ => return Err(format!("must be I/N with integers, got {s:?}")),
        };
        if count == 0 || index >= count {
            return Err(format!(
                "I/N needs 0 <= I < N, got {s:?} (indices start at 0)"
            ));
        }
        Ok(Self { index, count })
    }
}

impl Shard {
    /// Its batches out of `batches`: `[⌊I·B/N⌋, ⌊(I+1)·B/N⌋)`.
    pub fn batches(&self, batches: u64) -> std::ops::Range<u64> {
        let at = |i: u64| (i as u128 * batches as u128 / self.count as u128) as u64;
        at(self.index)..at(self.index + 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The parallel recursion starts from the nodes the batch-by-batch
    /// tree stack ends with, for any batch range (so both build one tree).
    #[test]
    fn aligned_nodes_are_what_the_tree_stack_keeps() {
        for start in 0..40u64 {
            for end in start..start + 70 {
                for max_level in [2, u32::MAX] {
                    let mut stack = TreeStack::new(max_level);
                    for b in start..end {
                        stack.push(b, RunAcc::new(1, 1));
                    }
                    let kept: Vec<Node> = stack.nodes.iter().map(|(n, _)| *n).collect();
                    assert_eq!(
                        aligned_nodes(start..end, max_level),
                        kept,
                        "batches {start}..{end} up to level {max_level}"
                    );
                    assert!(kept.iter().all(|n| n.level <= max_level));
                }
            }
        }
    }
}
