//! The faces around one vertex, as the simplifier keeps them: corners inline in two cache lines
//! for the usual valence, on the heap beyond it.
//!
//! The collapse looks a face up in a neighbour's fan about ten times; in a fan of variable length
//! a search that stops at the match (or at the end) mispredicts its exit about once per search
//! wherever the match falls. The inline corners are therefore kept with padding that matches
//! nothing, so the searches here run over all [`FAN_INLINE`] slots with no branch on the data.

use crate::prefetch::prefetch;

use crate::mesh::NONE;

/// One face at a vertex `v`, read from `v` in the face's orientation: (v, next, prev). Fans carry
/// the corners so that the hot checks (link condition, folds, neighbour rings) never look up the
/// triangle array.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Corner {
    pub(crate) face: u32,
    pub(crate) next: u32,
    pub(crate) prev: u32,
}

impl Corner {
    /// The padding of a fan's unused inline slots: no face, no vertex.
    pub(crate) const NONE: Corner = Corner { face: NONE, next: NONE, prev: NONE };

    /// The corner of this face that is neither the fan's vertex nor `x` (one of `next`, `prev`).
    #[inline]
    pub(crate) fn other(&self, x: u32) -> u32 {
        debug_assert!(self.touches(x), "{x} is not a corner of {self:?}");
        // x is one of the two: the other is what is left of their XOR (no branch on which).
        self.next ^ self.prev ^ x
    }

    /// Whether `x` is one of this face's other two corners (both compared: no branch).
    #[inline]
    pub(crate) fn touches(&self, x: u32) -> bool {
        (self.next == x) | (self.prev == x)
    }
}

/// Faces around a vertex kept inline up to this count (valence 6 is typical; merged vertices
/// reach 8–10 before their neighbours collapse in turn); larger fans move to the heap, and back
/// when they shrink to this count again.
pub(crate) const FAN_INLINE: usize = 8;

/// The faces around one vertex, in two whole cache lines of its own (a prefetch hint can name
/// both: [`FanSlot::prefetch`]). Derefs to the live corners, in order.
///
/// Up to [`FAN_INLINE`] corners live in `inline`, the slots past them holding [`Corner::NONE`];
/// a larger fan lives wholly in `spill` (`inline` then unused).
#[derive(Debug, Clone)]
#[repr(C, align(64))]
pub(crate) struct FanSlot {
    inline: [Corner; FAN_INLINE],
    len: u32,
    spill: Vec<Corner>,
}

const _: () = assert!(std::mem::size_of::<FanSlot>() == 128);

impl Default for FanSlot {
    fn default() -> Self {
        FanSlot { inline: [Corner::NONE; FAN_INLINE], len: 0, spill: Vec::new() }
    }
}

impl FanSlot {
    /// Asks the cache for both lines of the fan.
    #[inline]
    pub(crate) fn prefetch(&self) {
        prefetch(&self.inline[0]);
        prefetch(&self.spill);
    }

    /// All inline slots (the live corners first, then padding), when the fan is inline.
    #[inline]
    pub(crate) fn inline_slots(&self) -> Option<&[Corner; FAN_INLINE]> {
        self.is_inline().then_some(&self.inline)
    }

    #[inline]
    fn is_inline(&self) -> bool {
        self.len as usize <= FAN_INLINE
    }

    pub(crate) fn push(&mut self, corner: Corner) {
        let len = self.len as usize;
        if len < FAN_INLINE {
            self.inline[len] = corner;
        } else {
            if len == FAN_INLINE {
                self.spill.extend_from_slice(&self.inline);
            }
            self.spill.push(corner);
        }
        self.len += 1;
    }

    /// Back inline once a spilled fan has shrunk to fit (the heap buffer keeps its capacity).
    fn settle(&mut self) {
        if self.is_inline() && !self.spill.is_empty() {
            let len = self.len as usize;
            self.inline = [Corner::NONE; FAN_INLINE];
            self.inline[..len].copy_from_slice(&self.spill[..len]);
            self.spill.clear();
        }
    }

    /// Removes the corner at `i`, keeping the order of the others.
    pub(crate) fn remove(&mut self, i: usize) {
        assert!(i < self.len as usize, "corner {i} of a fan of {}", self.len);
        if self.is_inline() {
            // A fixed-length shift (no branch on where `i` falls); the last slot becomes padding.
            let mut shifted = [Corner::NONE; FAN_INLINE];
            for (j, slot) in shifted.iter_mut().enumerate().take(FAN_INLINE - 1) {
                *slot = self.inline[j + (j >= i) as usize];
            }
            self.inline = shifted;
        } else {
            self.spill.remove(i);
        }
        self.len -= 1;
        self.settle();
    }

    /// Keeps the corners `keep` accepts, in order.
    pub(crate) fn retain(&mut self, mut keep: impl FnMut(&Corner) -> bool) {
        if self.is_inline() {
            // Every slot copied and the write position advanced by the verdict (padding is never
            // kept), then the tail padded: no branch on the verdicts.
            let len = self.len as usize;
            let mut kept = [Corner::NONE; FAN_INLINE];
            let mut count = 0;
            for (j, corner) in self.inline.iter().enumerate() {
                kept[count.min(FAN_INLINE - 1)] = *corner;
                count += ((j < len) & keep(corner)) as usize;
            }
            for (j, slot) in kept.iter_mut().enumerate() {
                if j >= count {
                    *slot = Corner::NONE;
                }
            }
            self.inline = kept;
            self.len = count as u32;
        } else {
            self.spill.retain(|c| keep(c));
            self.len = self.spill.len() as u32;
            self.settle();
        }
    }

    /// Bit `j` set where inline slot `j` passes `test`, over every slot (padding included: the
    /// tests used here never pass it, NONE being no face and no vertex).
    #[inline(always)]
    fn inline_hits(&self, test: impl Fn(&Corner) -> bool) -> u32 {
        let mut hits = 0u32;
        for (j, corner) in self.inline.iter().enumerate() {
            hits |= (test(corner) as u32) << j;
        }
        hits
    }

    /// Where the corner of `face` is, if the fan has one.
    #[inline]
    pub(crate) fn find_face(&self, face: u32) -> Option<usize> {
        if self.is_inline() {
            let hits = self.inline_hits(|corner| corner.face == face);
            (hits != 0).then(|| hits.trailing_zeros() as usize)
        } else {
            self.spill.iter().position(|c| c.face == face)
        }
    }

    /// The corners whose face has the edge to `x` (at most two around a manifold edge; the count
    /// says how many there are in all).
    #[inline]
    pub(crate) fn touching(&self, x: u32) -> ([Corner; 2], usize) {
        let mut out = [Corner::NONE; 2];
        if self.is_inline() {
            let hits = self.inline_hits(|corner| corner.touches(x));
            let count = hits.count_ones() as usize;
            if hits != 0 {
                out[0] = self.inline[hits.trailing_zeros() as usize];
                let rest = hits & (hits - 1);
                if rest != 0 {
                    out[1] = self.inline[rest.trailing_zeros() as usize];
                }
            }
            (out, count)
        } else {
            let mut n = 0;
            for c in self.spill.iter().filter(|c| c.touches(x)) {
                if n < 2 {
                    out[n] = *c;
                }
                n += 1;
            }
            (out, n)
        }
    }
}

impl std::ops::Deref for FanSlot {
    type Target = [Corner];
    #[inline]
    fn deref(&self) -> &[Corner] {
        if self.is_inline() { &self.inline[..self.len as usize] } else { &self.spill }
    }
}

impl std::ops::DerefMut for FanSlot {
    #[inline]
    fn deref_mut(&mut self) -> &mut [Corner] {
        if self.is_inline() { &mut self.inline[..self.len as usize] } else { &mut self.spill }
    }
}

impl<'a> IntoIterator for &'a FanSlot {
    type Item = &'a Corner;
    type IntoIter = std::slice::Iter<'a, Corner>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;

    fn corner(face: u32) -> Corner {
        Corner { face, next: 1000 + face, prev: 2000 + face }
    }

    /// Every operation against a plain `Vec` of the same corners, across the inline/heap line.
    #[test]
    fn behaves_like_a_vec_on_both_sides_of_the_inline_limit() {
        let mut rng = SplitMix64::new(5);
        let mut fan = FanSlot::default();
        let mut reference: Vec<Corner> = Vec::new();
        let mut next_face = 0;
        for step in 0..20_000 {
            match rng.next_u64() % 5 {
                0 | 1 if reference.len() < 20 => {
                    fan.push(corner(next_face));
                    reference.push(corner(next_face));
                    next_face += 1;
                }
                2 if !reference.is_empty() => {
                    let i = (rng.next_u64() % reference.len() as u64) as usize;
                    fan.remove(i);
                    reference.remove(i);
                }
                3 => {
                    let cut = rng.next_u64() % 4;
                    fan.retain(|c| c.face as u64 % 4 != cut);
                    reference.retain(|c| c.face as u64 % 4 != cut);
                }
                _ => {
                    let x = 1000 + (rng.next_u64() % (next_face as u64 + 1)) as u32;
                    let (found, count) = fan.touching(x);
                    let expected: Vec<Corner> = reference.iter().copied().filter(|c| c.touches(x)).collect();
                    assert_eq!(count, expected.len(), "step {step}");
                    assert_eq!(&found[..count.min(2)], &expected[..count.min(2)], "step {step}");
                }
            }
            assert_eq!(&fan[..], &reference[..], "step {step}");
            for c in &reference {
                assert_eq!(fan.find_face(c.face), reference.iter().position(|d| d.face == c.face));
            }
            assert_eq!(fan.find_face(next_face + 7), None);
            if reference.len() <= FAN_INLINE {
                assert!(fan.spill.is_empty(), "step {step}: a fan that fits is back inline");
                assert!(fan.inline[reference.len()..].iter().all(|c| *c == Corner::NONE), "step {step}: padding");
            }
        }
    }
}
