//! Partial renders and checkpoints: a film (exact per-pixel sums and counts of a window of a
//! frame) with what it holds, in candela's own file format (`docs/partial-format.md`).
//!
//! ```text
//! "candela-partial\n"                      16 bytes of magic
//! key=value\n …                            the header, UTF-8, one entry per line
//! \n                                       an empty line ends the header
//! body                                     per window pixel, row-major: the sample count,
//!                                          then `channels` sums, each a LEB128 varint
//!                                          (sums zigzag-encoded 128-bit fixed point)
//! checksum                                 8 bytes, FNV-1a 64 of everything before, LE
//! ```
//!
//! Header keys: `format` (1), `width`, `height`, `channels`, `window` (`x0,x1,y0,y1`, pixels,
//! half-open, row 0 at the top), `spp` (the whole frame's), `samples` (`A..B`: the sample
//! indices every pixel holds), `target` (`A..B`: the range the job that wrote it renders; equal
//! to `samples` once it is complete), `scene` (the hash of the scene's files) and any number of
//! `setting.NAME` entries (everything else that changes pixels). Readers refuse unknown
//! formats, truncated or corrupted files (the checksum), windows outside the image and counts
//! that disagree with `samples`.

use candela_render::film::{Film, Window};
use std::fmt::Write as _;

/// The first bytes of every partial file.
pub const MAGIC: &[u8; 16] = b"candela-partial\n";
/// The format version written.
pub const FORMAT: u32 = 1;

/// What a partial file holds besides its film.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PartialMeta {
    /// Samples per pixel of the whole frame.
    pub spp: u32,
    /// The sample indices `A..B` every pixel of the film holds.
    pub samples: (u32, u32),
    /// The sample range the writing job renders (equal to `samples` when it is complete).
    pub target: (u32, u32),
    /// The hash of the scene and the files it loads.
    pub scene: String,
    /// The other settings that change pixels, as `(name, value)`, in a fixed order.
    pub settings: Vec<(String, String)>,
}

/// A film with what it holds.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Partial {
    /// What the film holds.
    pub meta: PartialMeta,
    /// The sums and counts.
    pub film: Film,
}

impl Partial {
    /// True when the film holds every sample its job meant to render.
    pub fn is_complete(&self) -> bool {
        self.meta.samples == self.meta.target
    }
}

/// Encodes a partial file.
pub fn encode_partial(p: &Partial) -> Vec<u8> {
    let f = &p.film;
    let w = f.window();
    let m = &p.meta;
    let mut header = String::new();
    let _ = writeln!(header, "format={FORMAT}");
    let _ = writeln!(header, "width={}", f.width());
    let _ = writeln!(header, "height={}", f.height());
    let _ = writeln!(header, "channels={}", f.channels());
    let _ = writeln!(header, "window={},{},{},{}", w.x0, w.x1, w.y0, w.y1);
    let _ = writeln!(header, "spp={}", m.spp);
    let _ = writeln!(header, "samples={}..{}", m.samples.0, m.samples.1);
    let _ = writeln!(header, "target={}..{}", m.target.0, m.target.1);
    let _ = writeln!(header, "scene={}", clean(&m.scene));
    for (k, v) in &m.settings {
        let _ = writeln!(header, "setting.{}={}", clean(k), clean(v));
    }
    header.push('\n');
    let mut out = Vec::with_capacity(header.len() + w.pixels() * (1 + 8 * f.channels()) + 8);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(header.as_bytes());
    let c = f.channels();
    for (i, &n) in f.counts().iter().enumerate() {
        put_varint(&mut out, n as u128);
        for &s in &f.sums()[i * c..(i + 1) * c] {
            put_varint(&mut out, zigzag(s));
        }
    }
    let sum = fnv1a(&out);
    out.extend_from_slice(&sum.to_le_bytes());
    out
}

/// Decodes a partial file, checking everything it can (see the module doc); the error says
/// what is wrong.
pub fn decode_partial(bytes: &[u8]) -> Result<Partial, String> {
    if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
        return Err("not a candela partial file (it does not start with 'candela-partial')".into());
    }
    if bytes.len() < MAGIC.len() + 8 {
        return Err("truncated: the file ends before its checksum".into());
    }
    let (data, sum) = bytes.split_at(bytes.len() - 8);
    let header_end = data[MAGIC.len()..]
        .windows(2)
        .position(|w| w == b"\n\n")
        .map(|i| MAGIC.len() + i + 2)
        .ok_or("truncated: the header never ends")?;
    if fnv1a(data).to_le_bytes() != sum {
        return Err("corrupted or truncated: the checksum does not match the contents".into());
    }
    let header = std::str::from_utf8(&data[MAGIC.len()..header_end - 1])
        .map_err(|_| "the header is not UTF-8")?;
    let mut entries = Vec::new();
    for line in header.lines() {
        let (k, v) = line
            .split_once('=')
            .ok_or_else(|| format!("header line '{line}' is not key=value"))?;
        entries.push((k.to_string(), v.to_string()));
    }
    let get = |key: &str| {
        entries
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
            .ok_or_else(|| format!("the header has no '{key}'"))
    };
    let num = |key: &str| -> Result<usize, String> {
        let v = get(key)?;
        v.parse::<usize>()
            .map_err(|_| format!("header '{key}={v}' is not a whole number"))
    };
    let format = num("format")?;
    if format != FORMAT as usize {
        return Err(format!(
            "format {format} is not supported (this candela reads format {FORMAT})"
        ));
    }
    let (width, height, channels) = (num("width")?, num("height")?, num("channels")?);
    for (key, side) in [("width", width), ("height", height)] {
        if !(1..=MAX_FRAME_SIDE).contains(&side) {
            return Err(format!(
                "header '{key}={side}' is out of range (1 … {MAX_FRAME_SIDE})"
            ));
        }
    }
    if !(1..=64).contains(&channels) {
        return Err(format!("header 'channels={channels}' is out of range"));
    }
    let window = {
        let v = get("window")?;
        let n: Vec<usize> = v.split(',').filter_map(|x| x.parse().ok()).collect();
        match n[..] {
            [x0, x1, y0, y1] => Window { x0, x1, y0, y1 },
            _ => return Err(format!("header 'window={v}' is not x0,x1,y0,y1")),
        }
    };
    if !window.fits(width, height) {
        return Err(format!(
            "the window {},{},{},{} does not fit the {width}×{height} image",
            window.x0, window.x1, window.y0, window.y1
        ));
    }
    let spp = u32::try_from(num("spp")?).map_err(|_| "header 'spp' is out of range")?;
    let range = |key: &str| -> Result<(u32, u32), String> {
        let v = get(key)?;
        v.split_once("..")
            .and_then(|(a, b)| Some((a.parse().ok()?, b.parse().ok()?)))
            .filter(|&(a, b): &(u32, u32)| a <= b && b <= spp)
            .ok_or_else(|| format!("header '{key}={v}' is not a range A..B within 0..{spp}"))
    };
    let samples = range("samples")?;
    let target = range("target")?;
    if samples.0 != target.0 || samples.1 > target.1 {
        return Err("header 'samples' is not the start of 'target'".into());
    }
    let scene = get("scene")?.to_string();
    let settings = entries
        .iter()
        .filter_map(|(k, v)| Some((k.strip_prefix("setting.")?.to_string(), v.clone())))
        .collect();

    // Each pixel takes at least 1 + channels bytes: the body's length bounds what is allocated.
    let mut body = &data[header_end..];
    if window.pixels() > body.len() / (1 + channels) {
        return Err(format!(
            "truncated: {} pixels announced, the body has room for fewer",
            window.pixels()
        ));
    }
    let mut sums = Vec::with_capacity(window.pixels() * channels);
    let mut counts = Vec::with_capacity(window.pixels());
    let expected = samples.1 - samples.0;
    for i in 0..window.pixels() {
        let n = get_varint(&mut body).ok_or("truncated body")?;
        if n != expected as u128 {
            let (x, y) = (
                window.x0 + i % window.width(),
                window.y0 + i / window.width(),
            );
            return Err(format!(
                "pixel ({x}, {y}) holds {n} samples, the header says {expected}"
            ));
        }
        counts.push(expected);
        for _ in 0..channels {
            sums.push(unzigzag(get_varint(&mut body).ok_or("truncated body")?));
        }
    }
    if !body.is_empty() {
        return Err(format!("{} stray bytes after the body", body.len()));
    }
    let film = Film::from_parts(width, height, window, channels, sums, counts)
        .ok_or("the film's sizes disagree")?;
    Ok(Partial {
        meta: PartialMeta {
            spp,
            samples,
            target,
            scene,
            settings,
        },
        film,
    })
}

/// The largest frame side a partial file may hold (the renderer's image limit).
pub const MAX_FRAME_SIDE: usize = 1 << 15;

/// Header values stay on one line.
fn clean(s: &str) -> String {
    s.replace(['\n', '\r'], " ")
}

fn zigzag(v: i128) -> u128 {
    ((v << 1) ^ (v >> 127)) as u128
}

fn unzigzag(u: u128) -> i128 {
    ((u >> 1) as i128) ^ -((u & 1) as i128)
}

fn put_varint(out: &mut Vec<u8>, mut v: u128) {
    loop {
        let byte = (v & 0x7f) as u8;
        v >>= 7;
        if v == 0 {
            out.push(byte);
            return;
        }
        out.push(byte | 0x80);
    }
}

fn get_varint(buf: &mut &[u8]) -> Option<u128> {
    let mut v = 0u128;
    for shift in (0..128).step_by(7) {
        let (&byte, rest) = buf.split_first()?;
        *buf = rest;
        let bits = (byte & 0x7f) as u128;
        if shift == 126 && bits > 3 {
            return None;
        }
        v |= bits << shift;
        if byte & 0x80 == 0 {
            return Some(v);
        }
    }
    None
}

/// FNV-1a, 64 bits.
fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;
    use candela_render::film::to_fixed;

    fn sample() -> Partial {
        let window = Window {
            x0: 1,
            x1: 4,
            y0: 0,
            y1: 2,
        };
        let sums: Vec<i128> = (0..18)
            .map(|i| to_fixed((i as f32 - 7.0) * 1.0e3) * 1_000_000_007)
            .collect();
        let film = Film::from_parts(5, 3, window, 3, sums, vec![8; 6]).unwrap();
        Partial {
            meta: PartialMeta {
                spp: 16,
                samples: (4, 12),
                target: (4, 16),
                scene: "abc".into(),
                settings: vec![("integrator".into(), "path".into())],
            },
            film,
        }
    }

    #[test]
    fn round_trips_and_refuses_every_damaged_byte_count() {
        let p = sample();
        let bytes = encode_partial(&p);
        assert_eq!(decode_partial(&bytes).unwrap(), p);
        for cut in 0..bytes.len() {
            assert!(decode_partial(&bytes[..cut]).is_err(), "cut at {cut}");
        }
        for at in [0, 20, bytes.len() / 2, bytes.len() - 1] {
            let mut bad = bytes.clone();
            bad[at] ^= 0x10;
            assert!(decode_partial(&bad).is_err(), "flip at {at}");
        }
    }

    #[test]
    fn varints_cover_the_whole_range() {
        for v in [0i128, 1, -1, i128::MAX, i128::MIN, 1 << 100, -(1 << 90) + 3] {
            let mut out = Vec::new();
            put_varint(&mut out, zigzag(v));
            let mut s = &out[..];
            assert_eq!(unzigzag(get_varint(&mut s).unwrap()), v);
            assert!(s.is_empty());
        }
    }
}
