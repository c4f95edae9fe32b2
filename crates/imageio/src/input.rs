//! Input files and resource limits: every file the program reads (scene files, meshes, images,
//! radiosity caches) goes through [`read_file`], which accepts regular files only (a FIFO, a
//! device or a directory is refused before it is opened, so nothing can hang or stream
//! forever) and reads at most a given number of bytes. [`Limits`] bounds what decoders may
//! allocate (docs/limits.md).

use std::fmt;
use std::io::Read;
use std::path::Path;

/// The memory budget when none is given (`--max-memory`): 2 GiB.
pub const DEFAULT_MAX_MEMORY: u64 = 2 << 30;

/// Bytes a decoded image takes per pixel at its peak (the codec's buffer, its `f32` copy and
/// candela's image): the figure the pixel limit is derived from.
pub const DECODE_BYTES_PER_PIXEL: u64 = 48;

/// Largest width or height of an image read from a file.
pub const MAX_READ_SIDE: u32 = 1 << 16;

/// What a reader may use: file sizes and decoded pixels, both derived from a memory budget.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// The memory budget the other limits come from (`--max-memory`), in bytes.
    pub max_memory: u64,
    /// Largest file read, in bytes.
    pub max_file_bytes: u64,
    /// Largest image decoded, in pixels.
    pub max_pixels: u64,
}

impl Limits {
    /// The limits for a memory budget of `bytes`: files up to a quarter of it, images whose
    /// decoding takes at most all of it.
    pub fn from_memory(bytes: u64) -> Self {
        Self {
            max_memory: bytes,
            max_file_bytes: bytes / 4,
            max_pixels: bytes / DECODE_BYTES_PER_PIXEL,
        }
    }

    /// Fails unless a `width`×`height` image may be decoded.
    pub fn check_pixels(&self, width: u64, height: u64) -> Result<(), String> {
        let side = u64::from(MAX_READ_SIDE);
        if width > side || height > side {
            return Err(format!(
                "the image is {width}×{height} pixels, more than the limit of {side} pixels per side"
            ));
        }
        let pixels = width.saturating_mul(height);
        if pixels > self.max_pixels {
            return Err(format!(
                "the image is {width}×{height} = {pixels} pixels, more than the limit of {} pixels ({} bytes each while decoding, within --max-memory {})",
                self.max_pixels,
                DECODE_BYTES_PER_PIXEL,
                self.max_memory
            ));
        }
        Ok(())
    }
}

impl Default for Limits {
    fn default() -> Self {
        Self::from_memory(DEFAULT_MAX_MEMORY)
    }
}

/// Why an input file cannot be read.
#[derive(Debug)]
pub enum InputError {
    /// The path names something other than a regular file.
    NotRegular(&'static str),
    /// The file is larger than the limit.
    TooLarge {
        /// Its size (or the bytes read before giving up), in bytes.
        size: u64,
        /// The limit, in bytes.
        max: u64,
    },
    /// An operating-system error.
    Io(std::io::Error),
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            InputError::NotRegular(kind) => {
                write!(f, "it is {kind}, not a regular file")
            }
            InputError::TooLarge { size, max } => write!(
                f,
                "the file is {size} bytes or more, larger than the limit of {max} bytes (a quarter of --max-memory)"
            ),
            InputError::Io(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for InputError {}

/// What kind of file `meta` describes, for messages; `None` for a regular file.
pub fn special_kind(meta: &std::fs::Metadata) -> Option<&'static str> {
    use std::os::unix::fs::FileTypeExt;
    let t = meta.file_type();
    if t.is_file() {
        None
    } else if t.is_dir() {
        Some("a directory")
    } else if t.is_fifo() {
        Some("a FIFO (named pipe)")
    } else if t.is_char_device() {
        Some("a character device")
    } else if t.is_block_device() {
        Some("a block device")
    } else if t.is_socket() {
        Some("a socket")
    } else {
        Some("not a regular file")
    }
}

/// Reads the regular file `path` (symbolic links followed), at most `max_bytes` of it.
pub fn read_file(path: &Path, max_bytes: u64) -> Result<Vec<u8>, InputError> {
    // Checked before opening: opening a FIFO for reading blocks until a writer comes.
    let meta = std::fs::metadata(path).map_err(InputError::Io)?;
    if let Some(kind) = special_kind(&meta) {
        return Err(InputError::NotRegular(kind));
    }
    if meta.len() > max_bytes {
        return Err(InputError::TooLarge {
            size: meta.len(),
            max: max_bytes,
        });
    }
    let file = std::fs::File::open(path).map_err(InputError::Io)?;
    // The file may have been swapped since: check what was opened, and read no more than the
    // limit whatever its size says.
    let meta = file.metadata().map_err(InputError::Io)?;
    if let Some(kind) = special_kind(&meta) {
        return Err(InputError::NotRegular(kind));
    }
    read_into(
        file,
        Vec::with_capacity(meta.len().min(max_bytes) as usize),
        max_bytes,
    )
}

/// Reads standard input to its end, at most `max_bytes` of it: more is refused as soon as one
/// byte more has been read (an endless stream such as `/dev/zero` stops there). The input is
/// read in pieces, so memory grows with what was read, not with the limit.
pub fn read_stdin(max_bytes: u64) -> Result<Vec<u8>, InputError> {
    read_capped(std::io::stdin().lock(), max_bytes)
}

/// Reads `r` to its end, at most `max_bytes` of it ([`InputError::TooLarge`] beyond).
pub fn read_capped(r: impl Read, max_bytes: u64) -> Result<Vec<u8>, InputError> {
    read_into(r, Vec::new(), max_bytes)
}

/// [`read_capped`] into `bytes` (a buffer sized for the expected length).
fn read_into(r: impl Read, mut bytes: Vec<u8>, max_bytes: u64) -> Result<Vec<u8>, InputError> {
    r.take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(InputError::Io)?;
    if bytes.len() as u64 > max_bytes {
        return Err(InputError::TooLarge {
            size: bytes.len() as u64,
            max: max_bytes,
        });
    }
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn special_files_are_refused_without_blocking() {
        for (path, kind) in [
            ("/dev/zero", "a character device"),
            ("/dev/null", "a character device"),
            ("/", "a directory"),
        ] {
            let e = read_file(Path::new(path), 1 << 20).unwrap_err();
            assert_eq!(e.to_string(), format!("it is {kind}, not a regular file"));
        }
    }

    #[test]
    fn streams_are_read_up_to_the_limit() {
        assert_eq!(read_capped(&b"0123456789"[..], 10).unwrap(), b"0123456789");
        let endless = std::io::repeat(0);
        let e = read_capped(endless, 1000).unwrap_err();
        assert!(
            matches!(
                e,
                InputError::TooLarge {
                    size: 1001,
                    max: 1000
                }
            ),
            "{e}"
        );
    }

    #[test]
    fn files_are_read_up_to_the_limit() {
        let dir = std::env::temp_dir().join(format!("candela-input-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("ten");
        std::fs::write(&p, b"0123456789").unwrap();
        assert_eq!(read_file(&p, 10).unwrap(), b"0123456789");
        let e = read_file(&p, 9).unwrap_err();
        assert!(
            matches!(e, InputError::TooLarge { size: 10, max: 9 }),
            "{e}"
        );
        assert!(matches!(
            read_file(&dir.join("missing"), 9),
            Err(InputError::Io(_))
        ));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn pixel_limits_follow_the_memory_budget() {
        let l = Limits::from_memory(48 * 100);
        assert!(l.check_pixels(10, 10).is_ok());
        assert!(l.check_pixels(10, 11).unwrap_err().contains("limit of 100"));
        assert!(Limits::default()
            .check_pixels(1 << 17, 1)
            .unwrap_err()
            .contains("per side"));
    }
}
