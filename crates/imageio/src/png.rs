//! PNG through the `image` crate.
//!
//! Reading accepts 8- and 16-bit (and palette or lower-depth) PNGs in grey, grey+alpha, RGB
//! or RGBA; alpha is ignored (not premultiplied). The stored values are taken to be
//! sRGB-encoded and are decoded to linear radiance with the exact sRGB EOTF
//! ([`srgb_eotf`]); gamma and colour-profile chunks are ignored.
//!
//! Writing stores an already tone-mapped 8-bit RGB buffer (see [`crate::ToneMap`]) as is.

use candela_render::Image;
use image::{codecs::png::PngEncoder, ExtendedColorType, ImageEncoder, ImageFormat};

use crate::{
    check_size, decode_with_image, encode_with_image, tonemap::srgb_eotf, ImageError, Limits,
};

/// Decodes a PNG held in memory to linear RGB, within the default [`Limits`].
pub fn read_png(bytes: &[u8]) -> Result<Image, ImageError> {
    read_png_within(bytes, &Limits::default())
}

/// Decodes a PNG held in memory to linear RGB, refusing an image larger than `limits` allow
/// before decoding its pixels.
pub fn read_png_within(bytes: &[u8], limits: &Limits) -> Result<Image, ImageError> {
    decode_with_image(bytes, ImageFormat::Png, limits, srgb_eotf, |cause| {
        ImageError::Png {
            action: "decode",
            cause,
        }
    })
}

/// Encodes an 8-bit RGB buffer (`3 · width · height` bytes, top row first) as a PNG.
pub fn write_png(width: usize, height: usize, rgb: &[u8]) -> Result<Vec<u8>, ImageError> {
    check_size(width, height)?;
    let expected = width * height * 3; // Cannot overflow: both sides are below 2³¹.
    if rgb.len() != expected {
        return Err(ImageError::BufferSize {
            width,
            height,
            expected,
            got: rgb.len(),
        });
    }
    // check_size guarantees that both sides fit in u32.
    encode_with_image(
        |out| {
            PngEncoder::new(out).write_image(
                rgb,
                width as u32,
                height as u32,
                ExtendedColorType::Rgb8,
            )
        },
        |cause| ImageError::Png {
            action: "encode",
            cause,
        },
    )
}

#[cfg(test)]
mod tests {
    use std::io::Cursor;

    use candela_render::Rgb;
    use image::{DynamicImage, ImageBuffer, Luma, LumaA, Rgb as Rgb8, Rgba};

    use super::*;

    /// Encodes `img` with the `image` crate itself.
    fn png_of(img: DynamicImage) -> Vec<u8> {
        let mut out = Cursor::new(Vec::new());
        img.write_to(&mut out, ImageFormat::Png).unwrap();
        out.into_inner()
    }

    fn close(a: Rgb, b: Rgb) -> bool {
        a.approx_eq(b, 1e-5)
    }

    #[test]
    fn writes_and_reads_back_8_bit_rgb() {
        // Top row: black, white; bottom row: sRGB 128 grey, pure red.
        let bytes = [0, 0, 0, 255, 255, 255, 128, 128, 128, 255, 0, 0];
        let img = read_png(&write_png(2, 2, &bytes).unwrap()).unwrap();
        assert_eq!((img.width(), img.height()), (2, 2));
        let grey = ((128.0 / 255.0 + 0.055) / 1.055f32).powf(2.4); // 0.21586
        assert!(close(img.get(0, 0), Rgb::BLACK));
        assert!(close(img.get(1, 0), Rgb::WHITE));
        assert!(
            close(img.get(0, 1), Rgb::splat(grey)),
            "{:?}",
            img.get(0, 1)
        );
        assert!(close(img.get(1, 1), Rgb::new(1.0, 0.0, 0.0)));
    }

    #[test]
    fn reads_every_colour_type_and_ignores_alpha() {
        // Each case is sRGB 0.5 (or the nearest 8-bit value, 128), which decodes to ≈ 0.2140.
        let half8 = srgb_eotf(128.0 / 255.0);
        let half16 = srgb_eotf(32768.0 / 65535.0);
        let cases = [
            (
                DynamicImage::ImageLuma8(ImageBuffer::from_pixel(2, 1, Luma([128]))),
                half8,
            ),
            (
                DynamicImage::ImageLumaA8(ImageBuffer::from_pixel(2, 1, LumaA([128, 7]))),
                half8,
            ),
            (
                DynamicImage::ImageRgb8(ImageBuffer::from_pixel(2, 1, Rgb8([128; 3]))),
                half8,
            ),
            (
                DynamicImage::ImageRgba8(ImageBuffer::from_pixel(2, 1, Rgba([128, 128, 128, 0]))),
                half8,
            ),
            (
                DynamicImage::ImageLuma16(ImageBuffer::from_pixel(2, 1, Luma([32768]))),
                half16,
            ),
            (
                DynamicImage::ImageLumaA16(ImageBuffer::from_pixel(2, 1, LumaA([32768, 9]))),
                half16,
            ),
            (
                DynamicImage::ImageRgb16(ImageBuffer::from_pixel(2, 1, Rgb8([32768; 3]))),
                half16,
            ),
            (
                DynamicImage::ImageRgba16(ImageBuffer::from_pixel(
                    2,
                    1,
                    Rgba([32768, 32768, 32768, 1]),
                )),
                half16,
            ),
        ];
        assert!((half16 - 0.214_041).abs() < 1e-5);
        for (img, want) in cases {
            let colour = img.color();
            let read = read_png(&png_of(img)).unwrap();
            assert_eq!((read.width(), read.height()), (2, 1));
            for p in read.pixels() {
                assert!(close(*p, Rgb::splat(want)), "{colour:?}: {p:?}");
            }
        }
    }

    #[test]
    fn rejects_bad_input() {
        let err = read_png(b"not a png").unwrap_err();
        assert!(
            matches!(
                err,
                ImageError::Png {
                    action: "decode",
                    ..
                }
            ),
            "{err}"
        );
        assert!(err.to_string().starts_with("cannot decode PNG: "), "{err}");
        let good = write_png(1, 1, &[1, 2, 3]).unwrap();
        let err = read_png(&good[..good.len() - 20]).unwrap_err();
        assert!(matches!(err, ImageError::Png { .. }), "{err}");

        let err = write_png(2, 2, &[0; 11]).unwrap_err();
        assert!(
            matches!(
                err,
                ImageError::BufferSize {
                    expected: 12,
                    got: 11,
                    ..
                }
            ),
            "{err}"
        );
        assert!(matches!(
            write_png(0, 3, &[]),
            Err(ImageError::EmptyImage { .. })
        ));
        assert!(matches!(
            write_png(usize::MAX, 1, &[]),
            Err(ImageError::TooLarge { .. })
        ));
    }
}
