//! Read-only 8-bit formats through the `image` crate: JPEG, BMP, TGA and PNM (PPM/PGM), for
//! textures and environment maps (Mitsuba's `bitmap` reads them too). Their values are taken
//! to be sRGB-encoded and decoded to linear RGB, as for PNG. Decoding runs under limits: at
//! most [`MAX_DECODED_SIDE`] pixels a side and [`MAX_DECODED_BYTES`] bytes of allocation, so a
//! hostile header cannot exhaust memory.

use std::io::Cursor;
use std::path::Path;

use candela_render::Image;
use image::{ImageFormat, ImageReader, Limits};

use crate::{image_from_pixels, tonemap::srgb_eotf, ImageError};

/// The largest width or height decoded.
pub const MAX_DECODED_SIDE: u32 = 1 << 16;
/// The most memory a decoder may allocate.
pub const MAX_DECODED_BYTES: u64 = 4 << 30;

/// The read-only formats with their extensions and names.
const FORMATS: [(&str, ImageFormat, &str); 7] = [
    ("jpg", ImageFormat::Jpeg, "JPEG"),
    ("jpeg", ImageFormat::Jpeg, "JPEG"),
    ("bmp", ImageFormat::Bmp, "BMP"),
    ("tga", ImageFormat::Tga, "TGA"),
    ("ppm", ImageFormat::Pnm, "PNM"),
    ("pgm", ImageFormat::Pnm, "PNM"),
    ("pnm", ImageFormat::Pnm, "PNM"),
];

/// The extensions of the read-only formats.
pub const READ_ONLY_EXTENSIONS: [&str; 7] = ["jpg", "jpeg", "bmp", "tga", "ppm", "pgm", "pnm"];

/// The read-only format named by `path`'s extension (case-insensitive).
pub fn format_of(path: &Path) -> Option<(ImageFormat, &'static str)> {
    let ext = path.extension()?.to_str()?;
    FORMATS
        .iter()
        .find(|(e, _, _)| ext.eq_ignore_ascii_case(e))
        .map(|&(_, f, n)| (f, n))
}

/// Decodes `bytes` in `format` (named `name` in errors) to linear RGB, under the limits.
pub fn decode(bytes: &[u8], format: ImageFormat, name: &'static str) -> Result<Image, ImageError> {
    let error = |cause| ImageError::Raster {
        format: name,
        cause,
    };
    let mut reader = ImageReader::with_format(Cursor::new(bytes), format);
    let mut limits = Limits::default();
    limits.max_image_width = Some(MAX_DECODED_SIDE);
    limits.max_image_height = Some(MAX_DECODED_SIDE);
    limits.max_alloc = Some(MAX_DECODED_BYTES);
    reader.limits(limits);
    let decoded = reader.decode().map_err(error)?.into_rgb32f();
    let (width, height) = (decoded.width() as usize, decoded.height() as usize);
    let pixels = decoded
        .pixels()
        .map(|p| candela_render::Rgb::new(srgb_eotf(p[0]), srgb_eotf(p[1]), srgb_eotf(p[2])));
    Ok(image_from_pixels(width, height, pixels))
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::{DynamicImage, RgbImage};

    fn encoded(format: ImageFormat) -> Vec<u8> {
        let mut img = RgbImage::new(8, 4);
        for (x, _, p) in img.enumerate_pixels_mut() {
            *p = image::Rgb(if x < 4 { [255, 255, 255] } else { [0, 0, 0] });
        }
        let mut out = Cursor::new(Vec::new());
        DynamicImage::ImageRgb8(img)
            .write_to(&mut out, format)
            .unwrap();
        out.into_inner()
    }

    #[test]
    fn jpeg_bmp_tga_and_pnm_decode_to_linear_rgb() {
        for (ext, format, name) in FORMATS {
            assert_eq!(
                format_of(Path::new(&format!("a.{}", ext.to_uppercase())))
                    .unwrap()
                    .0,
                format
            );
            let img = decode(&encoded(format), format, name).unwrap();
            assert_eq!((img.width(), img.height()), (8, 4));
            // JPEG is lossy: a few levels of error near the edge, exact far from it.
            let tol = if format == ImageFormat::Jpeg {
                0.03
            } else {
                1e-6
            };
            assert!(
                (img.get(0, 0).g - 1.0).abs() < tol,
                "{name}: {:?}",
                img.get(0, 0)
            );
            assert!(img.get(7, 3).r.abs() < tol, "{name}: {:?}", img.get(7, 3));
        }
        assert!(format_of(Path::new("a.png")).is_none());
    }

    #[test]
    fn corrupt_and_huge_files_are_errors() {
        let good = encoded(ImageFormat::Jpeg);
        assert!(decode(&good[..good.len() / 2], ImageFormat::Jpeg, "JPEG").is_err());
        assert!(decode(b"not a jpeg", ImageFormat::Jpeg, "JPEG").is_err());
        // A PPM header claiming 100000×100000 pixels.
        let e = decode(b"P6 100000 100000 255\n\0\0\0", ImageFormat::Pnm, "PNM").unwrap_err();
        assert!(matches!(e, ImageError::Raster { .. }), "{e}");
    }
}
