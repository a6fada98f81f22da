//! How often a named verdict of each kind and strength was right on the nuisance-swept bench
//! (World N, `bench/independent/world_n`: controls, the catalogue's effects and causes outside
//! it, each under random nuisance structure; both parts, datasets and their twins). Strength is
//! the share of the gap the named effect closes out of sample, by quarter. The table is the
//! bench's own output (`score.py --reliability`, the parts merged): regenerate it after a change
//! that moves verdicts (docs/diagnosing.md, *Verdicts*, shows it).

use crate::effect_id::EffectId;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::sync::OnceLock;

/// The bench's table, as `score.py --reliability` writes it.
const TABLE_JSON: &str = include_str!("reliability.json");

#[derive(Debug, Deserialize)]
struct Table {
    table: BTreeMap<String, BTreeMap<String, Cell>>,
}

/// One effect at one strength: how often named, how often right.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
pub struct Cell {
    /// Verdicts of this kind and strength on the bench.
    pub named: u32,
    /// Those that were right.
    pub right: u32,
}

/// What the bench says of a verdict naming `effect` that closes `shrink_pct` % of the gap.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Reliability {
    /// The strength bin, `0-25` … `75-100` [% of the gap closed].
    pub bin: &'static str,
    /// The bench's counts there.
    pub cell: Cell,
}

impl Reliability {
    /// "right 30 of 31 times on the nuisance-swept bench (…)".
    pub fn describe(&self, effect: EffectId) -> String {
        format!(
            "on the nuisance-swept bench, `{effect}` verdicts closing {} % of the gap were right \
             {} of {} times",
            self.bin, self.cell.right, self.cell.named
        )
    }
}

const BINS: [&str; 4] = ["0-25", "25-50", "50-75", "75-100"];

fn table() -> &'static BTreeMap<String, BTreeMap<String, Cell>> {
    static TABLE: OnceLock<BTreeMap<String, BTreeMap<String, Cell>>> = OnceLock::new();
    TABLE.get_or_init(|| {
        serde_json::from_str::<Table>(TABLE_JSON)
            .map(|t| t.table)
            .unwrap_or_default()
    })
}

/// The bench's record for `effect` named at `shrink_pct`; `None` where it never named one.
pub fn of(effect: EffectId, shrink_pct: f64) -> Option<Reliability> {
    let index = if shrink_pct.is_finite() {
        ((shrink_pct.max(0.0) / 25.0) as usize).min(BINS.len() - 1)
    } else {
        0
    };
    let bin = BINS[index];
    let cell = *table().get(effect.id())?.get(bin)?;
    (cell.named > 0).then_some(Reliability { bin, cell })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bench_table_reads_and_names_only_catalogued_effects() {
        assert!(!table().is_empty(), "reliability.json did not parse");
        for (effect, bins) in table() {
            assert!(EffectId::from_id(effect).is_some(), "{effect}");
            for (bin, cell) in bins {
                assert!(BINS.contains(&bin.as_str()) || bin == "unknown", "{bin}");
                assert!(cell.right <= cell.named, "{effect} {bin}: {cell:?}");
            }
        }
        // The bins: below 0 is the first, 100 and above the last.
        let any = EffectId::ALL
            .into_iter()
            .find_map(|e| of(e, 60.0).map(|r| (e, r)));
        let (e, r) = any.expect("some effect named at 50-75 %");
        assert_eq!(r.bin, "50-75");
        assert!(r.describe(e).contains("right"));
        assert_eq!(of(e, -5.0).map(|r| r.bin), of(e, 10.0).map(|r| r.bin));
    }
}
