//! Reading and writing real files: every format, extension handling and atomic writes.

use std::{
    fs,
    path::PathBuf,
    sync::atomic::{AtomicUsize, Ordering},
};

use candela_imageio::{
    png::write_png, read_image, read_pfm_file, supported_extension, tonemap::srgb_oetf,
    write_image, Encoding, ImageError, ToneMap,
};
use candela_render::{Image, Rgb};

/// A fresh, empty directory under the system temp dir, removed on drop.
struct TempDir(PathBuf);

impl TempDir {
    fn new() -> Self {
        static COUNT: AtomicUsize = AtomicUsize::new(0);
        let n = COUNT.fetch_add(1, Ordering::Relaxed);
        let dir = std::env::temp_dir().join(format!("candela-imageio-{}-{n}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        Self(dir)
    }

    fn path(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }

    /// The names of the directory's entries, sorted.
    fn entries(&self) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(&self.0)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = fs::remove_dir_all(&self.0);
    }
}

/// A 4×3 HDR image with distinct pixels.
fn hdr_image() -> Image {
    let mut img = Image::new(4, 3);
    for (i, p) in img.pixels_mut().iter_mut().enumerate() {
        let i = i as f32;
        *p = Rgb::new(i * 0.5, i * i, 100.0 / (i + 1.0));
    }
    img
}

#[test]
fn pfm_and_exr_round_trip_exactly() {
    let dir = TempDir::new();
    for name in ["a.pfm", "b.exr", "C.PFM", "d.ExR"] {
        let path = dir.path(name);
        write_image(&path, &hdr_image(), &ToneMap::default()).unwrap();
        assert_eq!(read_image(&path).unwrap(), hdr_image(), "{name}");
    }
    // The PFM reader does not care about the extension.
    fs::rename(dir.path("a.pfm"), dir.path("a.data")).unwrap();
    assert_eq!(read_pfm_file(&dir.path("a.data")).unwrap(), hdr_image());
    assert_eq!(dir.entries(), ["C.PFM", "a.data", "b.exr", "d.ExR"]);
}

#[test]
fn png_holds_the_tone_mapped_bytes() {
    let dir = TempDir::new();
    let path = dir.path("t.png");
    let tonemap = ToneMap {
        encoding: Encoding::Srgb,
        ..ToneMap::default()
    };
    write_image(&path, &hdr_image(), &tonemap).unwrap();
    let back = read_image(&path).unwrap();
    assert_eq!((back.width(), back.height()), (4, 3));
    // Reading decodes sRGB, so re-encoding gives back exactly the tone-mapped bytes.
    let bytes: Vec<u8> = back
        .pixels()
        .iter()
        .flat_map(|p| p.to_array())
        .map(|x| (255.0 * srgb_oetf(x)).round() as u8)
        .collect();
    assert_eq!(bytes, tonemap.apply(&hdr_image()));
}

#[test]
fn png_values_are_decoded_from_srgb() {
    let dir = TempDir::new();
    let path = dir.path("half.png");
    // 128 is the 8-bit sRGB encoding of 0.5, which is linear 0.2140 (128 itself gives 0.2159).
    fs::write(&path, write_png(1, 1, &[128, 128, 128]).unwrap()).unwrap();
    let p = read_image(&path).unwrap().get(0, 0);
    assert!(p.approx_eq(Rgb::splat(0.2140), 0.002), "{p:?}");
    assert!(p.approx_eq(Rgb::splat(0.215_861), 1e-5), "{p:?}");
}

#[test]
fn unknown_extensions_are_refused_before_writing() {
    let dir = TempDir::new();
    // `.bmp` and `.jpg` are read (see `raster`), never written.
    for name in ["x.bmp", "x.jpg"] {
        let path = dir.path(name);
        assert!(!supported_extension(&path));
        let err = write_image(&path, &hdr_image(), &ToneMap::default()).unwrap_err();
        assert!(
            matches!(err, ImageError::UnsupportedExtension { .. }),
            "{err}"
        );
        assert!(!matches!(
            read_image(&path).unwrap_err(),
            ImageError::UnsupportedExtension { .. }
        ));
    }
    for name in ["x.gif", "x", "x.pfm.tmp"] {
        let path = dir.path(name);
        assert!(!supported_extension(&path));
        let err = write_image(&path, &hdr_image(), &ToneMap::default()).unwrap_err();
        assert!(
            matches!(err, ImageError::UnsupportedExtension { .. }),
            "{err}"
        );
        assert!(err.to_string().contains(".pfm, .exr, .png"), "{err}");
        let err = read_image(&path).unwrap_err();
        assert!(
            matches!(err, ImageError::UnsupportedExtension { .. }),
            "{err}"
        );
    }
    assert!(dir.entries().is_empty(), "{:?}", dir.entries());
}

#[test]
fn a_missing_directory_leaves_nothing_behind() {
    let dir = TempDir::new();
    let path = dir.path("missing/out.pfm");
    let err = write_image(&path, &hdr_image(), &ToneMap::default()).unwrap_err();
    assert!(matches!(err, ImageError::Io { .. }), "{err}");
    assert!(
        err.to_string().starts_with(&path.display().to_string()),
        "{err}"
    );
    assert!(dir.entries().is_empty(), "{:?}", dir.entries());
}

#[test]
fn failed_writes_leave_the_old_file_untouched() {
    let dir = TempDir::new();
    let path = dir.path("keep.pfm");
    write_image(&path, &hdr_image(), &ToneMap::default()).unwrap();
    let before = fs::read(&path).unwrap();

    // Encoding fails: nothing is touched.
    let err = write_image(&path, &Image::new(0, 2), &ToneMap::default()).unwrap_err();
    assert!(matches!(err.kind(), ImageError::EmptyImage { .. }), "{err}");
    assert!(err.to_string().contains("keep.pfm"), "{err}");
    assert_eq!(fs::read(&path).unwrap(), before);

    // The rename fails (the target is a non-empty directory): the temporary file goes away.
    let blocker = dir.path("blocked.exr");
    fs::create_dir(&blocker).unwrap();
    fs::write(blocker.join("inside"), b"x").unwrap();
    let err = write_image(&blocker, &hdr_image(), &ToneMap::default()).unwrap_err();
    assert!(matches!(err, ImageError::Io { .. }), "{err}");
    assert_eq!(dir.entries(), ["blocked.exr", "keep.pfm"]);
    assert_eq!(fs::read(blocker.join("inside")).unwrap(), b"x");

    // A successful write replaces the file and leaves no temporary file.
    let other = Image::new(1, 1);
    write_image(&path, &other, &ToneMap::default()).unwrap();
    assert_eq!(read_image(&path).unwrap(), other);
    assert_eq!(dir.entries(), ["blocked.exr", "keep.pfm"]);
}

#[test]
fn concurrent_writes_to_one_file_each_land_whole() {
    let dir = TempDir::new();
    let path = dir.path("race.exr");
    let images: Vec<Image> = (1..=8)
        .map(|i| Image::from_pixels(2, 2, vec![Rgb::splat(i as f32); 4]).unwrap())
        .collect();
    std::thread::scope(|s| {
        for img in &images {
            let path = &path;
            s.spawn(move || write_image(path, img, &ToneMap::default()).unwrap());
        }
    });
    assert!(images.contains(&read_image(&path).unwrap()));
    assert_eq!(dir.entries(), ["race.exr"]);
}

#[test]
fn read_errors_name_the_file() {
    let dir = TempDir::new();
    let missing = dir.path("nope.exr");
    let err = read_image(&missing).unwrap_err();
    assert!(
        matches!(&err, ImageError::Io { path, .. } if path == &missing),
        "{err}"
    );
    assert!(err
        .to_string()
        .starts_with(&format!("{}: cannot read: ", missing.display())));

    let cut = dir.path("cut.pfm");
    fs::write(&cut, b"PF\n2 2\n-1.0\n\0\0\0\0").unwrap();
    let err = read_image(&cut).unwrap_err();
    assert!(
        matches!(
            err.kind(),
            ImageError::Truncated {
                expected: 48,
                got: 4
            }
        ),
        "{err}"
    );
    assert!(
        err.to_string()
            .starts_with(&format!("{}: truncated", cut.display())),
        "{err}"
    );

    for (name, bytes) in [("bad.png", &b"PF\n1 1\n-1\n"[..]), ("bad.exr", b"\x89PNG")] {
        let path = dir.path(name);
        fs::write(&path, bytes).unwrap();
        let err = read_image(&path).unwrap_err();
        assert!(matches!(err, ImageError::File { .. }), "{err}");
        assert!(
            err.to_string().starts_with(&path.display().to_string()),
            "{err}"
        );
    }
}
