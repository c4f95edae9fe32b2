//! The one error type of this crate, [`ImageError`].
//!
//! Every message is complete on its own: it already contains the underlying cause (the OS
//! error, the decoder's complaint), so print it with `{}` and do not walk
//! [`std::error::Error::source`] (which is deliberately `None`, to avoid printing causes twice).
//! Errors about a file start with its path; errors from the in-memory codecs have no path, and
//! the file functions of this crate wrap them in [`ImageError::File`].

use std::{fmt, io, path::PathBuf};

use thiserror::Error;

use crate::Format;

/// Everything that can go wrong while reading, decoding, encoding or writing an image.
#[derive(Debug, Error)]
pub enum ImageError {
    /// An operating-system error while reading or writing a file.
    #[error("{}: cannot {action}: {cause}", .path.display())]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// What was being done, e.g. `"read"`.
        action: &'static str,
        /// The OS error.
        cause: io::Error,
    },
    /// An input file that is not a regular file, is too large, or cannot be read.
    #[error("{}: cannot read: {cause}", .path.display())]
    Input {
        /// The file concerned.
        path: PathBuf,
        /// Why.
        cause: crate::input::InputError,
    },
    /// An image larger than the limits (docs/limits.md).
    #[error("{reason}")]
    Limit {
        /// Which limit, with the figures.
        reason: String,
    },
    /// A PFM file does not start with the line `PF` (colour) or `Pf` (grey).
    #[error(
        "not a PFM file: the first line is {found:?}, expected \"PF\" (colour) or \"Pf\" (grey)"
    )]
    PfmMagic {
        /// The start of the offending line.
        found: String,
    },
    /// The PFM size line is not two positive integers, or describes an impossibly large image.
    #[error("invalid PFM size line {line:?}: {reason}")]
    PfmSize {
        /// The start of the offending line.
        line: String,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// The PFM scale line is not `-1.0` (little-endian) or `1.0` (big-endian).
    #[error(
        "invalid PFM scale line {line:?}: expected -1.0 (little-endian data) or 1.0 (big-endian data)"
    )]
    PfmEndianness {
        /// The start of the offending line.
        line: String,
    },
    /// The PFM pixel data ends before the last pixel.
    #[error(
        "truncated PFM file: the pixel data needs {expected} bytes, but only {got} are present"
    )]
    Truncated {
        /// Bytes of pixel data the header announces.
        expected: usize,
        /// Bytes of pixel data actually present.
        got: usize,
    },
    /// The file name's extension names no supported format.
    #[error(
        "{}: unsupported image file extension {}; supported extensions are {}",
        .path.display(),
        Quoted(extension),
        SupportedList
    )]
    UnsupportedExtension {
        /// The file concerned.
        path: PathBuf,
        /// Its extension without the dot (empty when it has none).
        extension: String,
    },
    /// The `image` crate failed to decode or encode a PNG.
    #[error("cannot {action} PNG: {cause}")]
    Png {
        /// `"decode"` or `"encode"`.
        action: &'static str,
        /// The codec's error.
        cause: image::ImageError,
    },
    /// The `image` crate failed to decode a read-only format (JPEG, BMP, TGA, PNM).
    #[error("cannot decode {format}: {cause}")]
    Raster {
        /// The format's name.
        format: &'static str,
        /// The codec's error.
        cause: image::ImageError,
    },
    /// The `image` crate failed to decode or encode a Radiance HDR image.
    #[error("cannot {action} Radiance HDR: {cause}")]
    Hdr {
        /// `"decode"` or `"encode"`.
        action: &'static str,
        /// The codec's error.
        cause: image::ImageError,
    },
    /// The `exr` crate failed to decode or encode an OpenEXR image.
    #[error("cannot {action} OpenEXR: {cause}")]
    Exr {
        /// `"decode"` or `"encode"`.
        action: &'static str,
        /// The codec's error.
        cause: exr::error::Error,
    },
    /// An OpenEXR file has no layer with an R, G, B or Y channel.
    #[error("OpenEXR file has no layer with an R, G, B or Y channel (channels found: {found})")]
    ExrNoColour {
        /// The channel names of the first layer, comma-separated.
        found: String,
    },
    /// An image with no pixels cannot be written.
    #[error("cannot write an empty {width}×{height} image")]
    EmptyImage {
        /// Width in pixels.
        width: usize,
        /// Height in pixels.
        height: usize,
    },
    /// An image is too large for the file format.
    #[error("cannot write a {width}×{height} image: at most {max} pixels per side are supported")]
    TooLarge {
        /// Width in pixels.
        width: usize,
        /// Height in pixels.
        height: usize,
        /// The largest supported width or height.
        max: usize,
    },
    /// An 8-bit RGB buffer does not match the image size it is said to have.
    #[error("an RGB buffer for a {width}×{height} image needs {expected} bytes, got {got}")]
    BufferSize {
        /// Width in pixels.
        width: usize,
        /// Height in pixels.
        height: usize,
        /// `3 · width · height`.
        expected: usize,
        /// The buffer's length.
        got: usize,
    },
    /// Any of the errors above that happened while decoding or encoding a given file.
    #[error("{}: {error}", .path.display())]
    File {
        /// The file concerned.
        path: PathBuf,
        /// What went wrong.
        error: Box<ImageError>,
    },
}

impl ImageError {
    /// The error without the [`ImageError::File`] context, for matching on what went wrong.
    pub fn kind(&self) -> &ImageError {
        match self {
            ImageError::File { error, .. } => error.kind(),
            e => e,
        }
    }

    /// Adds `path` as context unless the error already names a file.
    pub(crate) fn in_file(self, path: impl Into<PathBuf>) -> Self {
        match self {
            e @ (Self::Io { .. }
            | Self::Input { .. }
            | Self::UnsupportedExtension { .. }
            | Self::File { .. }) => e,
            e => Self::File {
                path: path.into(),
                error: Box::new(e),
            },
        }
    }

    /// A closure turning an [`io::Error`] about `path` into [`ImageError::Io`].
    pub(crate) fn io(
        path: &std::path::Path,
        action: &'static str,
    ) -> impl FnOnce(io::Error) -> Self {
        let path = path.to_path_buf();
        move |cause| Self::Io {
            path,
            action,
            cause,
        }
    }
}

/// Shows an extension as `".ext"`, or `(none)` when empty.
struct Quoted<'a>(&'a str);

impl fmt::Display for Quoted<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            "" => f.write_str("(none)"),
            ext => write!(f, "\".{ext}\""),
        }
    }
}

/// Lists the supported extensions, e.g. `.pfm, .exr, .png`.
struct SupportedList;

impl fmt::Display for SupportedList {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, format) in Format::ALL.iter().enumerate() {
            let sep = if i == 0 { "" } else { ", " };
            write!(f, "{sep}.{}", format.extension())?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn is_send_sync_and_static() {
        fn check<T: std::error::Error + Send + Sync + 'static>() {}
        check::<ImageError>();
    }

    #[test]
    fn messages_name_the_file_and_the_cause() {
        let e = ImageError::UnsupportedExtension {
            path: "out/a.bmp".into(),
            extension: "bmp".into(),
        };
        assert_eq!(
            e.to_string(),
            "out/a.bmp: unsupported image file extension \".bmp\"; supported extensions are .pfm, .exr, .png, .hdr"
        );
        let e = ImageError::UnsupportedExtension {
            path: "a".into(),
            extension: String::new(),
        };
        assert!(e.to_string().contains("extension (none)"), "{e}");

        let e = ImageError::Truncated {
            expected: 72,
            got: 10,
        }
        .in_file("x.pfm");
        assert_eq!(
            e.to_string(),
            "x.pfm: truncated PFM file: the pixel data needs 72 bytes, but only 10 are present"
        );
        assert!(matches!(
            e.kind(),
            ImageError::Truncated {
                expected: 72,
                got: 10
            }
        ));
        // Context is added once only.
        let e = e.in_file("y.pfm");
        assert!(e.to_string().starts_with("x.pfm: "));

        let cause = io::Error::new(io::ErrorKind::NotFound, "gone");
        let e = ImageError::io("a.pfm".as_ref(), "read")(cause);
        assert_eq!(e.to_string(), "a.pfm: cannot read: gone");
        assert!(std::error::Error::source(&e).is_none());
    }
}
