//! [`Topology`]: the shape of a cache tree — which cache each cache misses to.
//!
//! Nodes are numbered; each has settings ([`CacheLevel`]), a name used in reports and errors
//! (`l1`, `l2`, `trv-l1` …), a level label, and a parent: another node or memory. Leaves (nodes
//! nobody misses to) are where requests enter; they are numbered in node order
//! ([`Topology::leaves`]) and a request names its leaf by that index ("which L1"). Any acyclic
//! shape is accepted; [`Topology::new`] rejects cycles and different line sizes between a cache
//! and its parent.
//!
//! [`Topology::from_config`] builds the two-level tree of a [`CacheConfig`]: `l1_count` L1s,
//! grouped `l1s_per_l2` to an L2 (TRaX's 128 TM L1s over one or several L2s). Other shapes
//! (SGRT: per core four TRV L1s over an L2, plus an IST L1 straight to memory) are built with
//! [`Topology::new`].

use crate::cache::Cache;
use crate::config::{CacheConfig, CacheLevel};
use rtsim_config::ConfigError;

/// Where a cache sends its misses and writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Parent {
    Cache(usize),
    Memory,
}

/// One cache of the tree.
#[derive(Clone, Debug, PartialEq)]
pub struct Node {
    /// Name for reports and error messages (its config section, e.g. `l1`).
    pub name: String,
    /// Level label for grouping in reports (1 for L1s, 2 for L2s …).
    pub level: u32,
    pub cache: CacheLevel,
    pub parent: Parent,
}

/// A validated cache tree.
#[derive(Clone, Debug)]
pub struct Topology {
    nodes: Vec<Node>,
    leaves: Vec<usize>,
    seed: u64,
}

impl Topology {
    /// Validate `nodes` (each cache's settings, parents in range, no cycles, equal line sizes
    /// along every edge). `seed` seeds random replacement (node `i` uses stream `i`).
    pub fn new(nodes: Vec<Node>, seed: u64) -> Result<Self, ConfigError> {
        if nodes.is_empty() {
            return Err(ConfigError::key(
                "caches",
                "a hierarchy needs at least one cache",
            ));
        }
        let mut is_parent = vec![false; nodes.len()];
        for (i, n) in nodes.iter().enumerate() {
            n.cache.validate_at(&n.name)?;
            if let Parent::Cache(p) = n.parent {
                let Some(pn) = nodes.get(p) else {
                    return Err(ConfigError::key(
                        &n.name,
                        format!("parent cache {p} does not exist ({} caches)", nodes.len()),
                    ));
                };
                if pn.cache.line_bytes != n.cache.line_bytes {
                    return Err(ConfigError::key(
                        &format!("{}.line_bytes", n.name),
                        format!(
                            "= {} must equal `{}.line_bytes` = {} (caches of one hierarchy share \
                             a line size)",
                            n.cache.line_bytes, pn.name, pn.cache.line_bytes
                        ),
                    ));
                }
                is_parent[p] = true;
            }
            // Walk up: a path longer than the node count is a cycle.
            let mut cur = i;
            for step in 0..=nodes.len() {
                match nodes[cur].parent {
                    Parent::Memory => break,
                    Parent::Cache(p) => cur = p,
                }
                if step == nodes.len() {
                    return Err(ConfigError::key(&n.name, "the cache tree has a cycle"));
                }
            }
        }
        let leaves = (0..nodes.len()).filter(|&i| !is_parent[i]).collect();
        Ok(Topology {
            nodes,
            leaves,
            seed,
        })
    }

    /// The tree of a two-level [`CacheConfig`] (validated here): L1s are nodes
    /// `0..l1_count`, L2s follow.
    pub fn from_config(c: &CacheConfig) -> Result<Self, ConfigError> {
        use rtsim_config::Validate;
        c.validate()?;
        let l2s = c.l2_count() as usize;
        let group = if c.l1s_per_l2 == 0 {
            c.l1_count as usize
        } else {
            c.l1s_per_l2 as usize
        };
        let l1_count = c.l1_count as usize;
        let mut nodes = Vec::with_capacity(l1_count + l2s);
        for i in 0..l1_count {
            nodes.push(Node {
                name: "l1".into(),
                level: 1,
                cache: c.l1.clone(),
                parent: if l2s == 0 {
                    Parent::Memory
                } else {
                    Parent::Cache(l1_count + i / group)
                },
            });
        }
        for _ in 0..l2s {
            nodes.push(Node {
                name: "l2".into(),
                level: 2,
                cache: c.l2.clone(),
                parent: Parent::Memory,
            });
        }
        Topology::new(nodes, c.seed)
    }

    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }
    /// Node indices of the leaves, in node order; requests name a leaf by its position here.
    pub fn leaves(&self) -> &[usize] {
        &self.leaves
    }
    #[inline]
    pub fn parent(&self, n: usize) -> Parent {
        self.nodes[n].parent
    }
    pub fn seed(&self) -> u64 {
        self.seed
    }
    /// Line size of the caches that talk to memory (all equal along each edge; different
    /// subtrees could differ, which [`Topology::memory_line_bytes`] rejects).
    pub fn memory_line_bytes(&self) -> Result<Option<(u32, &str)>, ConfigError> {
        let mut found: Option<(u32, &str)> = None;
        for n in self.nodes.iter().filter(|n| n.parent == Parent::Memory) {
            match found {
                None => found = Some((n.cache.line_bytes, &n.name)),
                Some((b, name)) if b != n.cache.line_bytes => {
                    return Err(ConfigError::key(
                        &format!("{}.line_bytes", n.name),
                        format!(
                            "= {} differs from `{name}.line_bytes` = {b}; every cache that talks \
                             to memory must use the memory's line size",
                            n.cache.line_bytes
                        ),
                    ));
                }
                Some(_) => {}
            }
        }
        Ok(found)
    }

    /// Empty caches for every node.
    pub(crate) fn build_caches(&self) -> Result<Vec<Cache>, ConfigError> {
        self.nodes
            .iter()
            .enumerate()
            .map(|(i, n)| Cache::new(&n.name, &n.cache, self.seed, i as u64))
            .collect()
    }
}
