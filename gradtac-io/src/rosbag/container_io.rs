//! What the two container readers ([`super::bag`] and [`super::mcap_read`]) share: reading
//! a file up to a buffer's size, and an error at a byte offset of the file.

use crate::error::BagSite;
use crate::{Error, Result};
use std::fs::File;
use std::io::{BufReader, Read};
use std::path::{Path, PathBuf};

/// Open a container file for reading: the path, a 64 KiB buffered reader and the file's
/// length. Anything but a regular file (a directory, a FIFO, a device) is refused.
pub(crate) fn open_regular(path: impl AsRef<Path>) -> Result<(PathBuf, BufReader<File>, u64)> {
    let path = path.as_ref().to_path_buf();
    let f = File::open(&path).map_err(|source| Error::Io { path: path.clone(), source })?;
    let meta = f.metadata().map_err(|source| Error::Io { path: path.clone(), source })?;
    if !meta.is_file() {
        return Err(Error::Bag { path, site: Box::default(), reason: "not a regular file".into() });
    }
    Ok((path, BufReader::with_capacity(1 << 16, f), meta.len()))
}

/// A container error at byte `offset` of `path`.
pub(crate) fn error_at(path: &Path, offset: u64, reason: impl Into<String>) -> Error {
    Error::Bag {
        path: path.to_path_buf(),
        site: Box::new(BagSite { offset: Some(offset), ..BagSite::default() }),
        reason: reason.into(),
    }
}

/// Read into `buf` until it is full or the input ends (retrying when interrupted), adding the
/// bytes read to `pos`; the number of bytes read. An I/O error names `path`.
pub(crate) fn read_up_to(input: &mut impl Read, path: &Path, pos: &mut u64, buf: &mut [u8]) -> Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match input.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(source) => return Err(Error::Io { path: path.to_path_buf(), source }),
        }
    }
    *pos += n as u64;
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A reader that is interrupted once, then hands out at most 3 bytes a call.
    struct Choppy<'a> {
        data: &'a [u8],
        interrupted: bool,
    }

    impl Read for Choppy<'_> {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            if !self.interrupted {
                self.interrupted = true;
                return Err(std::io::ErrorKind::Interrupted.into());
            }
            let k = buf.len().min(3).min(self.data.len());
            buf[..k].copy_from_slice(&self.data[..k]);
            self.data = &self.data[k..];
            Ok(k)
        }
    }

    #[test]
    fn reads_until_full_or_the_end_across_short_reads_and_interrupts() {
        let mut pos = 10;
        let mut buf = [0u8; 5];
        let mut r = Choppy { data: b"abcdefg", interrupted: false };
        assert_eq!(read_up_to(&mut r, Path::new("x"), &mut pos, &mut buf).unwrap(), 5);
        assert_eq!(&buf, b"abcde");
        assert_eq!(pos, 15);
        let mut rest = [0u8; 5];
        assert_eq!(read_up_to(&mut r, Path::new("x"), &mut pos, &mut rest).unwrap(), 2);
        assert_eq!(&rest[..2], b"fg");
        assert_eq!(pos, 17);
    }

    #[test]
    fn an_error_names_the_file_and_offset() {
        let e = error_at(Path::new("hand.bag"), 86, "bad record").to_string();
        assert!(e.contains("hand.bag") && e.contains("86") && e.contains("bad record"), "{e}");
    }
}
