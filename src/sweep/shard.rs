//! Which part of a sweep this process runs: `--shard I/N`, or a cluster scheduler's array
//! index (Slurm job arrays, Kubernetes Indexed Jobs), and a deterministic, cost-balanced
//! assignment of job groups to shards.

/// Shard `index` of `count` (0-based).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: u32,
    pub count: u32,
}

impl Shard {
    pub const WHOLE: Shard = Shard { index: 0, count: 1 };

    /// `I/N` with 0 <= I < N.
    pub fn parse(text: &str) -> Result<Shard, String> {
        let bad = || format!("--shard {text}: expected I/N with 0 <= I < N, e.g. 0/4");
        let (i, n) = text.split_once('/').ok_or_else(bad)?;
        let (index, count) = (
            i.trim().parse().map_err(|_| bad())?,
            n.trim().parse().map_err(|_| bad())?,
        );
        Shard::new(index, count).ok_or_else(bad)
    }

    fn new(index: u32, count: u32) -> Option<Shard> {
        (count > 0 && index < count).then_some(Shard { index, count })
    }

    /// The shard a cluster scheduler gave this process, from `env`: Slurm's
    /// `SLURM_ARRAY_TASK_ID` with `SLURM_ARRAY_TASK_COUNT` (or `_MIN`/`_MAX`), or
    /// Kubernetes' `JOB_COMPLETION_INDEX` with `shards` (the Job's completions, which the
    /// pod cannot read). None outside an array job.
    pub fn from_env(env: &dyn Fn(&str) -> Option<String>, shards: Option<u32>) -> Result<Option<Shard>, String> {
        let number = |name: &str| -> Result<Option<u32>, String> {
            env(name)
                .map(|v| {
                    v.trim()
                        .parse::<u32>()
                        .map_err(|_| format!("{name}={v}: not a task index"))
                })
                .transpose()
        };
        if let Some(id) = number("SLURM_ARRAY_TASK_ID")? {
            let (min, max) = (number("SLURM_ARRAY_TASK_MIN")?, number("SLURM_ARRAY_TASK_MAX")?);
            let shard = match (number("SLURM_ARRAY_TASK_COUNT")?, min, max) {
                (_, Some(min), Some(max)) if max >= min => Shard::new(id.wrapping_sub(min), max - min + 1),
                (Some(count), _, _) => Shard::new(id, count),
                _ => None,
            };
            return shard
                .map(Some)
                .ok_or_else(|| format!("SLURM_ARRAY_TASK_ID={id}: outside the array's range"));
        }
        if let Some(index) = number("JOB_COMPLETION_INDEX")? {
            let count = shards.ok_or("JOB_COMPLETION_INDEX is set: give the Job's completions as --shards N")?;
            return Shard::new(index, count)
                .map(Some)
                .ok_or_else(|| format!("JOB_COMPLETION_INDEX={index}: not below --shards {count}"));
        }
        Ok(None)
    }

    /// The store file of this shard.
    pub fn store_name(&self) -> String {
        if *self == Shard::WHOLE {
            "sweep.db".to_string()
        } else {
            format!("shard-{:04}-of-{:04}.db", self.index, self.count)
        }
    }
}

/// The shard of each group of estimated cost `costs[g]`: longest first onto the least loaded
/// shard (ties to the lower group and shard index), so every process computes the same
/// assignment and the shards' totals stay within one group's cost of each other.
pub fn assign(costs: &[u64], count: u32) -> Vec<u32> {
    let mut order: Vec<usize> = (0..costs.len()).collect();
    order.sort_by(|&a, &b| costs[b].cmp(&costs[a]).then(a.cmp(&b)));
    let mut load = vec![0u64; count.max(1) as usize];
    let mut shard = vec![0u32; costs.len()];
    for g in order {
        let (least, _) = load.iter().enumerate().min_by_key(|&(i, &l)| (l, i)).unwrap_or((0, &0));
        shard[g] = least as u32;
        load[least] += costs[g];
    }
    shard
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shards_come_from_flags_and_schedulers() {
        assert_eq!(Shard::parse("1/4"), Ok(Shard { index: 1, count: 4 }));
        assert!(Shard::parse("4/4").is_err() && Shard::parse("x").is_err() && Shard::parse("0/0").is_err());
        let env = |vars: &'static [(&'static str, &'static str)]| {
            move |name: &str| vars.iter().find(|(k, _)| *k == name).map(|(_, v)| v.to_string())
        };
        let slurm = env(&[("SLURM_ARRAY_TASK_ID", "2"), ("SLURM_ARRAY_TASK_COUNT", "4")]);
        assert_eq!(Shard::from_env(&slurm, None), Ok(Some(Shard { index: 2, count: 4 })));
        let ranged = env(&[
            ("SLURM_ARRAY_TASK_ID", "11"),
            ("SLURM_ARRAY_TASK_MIN", "10"),
            ("SLURM_ARRAY_TASK_MAX", "13"),
        ]);
        assert_eq!(Shard::from_env(&ranged, None), Ok(Some(Shard { index: 1, count: 4 })));
        let k8s = env(&[("JOB_COMPLETION_INDEX", "3")]);
        assert_eq!(Shard::from_env(&k8s, Some(4)), Ok(Some(Shard { index: 3, count: 4 })));
        assert!(Shard::from_env(&k8s, None).is_err() && Shard::from_env(&k8s, Some(3)).is_err());
        assert_eq!(Shard::from_env(&env(&[]), None), Ok(None));
    }

    #[test]
    fn assignment_is_balanced_and_deterministic() {
        let costs = [10, 1, 7, 3, 3, 6, 2];
        let shards = assign(&costs, 3);
        assert_eq!(shards, assign(&costs, 3));
        let mut load = [0u64; 3];
        for (g, &s) in shards.iter().enumerate() {
            load[s as usize] += costs[g];
        }
        assert!(
            load.iter().max().unwrap() - load.iter().min().unwrap() <= 10,
            "{load:?}"
        );
        assert_eq!(assign(&costs, 1), vec![0; costs.len()]);
    }
}
