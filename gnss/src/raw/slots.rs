//! State kept per satellite and band slot across a log's epochs (lock times, slip flags), in
//! a dense table: the decoders look it up for every signal of every epoch, where a hash map's
//! hashing was a tenth of a conversion.

use crate::sv::{Constellation, Sv};

/// A value per (satellite, band slot 0..3), every one starting as `T::default()`.
pub struct SlotTable<T> {
    v: Vec<T>,
}

impl<T: Default + Clone> Default for SlotTable<T> {
    fn default() -> Self {
        SlotTable {
            v: vec![T::default(); Constellation::ALL.len() * 256 * 3],
        }
    }
}

impl<T> SlotTable<T> {
    /// The value of `sv`'s band `slot` (0, 1 or 2; larger slots share slot 2).
    pub fn get_mut(&mut self, sv: Sv, slot: usize) -> &mut T {
        debug_assert!(slot < 3);
        let k = (sv.sys.index() * 256 + usize::from(sv.prn)) * 3 + slot.min(2);
        &mut self.v[k]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_satellite_and_slot_has_its_own_value() {
        let mut t = SlotTable::<u32>::default();
        let mut n = 0;
        for sys in Constellation::ALL {
            for prn in 0..=255u8 {
                for slot in 0..3 {
                    n += 1;
                    *t.get_mut(Sv::new(sys, prn), slot) = n;
                }
            }
        }
        assert_eq!(*t.get_mut(Sv::new(Constellation::Gps, 0), 0), 1);
        assert_eq!(*t.get_mut(Sv::new(Constellation::Irnss, 255), 2), n);
        assert_eq!(
            *t.get_mut(Sv::new(Constellation::Galileo, 7), 1),
            768 + 7 * 3 + 2
        );
    }
}
