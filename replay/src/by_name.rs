//! What a job adds up per static name (shading stages, traffic classes): a short list scanned
//! in place, where the report's maps keyed by owned strings cost an allocation per name and a
//! string comparison per lookup. A job's list is added to the frame's report once, when the
//! job is done.

/// Values by `&'static str`, in the order their names were first used.
#[derive(Clone, Debug)]
pub struct ByName<T>(Vec<(&'static str, T)>);

impl<T> Default for ByName<T> {
    fn default() -> Self {
        ByName(Vec::new())
    }
}

impl<T: Default> ByName<T> {
    /// The value of `name`, created (default) on first use.
    #[inline]
    pub fn entry(&mut self, name: &'static str) -> &mut T {
        let i = match self.0.iter().position(|(n, _)| std::ptr::eq(*n, name) || *n == name) {
            Some(i) => i,
            None => {
                self.0.push((name, T::default()));
                self.0.len() - 1
            }
        };
        &mut self.0[i].1
    }
}

impl<T> ByName<T> {
    /// Every name and its value, in first-use order.
    pub fn iter(&self) -> impl Iterator<Item = (&'static str, &T)> {
        self.0.iter().map(|(name, value)| (*name, value))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A name reached through another string with the same text is the same entry.
    #[test]
    fn names_are_compared_by_text() {
        let mut sums = ByName::<u64>::default();
        *sums.entry("fine") += 2;
        let same = String::from("fine").leak();
        *sums.entry(same) += 3;
        *sums.entry("coarse") += 1;
        let all: Vec<(&str, u64)> = sums.iter().map(|(n, v)| (n, *v)).collect();
        assert_eq!(all, [("fine", 5), ("coarse", 1)]);
    }
}
