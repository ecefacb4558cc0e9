//! Discrete choices made exactly: a table of slots among choices.
//!
//! A random integer in `0..total` picks the choice whose slots hold it.
//! Each choice of positive weight owns about its share of the slots, and
//! at least one, so it can always be chosen; a choice of weight 0 owns
//! none. An estimator divides by the share of slots a choice *owns*
//! (`probability`), not by the weight share those slots approximate, so
//! it stays unbiased however the shares round. (A cumulative table of f32
//! searched with a 24-bit draw gives tiny choices probabilities far off
//! their weights, or none at all.)

/// Where each choice's slots end.
#[derive(Clone, Debug, PartialEq)]
pub struct SlotTable {
    /// End (exclusive) of each choice's slots; the last is `total`.
    ends: Vec<u64>,
    total: u64,
}

impl SlotTable {
    /// The table of `total` slots among choices of weights `weights`
    /// (finite, ≥ 0). `None` if no weight is positive, or if more weights
    /// are positive than there are slots.
    pub fn new(weights: &[f64], total: u64) -> Option<SlotTable> {
        let positive = weights.iter().filter(|&&w| w > 0.0).count() as u64;
        if positive == 0 || positive > total {
            return None;
        }
        let sum: f64 = weights.iter().sum();
        let last = weights.iter().rposition(|&w| w > 0.0)?;
        // Rounded cumulative shares, the last positive one exactly
        // `total`; then no end later than leaves a slot to each positive
        // choice after it, and none earlier than one slot past the end
        // before it. A choice of weight 0 ends where the one before did.
        let (mut cumulative, mut previous, mut after) = (0.0, 0, positive);
        let ends = weights
            .iter()
            .enumerate()
            .map(|(i, &w)| {
                if w <= 0.0 {
                    return previous;
                }
                after -= 1;
                cumulative += w;
                let rounded = if i >= last {
                    total
                } else {
                    (cumulative / sum * total as f64).round() as u64
                };
                previous = rounded.min(total - after).max(previous + 1);
                previous
            })
            .collect();
        Some(SlotTable { ends, total })
    }

    /// The choice that owns `slot` (< `total`).
    #[inline]
    pub fn choose(&self, slot: u64) -> usize {
        choose(&self.ends, slot)
    }

    /// The slots of choice `i`: `start..end`.
    #[inline]
    pub fn slots(&self, i: usize) -> std::ops::Range<u64> {
        owned(&self.ends, i)
    }

    /// The probability that choice `i` is made.
    pub fn probability(&self, i: usize) -> f64 {
        probability(&self.ends, i, self.total)
    }

    /// Where each choice's slots end.
    pub fn ends(&self) -> &[u64] {
        &self.ends
    }

    /// Number of choices (those of weight 0 included).
    pub fn len(&self) -> usize {
        self.ends.len()
    }

    pub fn is_empty(&self) -> bool {
        self.ends.is_empty()
    }
}

/// The choice whose slots, ending at `ends` (a table's ends, in any
/// integer type that holds them), hold `slot`.
#[inline]
pub fn choose<E: Copy + Ord>(ends: &[E], slot: E) -> usize {
    // The last end is the total, past every slot.
    ends.partition_point(|&end| end <= slot)
}

/// The slots of choice `i` among `ends`: `start..end`.
#[inline]
pub fn owned<E: Copy + Default>(ends: &[E], i: usize) -> std::ops::Range<E> {
    (if i == 0 { E::default() } else { ends[i - 1] })..ends[i]
}

/// The probability of choice `i` among `ends`, of `total` slots.
#[inline]
pub fn probability<E: Copy + Default + Into<u64>>(ends: &[E], i: usize, total: u64) -> f64 {
    let s = owned(ends, i);
    (s.end.into() - s.start.into()) as f64 / total as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Choices of weight 0 own no slot and are never chosen; every other
    /// owns at least one, however small its share, and the shares stay
    /// within a slot of the weights'.
    #[test]
    fn zero_weights_own_no_slot_and_tiny_ones_own_one() {
        let weights = [0.0, 5.0, 0.0, 1e-12, 3.0, 0.0, 0.0, 2.0, 0.0];
        let total = 1 << 10;
        let table = SlotTable::new(&weights, total).unwrap();
        let sum: f64 = weights.iter().sum();
        let mut owners = vec![0u64; weights.len()];
        for slot in 0..total {
            owners[table.choose(slot)] += 1;
        }
        for (i, &w) in weights.iter().enumerate() {
            let owned = table.slots(i).end - table.slots(i).start;
            assert_eq!(owners[i], owned, "choice {i}");
            assert_eq!(
                owned == 0,
                w == 0.0,
                "choice {i} of weight {w} owns {owned}"
            );
            assert!(
                (table.probability(i) - w / sum).abs() <= 2.0 / total as f64,
                "choice {i}: {} against {}",
                table.probability(i),
                w / sum
            );
        }
        assert_eq!(SlotTable::new(&[0.0, 0.0], total), None);
        assert_eq!(SlotTable::new(&[1.0, 1.0, 1.0], 2), None);
    }
}
