//! candela's image files: PFM, OpenEXR, Radiance HDR and PNG (read and written), JPEG, BMP, TGA
//! and PNM (read only), plus the course's tone mapping.
//!
//! The format of a file is chosen by its extension, case-insensitively: `.pfm`, `.exr` and
//! `.hdr` hold linear HDR data, `.png` holds tone-mapped 8-bit sRGB-ish data (see [`ToneMap`]).
//! [`read_image`] and [`write_image`] cover the common case; the per-format modules offer
//! in-memory codecs.
//!
//! Writing is atomic ([`atomic`]): the file is encoded fully in memory, written to a hidden
//! temporary file in the target's directory, flushed to disk and renamed onto the target. On
//! failure the temporary file is removed and an existing target is left untouched, so an
//! interrupted or failed render never leaves a half-written image behind.

pub mod atomic;
pub mod error;
pub mod exr;
pub mod hdr;
pub mod input;
pub mod partial;
pub mod pfm;
pub mod png;
pub mod raster;
pub mod tonemap;

use std::path::Path;

use candela_render::{Image, Rgb};

pub use atomic::{check_target, write_all_atomically, write_atomically};
pub use error::ImageError;
pub use input::Limits;
pub use pfm::{read_pfm, read_pfm_file, write_pfm};
pub use tonemap::{Encoding, ToneMap};

/// The largest width or height this crate writes (OpenEXR and PNG store sides as 31-bit
/// integers).
pub const MAX_SIDE: usize = i32::MAX as usize;

/// A supported image file format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Format {
    /// Portable Float Map: linear f32 RGB.
    Pfm,
    /// OpenEXR: linear RGB (written as f32).
    Exr,
    /// PNG: tone-mapped 8-bit RGB.
    Png,
    /// Radiance HDR (RGBE): linear RGB with a shared 8-bit exponent.
    Hdr,
}

impl Format {
    /// All formats, in the order they are listed to users.
    pub const ALL: [Format; 4] = [Format::Pfm, Format::Exr, Format::Png, Format::Hdr];

    /// The file extension, lower-case and without the dot.
    pub fn extension(self) -> &'static str {
        match self {
            Format::Pfm => "pfm",
            Format::Exr => "exr",
            Format::Png => "png",
            Format::Hdr => "hdr",
        }
    }

    /// The format named by `path`'s extension (case-insensitive), or
    /// [`ImageError::UnsupportedExtension`].
    pub fn from_path(path: &Path) -> Result<Format, ImageError> {
        let extension = path.extension().unwrap_or_default().to_string_lossy();
        Format::ALL
            .into_iter()
            .find(|f| extension.eq_ignore_ascii_case(f.extension()))
            .ok_or_else(|| ImageError::UnsupportedExtension {
                path: path.to_path_buf(),
                extension: extension.into_owned(),
            })
    }

    /// Decodes a file of this format held in memory to linear RGB, within the default
    /// [`Limits`].
    pub fn decode(self, bytes: &[u8]) -> Result<Image, ImageError> {
        self.decode_within(bytes, &Limits::default())
    }

    /// Decodes a file of this format held in memory to linear RGB, refusing an image larger
    /// than `limits` allow before allocating it.
    pub fn decode_within(self, bytes: &[u8], limits: &Limits) -> Result<Image, ImageError> {
        match self {
            Format::Pfm => pfm::read_pfm_within(bytes, limits),
            Format::Exr => exr::read_exr_within(bytes, limits),
            Format::Png => png::read_png_within(bytes, limits),
            Format::Hdr => hdr::read_hdr_within(bytes, limits),
        }
    }

    /// Encodes `img` in this format; `tonemap` is used for PNG only.
    pub fn encode(self, img: &Image, tonemap: &ToneMap) -> Result<Vec<u8>, ImageError> {
        match self {
            Format::Pfm => check_size(img.width(), img.height()).map(|()| pfm::write_pfm(img)),
            Format::Exr => exr::write_exr(img),
            Format::Png => png::write_png(img.width(), img.height(), &tonemap.apply(img)),
            Format::Hdr => hdr::write_hdr(img),
        }
    }
}

/// True when `path` has an extension that [`write_image`] and [`read_image`] support, so that
/// output paths can be validated before a long render.
pub fn supported_extension(path: &Path) -> bool {
    Format::from_path(path).is_ok()
}

/// Reads an image, choosing the decoder by the file's extension, within the default
/// [`Limits`].
///
/// Beside the four formats that are also written, the read-only 8-bit formats of [`raster`]
/// (JPEG, BMP, TGA, PNM) are decoded from sRGB to linear RGB.
pub fn read_image(path: &Path) -> Result<Image, ImageError> {
    read_image_within(path, &Limits::default())
}

/// Reads an image, choosing the decoder by the file's extension: a regular file of at most
/// `limits.max_file_bytes`, holding at most `limits.max_pixels` pixels.
pub fn read_image_within(path: &Path, limits: &Limits) -> Result<Image, ImageError> {
    match Format::from_path(path) {
        Ok(format) => {
            let bytes = read_input(path, limits)?;
            format
                .decode_within(&bytes, limits)
                .map_err(|e| e.in_file(path))
        }
        Err(unsupported) => {
            let Some((format, name)) = raster::format_of(path) else {
                return Err(unsupported);
            };
            let bytes = read_input(path, limits)?;
            raster::decode(&bytes, format, name).map_err(|e| e.in_file(path))
        }
    }
}

/// True when the values stored in the image file `path` are sRGB-encoded (8-bit formats: PNG
/// and the read-only ones), false for the linear formats (PFM, OpenEXR, Radiance HDR).
pub fn is_srgb_encoded(path: &Path) -> bool {
    matches!(Format::from_path(path), Ok(Format::Png)) || raster::format_of(path).is_some()
}

/// Writes an image atomically, choosing the encoder by the file's extension: `.pfm` and
/// `.exr` get linear data, `.png` gets the bytes of `tonemap`.
///
/// An unsupported extension is reported before anything is written. The data goes to a
/// temporary file next to `path` that is then renamed onto it; on any failure the temporary
/// file is removed and an existing file at `path` is left as it was.
pub fn write_image(path: &Path, img: &Image, tonemap: &ToneMap) -> Result<(), ImageError> {
    let format = Format::from_path(path)?;
    let bytes = format.encode(img, tonemap).map_err(|e| e.in_file(path))?;
    write_atomically(path, &bytes).map_err(|e| ImageError::io(path, e.stage)(e.source))
}

/// Reads the input file `path` within `limits` ([`input::read_file`]).
pub(crate) fn read_input(path: &Path, limits: &Limits) -> Result<Vec<u8>, ImageError> {
    input::read_file(path, limits.max_file_bytes).map_err(|cause| match cause {
        input::InputError::Io(e) => ImageError::io(path, "read")(e),
        cause => ImageError::Input {
            path: path.to_path_buf(),
            cause,
        },
    })
}

/// Fails with [`ImageError::EmptyImage`] or [`ImageError::TooLarge`] unless a
/// `width`×`height` image can be written.
pub(crate) fn check_size(width: usize, height: usize) -> Result<(), ImageError> {
    if width == 0 || height == 0 {
        Err(ImageError::EmptyImage { width, height })
    } else if width > MAX_SIDE || height > MAX_SIDE {
        Err(ImageError::TooLarge {
            width,
            height,
            max: MAX_SIDE,
        })
    } else {
        Ok(())
    }
}

/// An image of `width`×`height` filled from `pixels` (top row first); decoders guarantee that
/// exactly `width · height` pixels follow, any shortfall would stay black.
/// Decodes `bytes` in `format` through the `image` crate, mapping every channel by `f`;
/// `error` wraps the codec's error.
pub(crate) fn decode_with_image(
    bytes: &[u8],
    format: image::ImageFormat,
    limits: &Limits,
    f: impl Fn(f32) -> f32,
    error: impl Fn(image::ImageError) -> ImageError,
) -> Result<Image, ImageError> {
    let mut reader = image::ImageReader::with_format(std::io::Cursor::new(bytes), format);
    // The codec's own limits, and ours checked on the header before any pixel is decoded.
    let mut codec_limits = image::Limits::default();
    codec_limits.max_image_width = Some(input::MAX_READ_SIDE);
    codec_limits.max_image_height = Some(input::MAX_READ_SIDE);
    codec_limits.max_alloc = Some(limits.max_memory / 2);
    reader.limits(codec_limits);
    let decoder = reader.into_decoder().map_err(&error)?;
    let (width, height) = image::ImageDecoder::dimensions(&decoder);
    limits
        .check_pixels(u64::from(width), u64::from(height))
        .map_err(|reason| ImageError::Limit { reason })?;
    let decoded = image::DynamicImage::from_decoder(decoder)
        .map_err(&error)?
        .into_rgb32f();
    let (width, height) = (decoded.width() as usize, decoded.height() as usize);
    let pixels = decoded
        .pixels()
        .map(|p| Rgb::new(f(p[0]), f(p[1]), f(p[2])));
    Ok(image_from_pixels(width, height, pixels))
}

/// Runs an `image` encoder into memory; `error` wraps the codec's error.
pub(crate) fn encode_with_image(
    encode: impl FnOnce(&mut std::io::Cursor<Vec<u8>>) -> Result<(), image::ImageError>,
    error: impl FnOnce(image::ImageError) -> ImageError,
) -> Result<Vec<u8>, ImageError> {
    let mut out = std::io::Cursor::new(Vec::new());
    encode(&mut out).map_err(error)?;
    Ok(out.into_inner())
}

pub(crate) fn image_from_pixels(
    width: usize,
    height: usize,
    pixels: impl IntoIterator<Item = Rgb>,
) -> Image {
    let mut img = Image::new(width, height);
    for (dst, src) in img.pixels_mut().iter_mut().zip(pixels) {
        *dst = src;
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_come_from_extensions_case_insensitively() {
        for (name, format) in [
            ("a.pfm", Format::Pfm),
            ("dir.x/B.PFM", Format::Pfm),
            ("c.Exr", Format::Exr),
            ("/tmp/d.png", Format::Png),
            ("e.tar.PnG", Format::Png),
        ] {
            assert_eq!(Format::from_path(name.as_ref()).unwrap(), format, "{name}");
            assert!(supported_extension(name.as_ref()));
        }
        for name in ["a.jpg", "pfm", "a.pfm.bak", "a.", "", ".png", "dir/"] {
            let err = Format::from_path(name.as_ref()).unwrap_err();
            assert!(
                matches!(err, ImageError::UnsupportedExtension { .. }),
                "{name}"
            );
            assert!(!supported_extension(name.as_ref()));
        }
    }

    #[test]
    fn empty_images_are_not_encoded() {
        let t = ToneMap::default();
        for format in Format::ALL {
            let err = format.encode(&Image::new(0, 3), &t).unwrap_err();
            assert!(
                matches!(
                    err,
                    ImageError::EmptyImage {
                        width: 0,
                        height: 3
                    }
                ),
                "{format:?}"
            );
        }
        assert!(matches!(
            check_size(MAX_SIDE + 1, 1),
            Err(ImageError::TooLarge { .. })
        ));
        assert!(check_size(MAX_SIDE, 1).is_ok());
    }

    #[test]
    fn every_format_round_trips_in_memory() {
        let img = Image::from_pixels(2, 1, vec![Rgb::new(0.5, 1.0, 2.0), Rgb::splat(3.0)]).unwrap();
        for format in [Format::Pfm, Format::Exr] {
            let bytes = format.encode(&img, &ToneMap::default()).unwrap();
            assert_eq!(format.decode(&bytes).unwrap(), img, "{format:?}");
        }
        let bytes = Format::Png.encode(&img, &ToneMap::default()).unwrap();
        let back = Format::Png.decode(&bytes).unwrap();
        assert_eq!((back.width(), back.height()), (2, 1));
    }
}
