//! The decompression budget of the recorded-hand readers (ROS bag chunks: bz2, lz4; MCAP
//! chunks: zstd, lz4).
//!
//! A chunk declares its uncompressed size before a byte of it is decompressed; the budget
//! refuses, before decompressing, a chunk whose declared size exceeds
//! [`MAX_RATIO`] × its compressed size (beyond a [`RATIO_FLOOR_BYTES`] every chunk may
//! reach), and a file whose chunks together declare more than
//! [`MAX_TOTAL_RATIO`] × the file's size (beyond [`TOTAL_FLOOR_BYTES`]). The decompressors
//! themselves are read through `take(declared + 1)`, so a chunk that lies about its size
//! stops one byte past its claim and is refused for the mismatch.
//!
//! Trade-off: a genuine chunk that compresses better than 1024 : 1 and is larger than
//! 1 MiB (a topic of constant images, say) is refused too; tactile messages compress 2–20 : 1.
//! A 269-byte bzip2 chunk declaring 250 MiB of zeros is refused in microseconds instead of
//! costing a second and 250 MB each.

/// Largest accepted ratio of a chunk's declared uncompressed size to its compressed size.
pub const MAX_RATIO: u64 = 1024;
/// A chunk may declare up to this many bytes whatever its compressed size (1 MiB).
pub const RATIO_FLOOR_BYTES: u64 = 1 << 20;
/// Largest accepted ratio of the bytes all chunks of a file declare to the file's size.
pub const MAX_TOTAL_RATIO: u64 = 64;
/// The chunks of any file may declare up to this many bytes in all (256 MiB), whatever its size.
pub const TOTAL_FLOOR_BYTES: u64 = 256 << 20;

/// What one input may decompress (see the [module docs](self)).
#[derive(Clone, Debug)]
pub struct InflateBudget {
    total: u64,
    used: u64,
}

impl InflateBudget {
    /// The budget of a file of `file_len` bytes.
    pub fn for_file(file_len: u64) -> Self {
        InflateBudget { total: file_len.saturating_mul(MAX_TOTAL_RATIO).max(TOTAL_FLOOR_BYTES), used: 0 }
    }

    /// The per-file total.
    pub fn total(&self) -> u64 {
        self.total
    }

    /// Admit a chunk of `compressed` bytes declaring `declared` bytes uncompressed, or say why
    /// not (the caller names the file, the chunk and its offset).
    pub fn admit(&mut self, kind: &str, compressed: u64, declared: u64) -> Result<(), String> {
        let ratio_cap = compressed.saturating_mul(MAX_RATIO).max(RATIO_FLOOR_BYTES);
        if declared > ratio_cap {
            return Err(format!(
                "a {kind} chunk of {compressed} bytes declares {declared} bytes uncompressed: more than {MAX_RATIO} \
                 times its size (and above {RATIO_FLOOR_BYTES} bytes); refused as a decompression bomb"
            ));
        }
        let used = self.used.saturating_add(declared);
        if used > self.total {
            return Err(format!(
                "the chunks so far declare {used} bytes uncompressed, more than this file's budget of {} bytes \
                 ({MAX_TOTAL_RATIO} times its size, at least {TOTAL_FLOOR_BYTES}); refused as a decompression bomb",
                self.total
            ));
        }
        self.used = used;
        Ok(())
    }
}

/// Decompress `r` into `out` (cleared first), at most `declared + 1` bytes, growing the
/// buffer as bytes arrive (never reserving `declared` up front); `Ok(false)` when the stream
/// does not hold exactly `declared` bytes.
pub(crate) fn inflate_into(r: impl std::io::Read, declared: u64, out: &mut Vec<u8>) -> std::io::Result<bool> {
    use std::io::Read as _;
    out.clear();
    out.reserve(usize::try_from(declared).unwrap_or(usize::MAX).min(1 << 20));
    r.take(declared.saturating_add(1)).read_to_end(out)?;
    Ok(out.len() as u64 == declared)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ratio_and_total_bounds() {
        let mut b = InflateBudget::for_file(1000);
        assert_eq!(b.total(), TOTAL_FLOOR_BYTES);
        // the floor: any chunk may declare 1 MiB
        assert!(b.admit("bz2", 10, RATIO_FLOOR_BYTES).is_ok());
        assert!(b.admit("bz2", 10, RATIO_FLOOR_BYTES + 1).unwrap_err().contains("decompression bomb"));
        // the ratio
        assert!(b.admit("lz4", 4096, 4096 * MAX_RATIO).is_ok());
        assert!(b.admit("lz4", 4096, 4096 * MAX_RATIO + 1).is_err());
        // the total: 256 MiB floor for a small file
        let mut b = InflateBudget::for_file(1000);
        for _ in 0..256 {
            b.admit("bz2", 100, RATIO_FLOOR_BYTES).unwrap();
        }
        assert!(b.admit("bz2", 100, 1).unwrap_err().contains("budget"));
        // a large file: 64 times its size
        assert_eq!(InflateBudget::for_file(1 << 30).total(), 64 << 30);
        assert_eq!(InflateBudget::for_file(u64::MAX).total(), u64::MAX);
    }
}
