//! PFM (Portable Float Map): uncompressed 32-bit float images.
//!
//! A PFM file is a three-line ASCII header followed by binary floats:
//!
//! ```text
//! PF            magic: "PF" = RGB, 3 floats per pixel; "Pf" = grey, 1 float per pixel
//! <w> <h>       width and height, positive integers
//! <scale>       -1.0 = little-endian data, 1.0 = big-endian data
//! ```
//!
//! The pixel rows follow **bottom row first**, each left to right; [`Image`] keeps the top row
//! first, so rows are flipped both ways. Grey files are read as `(v, v, v)`.
//!
//! Reading tolerates `\r\n` line ends and extra blanks around and between header values, but
//! not odd values: sizes must be positive decimal integers and the scale exactly ±1 numerically
//! (`-1`, `-1.0`, `1.000000` are fine). Missing pixel data is an error; bytes after the last
//! pixel are ignored. Writing always produces little-endian RGB with the header
//! `PF\n{w} {h}\n-1.0\n`.

use std::path::Path;

use candela_render::{Image, Rgb};

use crate::{image_from_pixels, ImageError, Limits};

/// Decodes a PFM file held in memory, within the default [`Limits`].
pub fn read_pfm(bytes: &[u8]) -> Result<Image, ImageError> {
    read_pfm_within(bytes, &Limits::default())
}

/// Decodes a PFM file held in memory, refusing an image larger than `limits` allow.
pub fn read_pfm_within(bytes: &[u8], limits: &Limits) -> Result<Image, ImageError> {
    let mut rest = bytes;
    let channels = header_line(&mut rest, |line| match line {
        "PF" => Some(3),
        "Pf" => Some(1),
        _ => None,
    })
    .map_err(|found| ImageError::PfmMagic { found })?;
    let (width, height) =
        header_line(&mut rest, parse_size).map_err(|line| ImageError::PfmSize {
            line,
            reason: "expected two positive integers, \"<width> <height>\"",
        })?;
    let little_endian = header_line(&mut rest, |line| {
        let scale: f64 = line.parse().ok()?;
        (scale.abs() == 1.0).then_some(scale < 0.0)
    })
    .map_err(|line| ImageError::PfmEndianness { line })?;

    let row_bytes = width
        .checked_mul(channels * 4)
        .filter(|n| n.checked_mul(height).is_some())
        .ok_or_else(|| ImageError::PfmSize {
            line: format!("{width} {height}"),
            reason: "the image is too large",
        })?;
    let expected = row_bytes * height;
    let data = rest.get(..expected).ok_or(ImageError::Truncated {
        expected,
        got: rest.len(),
    })?;
    // The data is present, so the file was already that large; the image is three times it.
    limits
        .check_pixels(width as u64, height as u64)
        .map_err(|reason| ImageError::Limit { reason })?;
    let decode = if little_endian {
        f32::from_le_bytes
    } else {
        f32::from_be_bytes
    };
    let float = |b: &[u8]| decode([b[0], b[1], b[2], b[3]]);
    let pixels = data.chunks_exact(row_bytes).rev().flat_map(|row| {
        row.chunks_exact(channels * 4).map(|p| match channels {
            3 => Rgb::new(float(&p[0..4]), float(&p[4..8]), float(&p[8..12])),
            _ => Rgb::splat(float(p)),
        })
    });
    Ok(image_from_pixels(width, height, pixels))
}

/// Reads a PFM file, whatever its extension.
pub fn read_pfm_file(path: &Path) -> Result<Image, ImageError> {
    let limits = Limits::default();
    let bytes = crate::read_input(path, &limits)?;
    read_pfm_within(&bytes, &limits).map_err(|e| e.in_file(path))
}

/// Encodes `img` as a little-endian RGB PFM file.
///
/// Images with no pixels are encoded too, but no reader (this one included) accepts them;
/// [`crate::write_image`] refuses to write them.
pub fn write_pfm(img: &Image) -> Vec<u8> {
    let (w, h) = (img.width(), img.height());
    let mut out = format!("PF\n{w} {h}\n-1.0\n").into_bytes();
    out.reserve(img.pixels().len() * 12);
    for row in img.pixels().chunks_exact(w.max(1)).rev() {
        for c in row.iter().flat_map(|p| p.to_array()) {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    out
}

/// Splits off the next header line and parses it, without surrounding blanks (`\r` included),
/// with `parse`. A line that is unterminated, not UTF-8 or rejected by `parse` is an error
/// carrying an excerpt of it.
fn header_line<'a, T>(
    rest: &mut &'a [u8],
    parse: impl FnOnce(&'a str) -> Option<T>,
) -> Result<T, String> {
    let end = rest.iter().position(|&b| b == b'\n');
    let line = &rest[..end.unwrap_or(rest.len())];
    let parsed = std::str::from_utf8(line)
        .ok()
        .map(str::trim_ascii)
        .and_then(parse);
    match (end, parsed) {
        (Some(end), Some(value)) => {
            *rest = &rest[end + 1..];
            Ok(value)
        }
        _ => Err(excerpt(line)),
    }
}

/// `<width> <height>`, both positive decimal integers.
fn parse_size(line: &str) -> Option<(usize, usize)> {
    let mut tokens = line.split_ascii_whitespace();
    let size = (
        parse_dimension(tokens.next()?)?,
        parse_dimension(tokens.next()?)?,
    );
    tokens.next().is_none().then_some(size)
}

/// The start of a header line, for error messages.
fn excerpt(line: &[u8]) -> String {
    const MAX: usize = 40;
    let text = String::from_utf8_lossy(&line[..line.len().min(MAX)]);
    let ellipsis = if line.len() > MAX { "…" } else { "" };
    format!("{}{ellipsis}", text.trim_ascii())
}

/// A width or height: decimal digits only (no sign), not zero.
fn parse_dimension(token: &str) -> Option<usize> {
    token
        .bytes()
        .all(|b| b.is_ascii_digit())
        .then(|| token.parse().ok())
        .flatten()
        .filter(|&n| n > 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Header + the course's reference 3×2 image, little-endian, bottom row first.
    const REFERENCE_LE: [u8; 84] = [
        0x50, 0x46, 0x0a, 0x33, 0x20, 0x32, 0x0a, 0x2d, 0x31, 0x2e, 0x30,
        0x0a, // PF\n3 2\n-1.0\n
        0x00, 0x00, 0xc8, 0x42, 0x00, 0x00, 0x48, 0x43, 0x00, 0x00, 0x96, 0x43, // 100 200 300
        0x00, 0x00, 0xc8, 0x43, 0x00, 0x00, 0xfa, 0x43, 0x00, 0x00, 0x16, 0x44, // 400 500 600
        0x00, 0x00, 0x2f, 0x44, 0x00, 0x00, 0x48, 0x44, 0x00, 0x00, 0x61, 0x44, // 700 800 900
        0x00, 0x00, 0x20, 0x41, 0x00, 0x00, 0xa0, 0x41, 0x00, 0x00, 0xf0, 0x41, // 10 20 30
        0x00, 0x00, 0x20, 0x42, 0x00, 0x00, 0x48, 0x42, 0x00, 0x00, 0x70, 0x42, // 40 50 60
        0x00, 0x00, 0x8c, 0x42, 0x00, 0x00, 0xa0, 0x42, 0x00, 0x00, 0xb4, 0x42, // 70 80 90
    ];

    /// The same image, big-endian.
    const REFERENCE_BE: [u8; 83] = [
        0x50, 0x46, 0x0a, 0x33, 0x20, 0x32, 0x0a, 0x31, 0x2e, 0x30, 0x0a, // PF\n3 2\n1.0\n
        0x42, 0xc8, 0x00, 0x00, 0x43, 0x48, 0x00, 0x00, 0x43, 0x96, 0x00, 0x00, // 100 200 300
        0x43, 0xc8, 0x00, 0x00, 0x43, 0xfa, 0x00, 0x00, 0x44, 0x16, 0x00, 0x00, // 400 500 600
        0x44, 0x2f, 0x00, 0x00, 0x44, 0x48, 0x00, 0x00, 0x44, 0x61, 0x00, 0x00, // 700 800 900
        0x41, 0x20, 0x00, 0x00, 0x41, 0xa0, 0x00, 0x00, 0x41, 0xf0, 0x00, 0x00, // 10 20 30
        0x42, 0x20, 0x00, 0x00, 0x42, 0x48, 0x00, 0x00, 0x42, 0x70, 0x00, 0x00, // 40 50 60
        0x42, 0x8c, 0x00, 0x00, 0x42, 0xa0, 0x00, 0x00, 0x42, 0xb4, 0x00, 0x00, // 70 80 90
    ];

    fn reference() -> Image {
        let mut img = Image::new(3, 2);
        img.set(0, 0, Rgb::new(1e1, 2e1, 3e1));
        img.set(1, 0, Rgb::new(4e1, 5e1, 6e1));
        img.set(2, 0, Rgb::new(7e1, 8e1, 9e1));
        img.set(0, 1, Rgb::new(1e2, 2e2, 3e2));
        img.set(1, 1, Rgb::new(4e2, 5e2, 6e2));
        img.set(2, 1, Rgb::new(7e2, 8e2, 9e2));
        img
    }

    /// A header followed by `data`.
    fn file(header: &str, data: &[u8]) -> Vec<u8> {
        [header.as_bytes(), data].concat()
    }

    #[test]
    fn reads_the_reference_image_in_both_byte_orders() {
        assert_eq!(read_pfm(&REFERENCE_LE).unwrap(), reference());
        assert_eq!(read_pfm(&REFERENCE_BE).unwrap(), reference());
    }

    #[test]
    fn writes_the_reference_image_byte_for_byte() {
        assert_eq!(write_pfm(&reference()), REFERENCE_LE);
        assert_eq!(read_pfm(&write_pfm(&reference())).unwrap(), reference());
    }

    #[test]
    fn tolerates_crlf_blanks_other_spellings_of_one_and_trailing_bytes() {
        let data = &REFERENCE_LE[12..];
        for header in [
            "PF\r\n3 2\r\n-1.0\r\n",
            "PF \n  3   2 \n -1 \n",
            "PF\n3\t2\n-1.000000\n",
            "PF\n3 2\n-1e0\n",
        ] {
            assert_eq!(
                read_pfm(&file(header, data)).unwrap(),
                reference(),
                "{header:?}"
            );
        }
        let be = file("PF\n3 2\n1.000000\n", &REFERENCE_BE[11..]);
        assert_eq!(read_pfm(&be).unwrap(), reference());
        let long = [&REFERENCE_LE[..], b"trailing junk"].concat();
        assert_eq!(read_pfm(&long).unwrap(), reference());
    }

    #[test]
    fn reads_grey_files_as_replicated_rgb() {
        // 2×2 grey, little-endian: bottom row 3 4, top row 1 2.
        let data: Vec<u8> = [3f32, 4., 1., 2.]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let img = read_pfm(&file("Pf\n2 2\n-1.0\n", &data)).unwrap();
        assert_eq!(img.pixels(), [1f32, 2., 3., 4.].map(Rgb::splat));
        let data: Vec<u8> = [0.5f32].iter().flat_map(|v| v.to_be_bytes()).collect();
        let img = read_pfm(&file("Pf\n1 1\n1\n", &data)).unwrap();
        assert_eq!(img.pixels(), [Rgb::splat(0.5)]);
    }

    #[test]
    fn rejects_bad_magic() {
        for bytes in [
            &b""[..],
            b"P6\n3 2\n255\n",
            b"PF3 2 -1.0",
            b"pf\n1 1\n-1\n",
            b"\xff\xfe\n",
        ] {
            let err = read_pfm(bytes).unwrap_err();
            assert!(
                matches!(err, ImageError::PfmMagic { .. }),
                "{bytes:?}: {err}"
            );
        }
        let err = read_pfm(b"P6\n3 2\n255\n").unwrap_err();
        assert!(err.to_string().contains("\"P6\""), "{err}");
    }

    #[test]
    fn rejects_bad_size_lines() {
        let huge = format!("{} 2", usize::MAX / 4);
        for size in [
            "0 2",
            "3 0",
            "-3 2",
            "3 -2",
            "+3 2",
            "3",
            "3 2 1",
            "",
            "a b",
            "3 2.0",
            "3x2",
            "99999999999999999999999 1",
            &huge,
        ] {
            let err = read_pfm(&file(&format!("PF\n{size}\n-1.0\n"), &[0; 72])).unwrap_err();
            assert!(matches!(err, ImageError::PfmSize { .. }), "{size:?}: {err}");
        }
        // The header stops in the middle of the size line.
        let err = read_pfm(b"PF\n3 2").unwrap_err();
        assert!(matches!(err, ImageError::PfmSize { .. }), "{err}");
    }

    #[test]
    fn rejects_scales_other_than_plus_or_minus_one() {
        for scale in ["0", "2.5", "-2", "abc", "", "-1.0 1", "nan", "inf", "0.999"] {
            let err = read_pfm(&file(&format!("PF\n1 1\n{scale}\n"), &[0; 12])).unwrap_err();
            assert!(
                matches!(err, ImageError::PfmEndianness { .. }),
                "{scale:?}: {err}"
            );
        }
        let err = read_pfm(b"PF\n1 1\n-1.0").unwrap_err();
        assert!(matches!(err, ImageError::PfmEndianness { .. }), "{err}");
    }

    #[test]
    fn rejects_truncated_data_saying_how_much_is_missing() {
        let err = read_pfm(&REFERENCE_LE[..83]).unwrap_err();
        assert!(
            matches!(
                err,
                ImageError::Truncated {
                    expected: 72,
                    got: 71
                }
            ),
            "{err}"
        );
        assert!(err.to_string().contains("72 bytes") && err.to_string().contains("71"));
        let err = read_pfm(&file("PF\n100000 100000\n-1\n", &[])).unwrap_err();
        assert!(matches!(
            err,
            ImageError::Truncated {
                expected: 120_000_000_000,
                got: 0
            }
        ));
        let err = read_pfm(&file("Pf\n2 1\n-1\n", &[0; 7])).unwrap_err();
        assert!(matches!(
            err,
            ImageError::Truncated {
                expected: 8,
                got: 7
            }
        ));
    }
}
