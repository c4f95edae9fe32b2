//! Radiance HDR (RGBE) through the `image` crate: linear RGB, each pixel three 8-bit mantissas
//! with a shared exponent (about 1 % relative precision). Negative and non-finite values cannot
//! be stored: they are written as 0.

use candela_render::Image;
use image::{codecs::hdr::HdrEncoder, ImageFormat};

use crate::{check_size, decode_with_image, encode_with_image, ImageError, Limits};

/// Decodes a Radiance HDR file held in memory. The first line is `#?` and the name of the
/// program that wrote the file (`#?RADIANCE`, `#?RGBE` from Mitsuba and others, …): any name
/// is accepted. The default [`Limits`] apply.
pub fn read_hdr(bytes: &[u8]) -> Result<Image, ImageError> {
    read_hdr_within(bytes, &Limits::default())
}

/// Decodes a Radiance HDR file held in memory, refusing an image larger than `limits` allow
/// before decoding its pixels.
pub fn read_hdr_within(bytes: &[u8], limits: &Limits) -> Result<Image, ImageError> {
    let renamed;
    let bytes = match bytes.iter().position(|&b| b == b'\n') {
        Some(end) if bytes.starts_with(b"#?") && !bytes.starts_with(b"#?RADIANCE\n") => {
            renamed = [b"#?RADIANCE".as_slice(), &bytes[end..]].concat();
            renamed.as_slice()
        }
        _ => bytes,
    };
    decode_with_image(
        bytes,
        ImageFormat::Hdr,
        limits,
        |x| x,
        |cause| ImageError::Hdr {
            action: "decode",
            cause,
        },
    )
}

/// Encodes `img` as a Radiance HDR file (top row first).
pub fn write_hdr(img: &Image) -> Result<Vec<u8>, ImageError> {
    check_size(img.width(), img.height())?;
    let clean = |x: f32| if x.is_finite() && x > 0.0 { x } else { 0.0 };
    let pixels: Vec<image::Rgb<f32>> = (0..img.height())
        .flat_map(|y| (0..img.width()).map(move |x| (x, y)))
        .map(|(x, y)| {
            let c = img.get(x, y);
            image::Rgb([clean(c.r), clean(c.g), clean(c.b)])
        })
        .collect();
    encode_with_image(
        |out| HdrEncoder::new(out).encode(&pixels, img.width(), img.height()),
        |cause| ImageError::Hdr {
            action: "encode",
            cause,
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image_from_pixels;
    use candela_render::Rgb;

    #[test]
    fn round_trip_within_rgbe_precision() {
        let values = [
            Rgb::new(1.0, 0.5, 0.25),
            Rgb::new(1000.0, 3.0, 0.001),
            Rgb::new(0.0, 0.0, 0.0),
            Rgb::new(-1.0, f32::NAN, 2.0),
            Rgb::new(1e-3, 2e-3, 4e-3),
            Rgb::new(65504.0, 1.0, 1.0),
        ];
        let img = image_from_pixels(3, 2, values);
        let back = read_hdr(&write_hdr(&img).unwrap()).unwrap();
        assert_eq!((back.width(), back.height()), (3, 2));
        for y in 0..2 {
            for x in 0..3 {
                let (a, b) = (img.get(x, y), back.get(x, y));
                let m = [a.r, a.g, a.b]
                    .into_iter()
                    .filter(|v| v.is_finite())
                    .fold(0.0f32, f32::max);
                for (u, v) in [(a.r, b.r), (a.g, b.g), (a.b, b.b)] {
                    let u = if u.is_finite() && u > 0.0 { u } else { 0.0 };
                    // The shared exponent: each channel to 1/256 of the largest.
                    assert!((u - v).abs() <= m / 128.0 + 1e-30, "({x}, {y}): {u} vs {v}");
                }
            }
        }
        // Another program's signature line.
        let mut rgbe = write_hdr(&img).unwrap();
        assert!(rgbe.starts_with(b"#?RADIANCE\n"));
        rgbe.splice(..10, b"#?RGBE".iter().copied());
        assert_eq!(read_hdr(&rgbe).unwrap(), back);
        assert!(matches!(
            read_hdr(b"#?RADIANCE\nnonsense").unwrap_err(),
            ImageError::Hdr { .. }
        ));
    }
}
