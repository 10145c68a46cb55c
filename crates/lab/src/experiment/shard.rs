//! Shards: one experiment split over machines or scheduler tasks.
//!
//! `raylab experiment MANIFEST --shard I/N` runs a deterministic 1/N of the
//! plan's runs ([`deal`]). Runs are dealt in groups: the runs whose keys
//! differ only in the `series` column of a ratio figure (T = t_OGSS /
//! t_centre pairs an `ogss:2` run with the `centre` run of the same
//! resolution) form one group and run on one machine, so every ratio is
//! measured in one process, as the figures' "ratios measured in one run"
//! promise. Groups are dealt round-robin in plan order: each shard gets
//! ⌊G/N⌋ or ⌈G/N⌉ of the G groups, and every sweep is spread over all
//! shards (a sweep of slow runs does not land on one machine). The deal
//! depends only on the plan and the figures, which depend only on the
//! manifest's text and `--quick`, so a shard is the same set of run keys
//! every time the manifest is unchanged; [`manifest_hash`] of that text is
//! written into each shard's `meta.json`, and `raylab merge`
//! ([`super::merge`]) refuses shards whose hashes differ.
//!
//! A shard writes `data.csv` and `meta.json` (with `shard` and
//! `manifest_hash`) into its own folder, by default
//! `out/NAME.shards/I-of-N` beside the manifest, and draws no figures: a
//! figure of a third of the runs would be misleading. The merge draws them.

use super::manifest::{FigureKind, Manifest, Plan};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::collections::HashMap;
use std::fmt;
use std::hash::Hash;
use std::str::FromStr;

/// Shard I of N (1 ≤ I ≤ N).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Shard {
    /// I, from 1 (as Slurm's `--array=1-N` numbers its tasks).
    pub index: usize,
    /// N, the number of shards.
    pub count: usize,
}

/// The most shards an experiment may be split into.
pub const MAX_SHARDS: usize = 100_000;

/// Text that is not a shard `I/N` (1 ≤ I ≤ N ≤ [`MAX_SHARDS`]).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ShardError {
    /// Not of the form `I/N` with 1 ≤ I ≤ N.
    #[error("`{0}` is not a shard: expected I/N with 1 ≤ I ≤ N, e.g. 2/3")]
    Malformed(String),
    /// More than [`MAX_SHARDS`] shards.
    #[error("`{0}`: at most {MAX_SHARDS} shards (a shard per run is already the finest split)")]
    TooMany(String),
}

impl Shard {
    /// The default folder name of this shard: `I-of-N`.
    pub fn dir_name(&self) -> String {
        format!("{}-of-{}", self.index, self.count)
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl FromStr for Shard {
    type Err = ShardError;

    /// `I/N` with 1 ≤ I ≤ N ≤ [`MAX_SHARDS`].
    fn from_str(s: &str) -> Result<Shard, ShardError> {
        let bad = || ShardError::Malformed(s.to_string());
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let index: usize = i.trim().parse().map_err(|_| bad())?;
        let count: usize = n.trim().parse().map_err(|_| bad())?;
        if count == 0 || index == 0 || index > count {
            return Err(bad());
        }
        if count > MAX_SHARDS {
            return Err(ShardError::TooMany(s.to_string()));
        }
        Ok(Shard { index, count })
    }
}

/// The shard of each run of `plan` (in plan order) when the experiment
/// is split `count` ways: its group (the run's key with the series columns
/// of the manifest's ratio figures blanked) dealt round-robin in order of
/// first appearance.
pub fn deal(manifest: &Manifest, plan: &Plan, count: usize) -> Vec<Shard> {
    let paired: Vec<&str> = manifest
        .figures
        .iter()
        .filter(|f| f.kind == FigureKind::Ratio)
        .filter_map(|f| f.series.as_deref())
        .collect();
    let blank: Vec<bool> = plan
        .param_columns
        .iter()
        .map(|c| paired.contains(&c.as_str()))
        .collect();
    let groups = plan.runs.iter().map(|run| {
        let mut key = plan.key(run);
        for (cell, &b) in key[1..].iter_mut().zip(&blank) {
            if b {
                cell.clear();
            }
        }
        key
    });
    deal_groups(groups, count)
}

/// Deal items round-robin by group, in order of each group's first item.
fn deal_groups<K: Eq + Hash>(groups: impl Iterator<Item = K>, count: usize) -> Vec<Shard> {
    let mut index: HashMap<K, usize> = HashMap::new();
    groups
        .map(|g| {
            let next = index.len();
            let i = *index.entry(g).or_insert(next);
            Shard {
                index: i % count + 1,
                count,
            }
        })
        .collect()
}

/// The SHA-256 (hex) of a manifest's text and whether `--quick` applies:
/// the identity of a plan. Shards with equal hashes split the same runs.
pub fn manifest_hash(text: &str, quick: bool) -> String {
    let mut h = Sha256::new();
    h.update(text.as_bytes());
    h.update(if quick {
        b"\0quick" as &[u8]
    } else {
        b"\0full"
    });
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// This machine's host name (`/proc/sys/kernel/hostname`, else
/// `$HOSTNAME`), or "unknown".
pub fn host_name() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .or_else(|| std::env::var("HOSTNAME").ok())
        .unwrap_or_else(|| "unknown".into())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_rejects() {
        assert_eq!("2/3".parse(), Ok(Shard { index: 2, count: 3 }));
        for bad in ["0/3", "4/3", "1/0", "x/2", "1", "1/2/3", "-1/2", ""] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
        assert!("1/100001"
            .parse::<Shard>()
            .unwrap_err()
            .to_string()
            .contains("at most"));
    }

    #[test]
    fn groups_are_dealt_whole_and_evenly() {
        // 23 groups of two items (a, b), interleaved as a plan orders them.
        let items: Vec<usize> = (0..46).map(|i| i / 2).collect();
        for count in 1..=7 {
            let dealt = deal_groups(items.iter(), count);
            for pair in dealt.chunks(2) {
                assert_eq!(pair[0], pair[1], "a group stays on one shard");
            }
            for index in 1..=count {
                let n = dealt.iter().filter(|s| s.index == index).count() / 2;
                assert!(n == 23 / count || n == 23 / count + 1, "{count}: {n}");
            }
        }
    }

    #[test]
    fn hash_depends_on_text_and_quick() {
        let a = manifest_hash("name = \"a\"", false);
        assert_eq!(a.len(), 64);
        assert_eq!(a, manifest_hash("name = \"a\"", false));
        assert_ne!(a, manifest_hash("name = \"a\"", true));
        assert_ne!(a, manifest_hash("name = \"b\"", false));
    }
}
