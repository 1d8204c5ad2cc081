//! A file written around the page cache (`O_DIRECT`, Linux): whole,
//! aligned blocks go from one aligned buffer straight to the disk, so the
//! kernel neither copies every byte into its cache nor holds gigabytes of
//! it dirty. The tail is written padded to a block and the file cut to its
//! length at the end. Where the file system refuses `O_DIRECT` (tmpfs, for
//! one), the same writer goes through the page cache.

use std::fs::{File, OpenOptions};
use std::io::{self, Write};
use std::path::Path;

/// The alignment and granularity of direct writes (bytes).
const BLOCK: usize = 4096;
/// Bytes gathered before a write.
const CHUNK: usize = 8 << 20;

/// Gathers bytes in an aligned buffer and writes them in whole chunks.
pub struct DirectFile {
    file: File,
    direct: bool,
    /// CHUNK + BLOCK bytes; the aligned window starts at `start`.
    buf: Vec<u8>,
    start: usize,
    len: usize,
    written: u64,
}

impl DirectFile {
    /// Opens `path` (which exists, empty) for writing, directly if the
    /// file system allows it.
    pub fn open(path: &Path) -> io::Result<Self> {
        Self::open_with(path, true)
    }

    fn open_with(path: &Path, try_direct: bool) -> io::Result<Self> {
        let (file, direct) = match try_direct.then(|| direct_open(path)) {
            Some(Ok(f)) => (f, true),
            _ => (OpenOptions::new().write(true).open(path)?, false),
        };
        let buf = vec![0u8; CHUNK + BLOCK];
        let start = buf.as_ptr().align_offset(BLOCK);
        Ok(Self {
            file,
            direct,
            buf,
            start,
            len: 0,
            written: 0,
        })
    }

    /// Whether writes bypass the page cache.
    pub fn is_direct(&self) -> bool {
        self.direct
    }

    fn write_chunk(&mut self, bytes: usize) -> io::Result<()> {
        self.file
            .write_all(&self.buf[self.start..self.start + bytes])?;
        self.written += bytes as u64;
        Ok(())
    }

    /// Syncs what has been written (the gathered rest is not).
    pub fn sync_written(&mut self) -> io::Result<()> {
        self.file.sync_data()
    }

    /// Writes what is left (the last block zero-padded), cuts the file to
    /// its length and syncs it.
    pub fn finish(mut self) -> io::Result<File> {
        let len = self.len;
        let padded = len.div_ceil(BLOCK) * BLOCK;
        self.buf[self.start + len..self.start + padded].fill(0);
        self.write_chunk(padded)?;
        self.file.set_len(self.written - (padded - len) as u64)?;
        self.file.sync_all()?;
        Ok(self.file)
    }
}

#[cfg(target_os = "linux")]
fn direct_open(path: &Path) -> io::Result<File> {
    use std::os::unix::fs::OpenOptionsExt;
    OpenOptions::new()
        .write(true)
        .custom_flags(libc::O_DIRECT)
        .open(path)
}

#[cfg(not(target_os = "linux"))]
fn direct_open(_: &Path) -> io::Result<File> {
    Err(io::ErrorKind::Unsupported.into())
}

impl Write for DirectFile {
    fn write(&mut self, data: &[u8]) -> io::Result<usize> {
        let n = data.len().min(CHUNK - self.len);
        let at = self.start + self.len;
        self.buf[at..at + n].copy_from_slice(&data[..n]);
        self.len += n;
        if self.len == CHUNK {
            self.write_chunk(CHUNK)?;
            self.len = 0;
        }
        Ok(n)
    }

    /// Whole chunks are written as they fill; the rest waits for
    /// [`DirectFile::finish`] (a direct write must be whole blocks).
    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whatever the sizes written, the file holds exactly the bytes, in
    /// order (chunk boundaries, a partial last block, an empty file),
    /// written directly (where the temporary folder's file system allows
    /// it) and through the page cache.
    #[test]
    fn the_file_holds_exactly_what_was_written() {
        let dir = std::env::temp_dir().join(format!("impactmc-direct-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for try_direct in [true, false] {
            for total in [
                0usize,
                1,
                4095,
                4096,
                4097,
                CHUNK,
                CHUNK + 1,
                2 * CHUNK + 12_345,
            ] {
                let path = dir.join(format!("f{total}-{try_direct}"));
                File::create(&path).unwrap();
                let data: Vec<u8> = (0..total).map(|i| (i * 7 + i / 251) as u8).collect();
                let mut f = DirectFile::open_with(&path, try_direct).unwrap();
                assert!(try_direct || !f.is_direct());
                let mut at = 0;
                let mut piece = 1;
                while at < total {
                    let n = piece.min(total - at);
                    f.write_all(&data[at..at + n]).unwrap();
                    at += n;
                    piece = piece * 3 + 1;
                }
                f.finish().unwrap();
                let direct = if try_direct { "direct" } else { "cached" };
                assert_eq!(
                    std::fs::read(&path).unwrap(),
                    data,
                    "{total} bytes, {direct}"
                );
            }
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
