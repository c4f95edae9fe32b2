//! Animation frames: `%d` and `%0Nd` in file names become the frame number.

use std::path::{Path, PathBuf};

/// The position and zero-padding width of the first `%d` / `%0Nd` in `s`.
fn placeholder(s: &str) -> Option<(usize, usize, usize)> {
    let bytes = s.as_bytes();
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let mut j = i + 1;
            while j < bytes.len() && bytes[j].is_ascii_digit() {
                j += 1;
            }
            if j < bytes.len() && bytes[j] == b'd' {
                let width = s[i + 1..j].parse::<usize>().unwrap_or(0).min(10);
                return Some((i, j + 1, width));
            }
        }
        i += 1;
    }
    None
}

/// True when `path` has a frame-number placeholder.
pub fn has_number(path: &Path) -> bool {
    path.to_str().and_then(placeholder).is_some()
}

/// `path` with its placeholder replaced by `frame` (unchanged without a frame or placeholder).
pub fn name(path: &Path, frame: Option<u32>) -> PathBuf {
    let (Some(frame), Some(s)) = (frame, path.to_str()) else {
        return path.to_path_buf();
    };
    match placeholder(s) {
        Some((a, b, width)) => PathBuf::from(format!("{}{frame:0width$}{}", &s[..a], &s[b..])),
        None => path.to_path_buf(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn placeholders_become_frame_numbers() {
        let n = |p: &str, f| name(Path::new(p), f).to_str().unwrap().to_string();
        assert_eq!(n("out_%04d.png", Some(7)), "out_0007.png");
        assert_eq!(n("f%d.exr", Some(123)), "f123.exr");
        assert_eq!(n("f%2d.exr", Some(123)), "f123.exr");
        assert_eq!(n("plain.png", Some(3)), "plain.png");
        assert_eq!(n("out_%04d.png", None), "out_%04d.png");
        assert!(has_number(Path::new("a/%03d.pfm")));
        assert!(!has_number(Path::new("a/100%.pfm")));
    }
}
