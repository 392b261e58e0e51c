//! `--shard K/N`: which items shard K of N runs. The partition is a deterministic
//! function of the item list (ids and estimated costs): items in decreasing cost (ties by
//! id) go one by one to the shard with the least cost so far (ties to the lowest shard),
//! the longest-processing-time rule. Every machine computes the same partition; no shard
//! needs to talk to another.

use crate::error::{Error, Result};

use super::plan::Item;

/// Shard `index` (from 1) of `count`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// Which shard, 1 to `count`.
    pub index: usize,
    /// How many shards.
    pub count: usize,
}

impl Shard {
    /// The whole campaign in one shard.
    pub const ALL: Shard = Shard { index: 1, count: 1 };
}

impl std::str::FromStr for Shard {
    type Err = String;

    /// `K/N` with 1 <= K <= N (as a Slurm array `--array=1-N` or GNU parallel's `{#}` count).
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let (k, n) = s.split_once('/').ok_or_else(|| format!("'{s}': expected K/N, e.g. 2/8"))?;
        let parse = |x: &str| x.trim().parse::<usize>().map_err(|_| format!("'{s}': '{x}' is not a count"));
        let (index, count) = (parse(k)?, parse(n)?);
        if count == 0 || index == 0 || index > count {
            return Err(format!("'{s}': K must be between 1 and N (shards are counted from 1)"));
        }
        Ok(Shard { index, count })
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// The shard (from 1) of each item of `items`, in the items' order.
pub fn assign(items: &[Item], count: usize) -> Result<Vec<usize>> {
    if count == 0 {
        return Err(Error::Invalid("a campaign needs at least one shard".into()));
    }
    let mut order: Vec<usize> = (0..items.len()).collect();
    order.sort_by(|&a, &b| items[b].cost.cmp(&items[a].cost).then_with(|| items[a].id.cmp(&items[b].id)));
    let mut load = vec![0u128; count];
    let mut out = vec![0; items.len()];
    for i in order {
        let (s, _) = load.iter().enumerate().min_by_key(|&(k, l)| (*l, k)).expect("count > 0");
        load[s] += u128::from(items[i].cost);
        out[i] = s + 1;
    }
    Ok(out)
}

/// The items of `shard`, in the items' order.
pub fn select(items: &[Item], shard: Shard) -> Result<Vec<&Item>> {
    let owner = assign(items, shard.count)?;
    Ok(items.iter().zip(owner).filter(|(_, s)| *s == shard.index).map(|(i, _)| i).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::campaign::plan::ItemKind;

    fn items(costs: &[u64]) -> Vec<Item> {
        costs
            .iter()
            .enumerate()
            .map(|(k, &c)| Item {
                id: format!("i{k:02}"),
                kind: ItemKind::Speed,
                input: format!("m{k}"),
                set: None,
                cost: c,
            })
            .collect()
    }

    #[test]
    fn shards_cover_every_item_once_and_balance_the_cost() {
        let v = items(&[100, 1, 1, 1, 50, 50, 7, 3, 90, 10, 10, 10]);
        let mut seen = vec![0; v.len()];
        let mut loads = Vec::new();
        for k in 1..=3 {
            let s = select(&v, Shard { index: k, count: 3 }).unwrap();
            loads.push(s.iter().map(|i| i.cost).sum::<u64>());
            for i in s {
                seen[v.iter().position(|x| x.id == i.id).unwrap()] += 1;
            }
        }
        assert!(seen.iter().all(|&n| n == 1), "{seen:?}");
        assert_eq!(loads.iter().sum::<u64>(), 333);
        assert!(loads.iter().max().unwrap() - loads.iter().min().unwrap() <= 10, "{loads:?}");
        // The same list gives the same partition (no timing, no machine).
        assert_eq!(assign(&v, 3).unwrap(), assign(&v.clone(), 3).unwrap());
    }

    #[test]
    fn shard_syntax() {
        assert_eq!("2/4".parse::<Shard>().unwrap(), Shard { index: 2, count: 4 });
        for bad in ["0/4", "5/4", "1/0", "x/2", "3"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
    }
}
