//! The identifier's large reusable buffers (bank predictions, their bins), on transparent huge
//! pages.
//!
//! A measurement reads 60–150 columns of 50,000 predictions: 12–30 MB, and bins them: another
//! 6–15 MB. In a fresh process that memory is touched for the first time, and on 4 kB pages
//! every 4 kB costs a page fault: some 4,500–11,000 faults, several milliseconds of a cold
//! `identify`. A buffer is an anonymous
//! mapping (`memmap2`) advised `MADV_HUGEPAGE`, so the kernel backs it with 2 MB pages where
//! it can (a hint: where it cannot, the buffer works the same on small pages). It grows when a
//! measurement needs more and is reused by the next.

use memmap2::{Advice, MmapMut};

/// The mapping's granularity: one huge page.
const HUGE_PAGE: usize = 2 << 20;

/// A growable buffer of plain values (`f32` predictions, `u16` bins) backed by an anonymous
/// mapping.
#[derive(Default)]
pub(crate) struct HugeBuffer {
    map: Option<MmapMut>,
}

impl std::fmt::Debug for HugeBuffer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "HugeBuffer({} bytes)", self.capacity_bytes())
    }
}

impl HugeBuffer {
    fn capacity_bytes(&self) -> usize {
        self.map.as_ref().map_or(0, |m| m.len())
    }

    /// The first `len` values (contents unspecified: the caller overwrites them), growing the
    /// mapping when it is too small.
    pub(crate) fn values<T: bytemuck::Pod>(&mut self, len: usize) -> std::io::Result<&mut [T]> {
        let bytes = len * std::mem::size_of::<T>();
        if self.capacity_bytes() < bytes {
            let map = MmapMut::map_anon(bytes.next_multiple_of(HUGE_PAGE))?;
            // Advisory: a kernel without transparent huge pages refuses, and small pages serve.
            let _ = map.advise(Advice::HugePage);
            self.map = Some(map);
        }
        let map = self.map.as_mut().expect("mapped above");
        Ok(bytemuck::cast_slice_mut(&mut map[..bytes]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_buffer_grows_and_keeps_what_fits() {
        let mut b = HugeBuffer::default();
        b.values(10).unwrap().copy_from_slice(&[1.5f32; 10]);
        assert!(b
            .values::<f32>(10)
            .unwrap()
            .iter()
            .all(|&v| v.to_bits() == 1.5f32.to_bits()));
        // Larger than one huge page: a new mapping of the whole size, zeroed.
        let big = b.values::<f32>(HUGE_PAGE).unwrap();
        assert_eq!(big.len(), HUGE_PAGE);
        assert!(big.iter().all(|&v| v.to_bits() == 0));
        big[HUGE_PAGE - 1] = 7.0;
        assert_eq!(
            b.values::<f32>(HUGE_PAGE).unwrap()[HUGE_PAGE - 1].to_bits(),
            7.0f32.to_bits()
        );
        assert_eq!(b.values::<f32>(0).unwrap().len(), 0);
        // The same mapping serves another type: 2 MB of u16 fits the 8 MB mapped above.
        assert_eq!(b.values::<u16>(HUGE_PAGE).unwrap().len(), HUGE_PAGE);
    }
}
