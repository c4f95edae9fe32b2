//! The bad-input suite: every row of `cases.txt` runs the `candela` binary alone in a fresh
//! folder, under a 10 s timeout and a 1 GB address-space limit (`ulimit -v`), and checks:
//! the exit status, a message matching the row's pattern, no panic, no file of the folder
//! (inputs, FIFOs, links to devices) changed, and after a failure no new file at all (no
//! partial output, no temporary file left).
//!
//! Row format (`|`-separated, `#` comments): `name | files | command | status | stderr pattern
//! [| post-check]`. `files` is a `;;`-separated list of `NAME=TEXT` (with `\n`, `\t`, `\xHH`
//! escapes), `NAME@fifo`, `NAME@dir`, `NAME@link:TARGET` or `NAME@gen:GENERATOR` (see
//! [`generate`]). `command` is the shell text after the binary (redirections allowed: `< FILE`
//! feeds standard input, which is otherwise empty). The post-checks (`,`-separated):
//! `finite:FILE.pfm` reads an output PFM and requires every value finite and ≥ 0;
//! `exists:FILE` requires an output that is not empty; `changed:FILE` lets an input change (a
//! radiosity cache solved again).

use std::collections::BTreeMap;
use std::fs;
use std::os::unix::fs::FileTypeExt;
use std::path::Path;
use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

const TIMEOUT_SECONDS: u32 = 10;
const ADDRESS_SPACE_KB: u64 = 1 << 20;

struct Case {
    line: usize,
    name: String,
    files: String,
    command: String,
    status: i32,
    pattern: String,
    post: String,
}

fn parse_cases() -> Vec<Case> {
    let text = include_str!("cases.txt");
    let mut cases = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let f: Vec<&str> = line.splitn(6, " | ").map(str::trim).collect();
        assert!(f.len() >= 5, "cases.txt:{}: expected 5 or 6 fields", i + 1);
        cases.push(Case {
            line: i + 1,
            name: f[0].to_string(),
            files: f[1].to_string(),
            command: f[2].to_string(),
            status: f[3]
                .parse()
                .unwrap_or_else(|_| panic!("cases.txt:{}: bad status", i + 1)),
            pattern: f[4].to_string(),
            post: f.get(5).unwrap_or(&"").to_string(),
        });
    }
    cases
}

fn unescape(s: &str) -> Vec<u8> {
    let mut out = Vec::new();
    let b = s.as_bytes();
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'\\' && i + 1 < b.len() {
            match b[i + 1] {
                b'n' => out.push(b'\n'),
                b't' => out.push(b'\t'),
                b'r' => out.push(b'\r'),
                b'\\' => out.push(b'\\'),
                b'x' if i + 3 < b.len() => {
                    let hex = std::str::from_utf8(&b[i + 2..i + 4]).unwrap();
                    out.push(u8::from_str_radix(hex, 16).unwrap());
                    i += 4;
                    continue;
                }
                c => {
                    out.push(b'\\');
                    out.push(c);
                }
            }
            i += 2;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    out
}

fn crc32(data: &[u8]) -> u32 {
    let mut crc = 0xffff_ffffu32;
    for &x in data {
        crc ^= x as u32;
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xedb8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

fn png_chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
    out.extend((data.len() as u32).to_be_bytes());
    let mut c = kind.to_vec();
    c.extend(data);
    out.extend(&c);
    out.extend(crc32(&c).to_be_bytes());
}

/// A PNG whose header declares `w`×`h` pixels, with a few bytes of data.
fn png_declaring(w: u32, h: u32) -> Vec<u8> {
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = Vec::new();
    ihdr.extend(w.to_be_bytes());
    ihdr.extend(h.to_be_bytes());
    ihdr.extend([8, 2, 0, 0, 0]);
    png_chunk(&mut out, b"IHDR", &ihdr);
    // An empty stored zlib stream (whatever the decoder thinks of it).
    png_chunk(
        &mut out,
        b"IDAT",
        &[0x78, 0x01, 0x01, 0x00, 0x00, 0xff, 0xff, 0, 0, 0, 1],
    );
    png_chunk(&mut out, b"IEND", &[]);
    out
}

/// A valid 1×1 OpenEXR file whose data window is patched to `w`×`h`.
fn exr_declaring(w: i32, h: i32) -> Vec<u8> {
    let img = candela_render::Image::new(1, 1);
    let mut bytes = candela_imageio::exr::write_exr(&img).unwrap();
    let key = b"dataWindow\0box2i\0";
    let at = bytes
        .windows(key.len())
        .position(|x| x == key)
        .expect("a data window")
        + key.len()
        + 4;
    bytes[at + 8..at + 12].copy_from_slice(&(w - 1).to_le_bytes());
    bytes[at + 12..at + 16].copy_from_slice(&(h - 1).to_le_bytes());
    bytes
}

fn pfm(w: usize, h: usize, values: &[f32]) -> Vec<u8> {
    let mut out = format!("PF\n{w} {h}\n-1.0\n").into_bytes();
    for v in values {
        out.extend(v.to_le_bytes());
    }
    out
}

/// An OBJ of `n` triangles.
fn obj(n: usize) -> Vec<u8> {
    let mut s = String::new();
    for i in 0..n {
        let x = i as f32 * 0.01;
        s += &format!("v {x} 0 0\nv {x} 1 0\nv {x} 0 1\nf -3 -2 -1\n");
    }
    s.into_bytes()
}

/// The candela scene with `n` half-spaces tangent to the unit sphere.
fn polyhedron_scene(n: usize) -> Vec<u8> {
    let mut s = String::from("material m(diffuse(<0.5, 0.5, 0.5>))\npolyhedron(m, identity");
    for i in 0..n {
        let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
        let r = (1.0 - z * z).sqrt();
        let phi = i as f64 * 2.399_963;
        s += &format!(
            ", [{:.6}, {:.6}, {:.6}], 1",
            r * phi.cos(),
            r * phi.sin(),
            z
        );
    }
    s += ")\ncamera(perspective, translation([-4, 0, 0]), 1, 1)\n";
    s.into_bytes()
}

/// Named CSG shapes, each the union of the previous one with itself, `n` levels.
fn csg_chain(n: usize) -> Vec<u8> {
    let mut s =
        String::from("material m(diffuse(<0.5, 0.5, 0.5>))\nshape s0(sphere(m, identity))\n");
    for i in 1..=n {
        s += &format!("shape s{i}(union(s{p}, s{p}))\n", p = i - 1);
    }
    s += &format!("s{n}\n");
    s.into_bytes()
}

/// Mitsuba `<default>`s that double at every level.
fn xml_default_bomb(n: usize) -> Vec<u8> {
    let mut s =
        String::from("<scene version=\"3.0.0\">\n<default name=\"a0\" value=\"xxxxxxxx\"/>\n");
    for i in 1..=n {
        s += &format!("<default name=\"a{i}\" value=\"$a{p}$a{p}\"/>\n", p = i - 1);
    }
    s += &format!("<shape type=\"sphere\" id=\"$a{n}\"/>\n</scene>\n");
    s.into_bytes()
}

/// Deeply nested XML elements.
fn xml_deep(n: usize) -> Vec<u8> {
    let mut s = String::from("<scene version=\"3.0.0\">");
    s += &"<shape type=\"sphere\">".repeat(n);
    s += &"</shape>".repeat(n);
    s += "</scene>";
    s.into_bytes()
}

/// Deeply nested scene-language shapes.
fn lang_deep(n: usize) -> Vec<u8> {
    let mut s = String::from("material m(diffuse(<0.5, 0.5, 0.5>))\n");
    s += &"union(".repeat(n);
    s += "sphere(m, identity)";
    s += &", sphere(m, identity))".repeat(n);
    s += "\n";
    s.into_bytes()
}

/// A radiosity scene with a point light (solved in a moment).
const RADIOSITY_SCENE: &str = "material m(diffuse(<0.5, 0.5, 0.5>))\nbox(m, identity)\npoint_light([0, 0, 0.5], <1, 1, 1>, 0)\ncamera(perspective, translation([-0.5, 0, 0]), 1, 1)\n";

/// A zlib stream holding `data` in stored (uncompressed) blocks.
fn zlib_stored(data: &[u8]) -> Vec<u8> {
    let mut out = vec![0x78, 0x01];
    let mut chunks = data.chunks(0xffff).peekable();
    if chunks.peek().is_none() {
        out.extend([1, 0, 0, 0xff, 0xff]);
    }
    while let Some(c) = chunks.next() {
        out.push(u8::from(chunks.peek().is_none()));
        out.extend((c.len() as u16).to_le_bytes());
        out.extend((!(c.len() as u16)).to_le_bytes());
        out.extend(c);
    }
    let (mut a, mut b) = (1u32, 0u32);
    for &x in data {
        a = (a + x as u32) % 65521;
        b = (b + a) % 65521;
    }
    out.extend(((b << 16) | a).to_be_bytes());
    out
}

/// A Mitsuba serialized file (format 4, single precision) of `vertices` and `triangles` with
/// the data `data`, then `pad` zero bytes.
fn serialized(vertices: u64, triangles: u64, data: &[u8], pad: usize) -> Vec<u8> {
    let mut body = 0x1000u32.to_le_bytes().to_vec();
    body.push(0);
    body.extend(vertices.to_le_bytes());
    body.extend(triangles.to_le_bytes());
    body.extend(data);
    let mut out = vec![0x1c, 0x04, 4, 0];
    out.extend(zlib_stored(&body));
    out.resize(out.len() + pad, 0);
    out
}

/// The data of one triangle with vertices `p` and indices `i`.
fn triangle_data(p: [f32; 9], i: [u32; 3]) -> Vec<u8> {
    let mut out: Vec<u8> = p.iter().flat_map(|v| v.to_le_bytes()).collect();
    out.extend(i.iter().flat_map(|v| v.to_le_bytes()));
    out
}

/// A partial file of the demo (4×4, 4 spp) holding samples `samples`, its header values
/// replaced by `edits` (the checksum made right again).
fn demo_part(dir: &Path, samples: &str, edits: &[(&str, &str)]) -> Vec<u8> {
    let o = run_candela(
        dir,
        &format!("demo -q --width 4 --height 4 --spp 4 --samples {samples} --partial gen.part"),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut b = fs::read(dir.join("gen.part")).unwrap();
    fs::remove_file(dir.join("gen.part")).unwrap();
    for (key, value) in edits {
        let line = format!("\n{key}=");
        let at = b
            .windows(line.len())
            .position(|w| w == line.as_bytes())
            .unwrap()
            + line.len();
        let end = at + b[at..].iter().position(|&c| c == b'\n').unwrap();
        b.splice(at..end, value.bytes());
    }
    let n = b.len() - 8;
    let h = fnv(&b[..n]);
    b[n..].copy_from_slice(&h.to_le_bytes());
    b
}

/// A Mitsuba scene whose `<include>`s multiply: 10 of a file that includes 10 of the next, 7
/// levels (10⁷ spheres if nothing stopped it); the included files are written into `dir`.
fn xml_include_bomb(dir: &Path) -> Vec<u8> {
    let level = |next: &str| {
        format!(
            "<scene version=\"3.0.0\">{}</scene>\n",
            format!("<include filename=\"{next}\"/>").repeat(10)
        )
    };
    let names = [
        "a.xml", "b.xml", "c.xml", "d.xml", "e.xml", "f.xml", "g.xml",
    ];
    for w in names.windows(2) {
        fs::write(dir.join(w[0]), level(w[1])).unwrap();
    }
    fs::write(
        dir.join("g.xml"),
        "<scene version=\"3.0.0\"><shape type=\"sphere\"/></scene>\n",
    )
    .unwrap();
    level("a.xml").into_bytes()
}

fn run_candela(dir: &Path, args: &str) -> std::process::Output {
    Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -v {ADDRESS_SPACE_KB}; exec timeout -s KILL {TIMEOUT_SECONDS} '{}' {args}",
            env!("CARGO_BIN_EXE_candela")
        ))
        .current_dir(dir)
        .output()
        .expect("sh runs")
}

fn fnv(bytes: &[u8]) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for &x in bytes {
        h ^= x as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// Files made by code: bombs and other inputs too large or too binary for the table.
fn generate(name: &str, dir: &Path) -> Vec<u8> {
    match name {
        "png_huge" => png_declaring(60_000, 60_000),
        "png_wide" => png_declaring(1 << 30, 1),
        "png_max" => png_declaring(u32::MAX, u32::MAX),
        "exr_huge" => exr_declaring(60_000, 60_000),
        "exr_wide" => exr_declaring(i32::MAX, 1),
        "exr_ok" => candela_imageio::exr::write_exr(&candela_render::Image::new(2, 2)).unwrap(),
        "hdr_huge" => {
            b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 60000 +X 60000\n\x02\x02\x00\x00".to_vec()
        }
        "hdr_wide" => b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 4000000000\n".to_vec(),
        "pfm_huge" => pfm(60_000, 60_000, &[1.0; 6]),
        "pfm_negative" => pfm(
            2,
            1,
            &[-1.0, f32::NAN, f32::INFINITY, 0.5, -0.0, f32::NEG_INFINITY],
        ),
        "pfm_ok" => pfm(2, 1, &[0.5; 6]),
        "png_ok" => candela_imageio::png::write_png(1, 1, &[10, 20, 30]).unwrap(),
        "obj_2000" => obj(2000),
        "polyhedron_2000" => polyhedron_scene(2000),
        "csg_chain_40" => csg_chain(40),
        "csg_chain_16" => csg_chain(16),
        "xml_default_bomb" => xml_default_bomb(40),
        "xml_deep" => xml_deep(5000),
        "lang_deep" => lang_deep(5000),
        "cache_forged" => {
            // A true cache of RADIOSITY_SCENE, one radiosity made negative, checksum fixed.
            fs::write(dir.join("rad.scene"), RADIOSITY_SCENE).unwrap();
            let o = run_candela(
                dir,
                "render rad.scene -q --width 4 --height 4 --integrator radiosity --patch-size 1 --radiosity-cache rad.cache -o tmp.pfm",
            );
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            fs::remove_file(dir.join("tmp.pfm")).unwrap();
            let mut b = fs::read(dir.join("rad.cache")).unwrap();
            fs::remove_file(dir.join("rad.cache")).unwrap();
            let ns = u32::from_le_bytes(b[28..32].try_into().unwrap()) as usize;
            let at = 32 + 4 * ns;
            b[at..at + 8].copy_from_slice(&(-1e6f64).to_le_bytes());
            let n = b.len() - 8;
            let h = fnv(&b[..n]);
            b[n..].copy_from_slice(&h.to_le_bytes());
            b
        }
        "radiosity_scene" => RADIOSITY_SCENE.as_bytes().to_vec(),
        "big_text" => vec![b'#'; 3 << 20],
        "pfm_one" => pfm(1, 1, &[0.5; 3]),
        "pfm_max" => pfm(2, 1, &[f32::MAX; 6]),
        "ser_ok" => serialized(
            3,
            1,
            &triangle_data([0., 0., 0., 1., 0., 0., 0., 1., 0.], [0, 1, 2]),
            0,
        ),
        "ser_index_out_of_range" => serialized(
            3,
            1,
            &triangle_data([0., 0., 0., 1., 0., 0., 0., 1., 0.], [0, 1, 7]),
            0,
        ),
        "ser_nan" => serialized(
            3,
            1,
            &triangle_data([f32::NAN, 0., 0., 1., 0., 0., 0., 1., 0.], [0, 1, 2]),
            0,
        ),
        // Counts whose data would take 1 GB, in a file large enough for deflate to hold them.
        "ser_bomb_vertices" => serialized(90_000_000, 0, &[], 2_000_000),
        "ser_bomb_triangles" => serialized(0, 90_000_000, &[], 2_000_000),
        "ser_truncated" => {
            let mut b = serialized(3, 1, &[0; 48], 0);
            b.truncate(24);
            b
        }
        "part_a" => demo_part(dir, "0..2", &[]),
        "part_albedo" => {
            let o = run_candela(
                dir,
                "demo -q --width 4 --height 4 --spp 2 --aov albedo --partial gen.part",
            );
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            let b = fs::read(dir.join("gen.part")).unwrap();
            fs::remove_file(dir.join("gen.part")).unwrap();
            b
        }
        "part_b" => demo_part(dir, "2..4", &[]),
        "part_frame_huge" => demo_part(dir, "2..4", &[("width", "30000"), ("height", "30000")]),
        "part_frame_wide" => demo_part(dir, "2..4", &[("width", "4000000000")]),
        "part_channels_huge" => demo_part(dir, "2..4", &[("channels", "4000000000")]),
        "part_window_huge" => demo_part(dir, "2..4", &[("window", "0,4294967295,0,4294967295")]),
        "part_truncated" => {
            let mut b = demo_part(dir, "2..4", &[]);
            b.truncate(b.len() / 2);
            b
        }
        "part_bit_flipped" => {
            let mut b = demo_part(dir, "2..4", &[]);
            let n = b.len() - 20;
            b[n] ^= 1;
            b
        }
        "polyhedron_repeated" => {
            let mut s =
                String::from("material m(diffuse(<0.5, 0.5, 0.5>))\npolyhedron(m, identity");
            s += &", [1, 0, 0], 1".repeat(3000);
            s += ", [-1, 0, 0], 1, [0, 1, 0], 1, [0, -1, 0], 1, [0, 0, 1], 1, [0, 0, -1], 1)\n";
            s += "camera(perspective, translation([-4, 0, 0]), 1, 1)\n";
            s.into_bytes()
        }
        "lang_parens" => {
            format!("float x({}1{})\n", "(".repeat(100_000), ")".repeat(100_000)).into_bytes()
        }
        "lang_unary" => format!("float x({}1)\n", "- ".repeat(100_000)).into_bytes(),
        "xml_include_bomb" => xml_include_bomb(dir),
        // 100 000 shapes on a single line (positions must not cost the line's length each).
        "xml_one_line" => format!(
            "<scene version=\"3.0.0\">{}</scene>",
            "<shape type=\"sphere\"><float name=\"radius\" value=\"0.001\"/></shape>"
                .repeat(100_000)
        )
        .into_bytes(),
        "xml_ref_chain" => {
            // 100 000 twosided BSDFs, each referring to the one before.
            let mut s = String::from("<scene version=\"3.0.0\"><bsdf type=\"diffuse\" id=\"b0\"/>");
            for i in 1..100_000 {
                s += &format!(
                    "<bsdf type=\"twosided\" id=\"b{i}\"><ref id=\"b{}\"/></bsdf>",
                    i - 1
                );
            }
            s += "<shape type=\"sphere\"><ref id=\"b99999\"/></shape></scene>\n";
            s.into_bytes()
        }
        _ => panic!("unknown generator {name}"),
    }
}

fn make_files(spec: &str, dir: &Path) {
    for item in spec.split(";;").map(str::trim).filter(|s| !s.is_empty()) {
        if let Some((name, kind)) = item.split_once('@') {
            if !name.contains('=') {
                let path = dir.join(name);
                match kind {
                    "fifo" => {
                        let ok = Command::new("mkfifo").arg(&path).status().unwrap();
                        assert!(ok.success());
                    }
                    "dir" => fs::create_dir_all(&path).unwrap(),
                    k if k.starts_with("link:") => {
                        std::os::unix::fs::symlink(&k[5..], &path).unwrap()
                    }
                    k if k.starts_with("gen:") => {
                        let bytes = generate(&k[4..], dir);
                        fs::write(&path, bytes).unwrap();
                    }
                    k => panic!("unknown file kind {k}"),
                }
                continue;
            }
        }
        let (name, text) = item.split_once('=').expect("NAME=TEXT");
        fs::write(dir.join(name), unescape(text)).unwrap();
    }
}

/// What a folder holds: each entry's kind and, for regular files, a hash of the bytes.
fn snapshot(dir: &Path) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    for e in fs::read_dir(dir).unwrap() {
        let e = e.unwrap();
        let t = e.file_type().unwrap();
        let what = if t.is_symlink() {
            format!("link:{}", fs::read_link(e.path()).unwrap().display())
        } else if t.is_fifo() {
            "fifo".into()
        } else if t.is_dir() {
            "dir".into()
        } else {
            format!("file:{:x}", fnv(&fs::read(e.path()).unwrap()))
        };
        out.insert(e.file_name().to_string_lossy().into_owned(), what);
    }
    out
}

fn post_check(checks: &str, dir: &Path) -> Result<(), String> {
    for check in checks.split(',').map(str::trim).filter(|c| !c.is_empty()) {
        if check.starts_with("changed:") {
            continue;
        }
        if let Some(file) = check.strip_prefix("exists:") {
            match fs::metadata(dir.join(file)) {
                Ok(m) if m.is_file() && m.len() > 0 => continue,
                _ => return Err(format!("{file} was not written")),
            }
        }
        let Some(file) = check.strip_prefix("finite:") else {
            return Err(format!("unknown post-check {check}"));
        };
        finite(file, dir)?;
    }
    Ok(())
}

/// Every value of the output PFM `file` is finite and not negative.
fn finite(file: &str, dir: &Path) -> Result<(), String> {
    let img = candela_imageio::read_pfm_file(&dir.join(file)).map_err(|e| e.to_string())?;
    match img
        .pixels()
        .iter()
        .find(|p| ![p.r, p.g, p.b].iter().all(|v| v.is_finite() && *v >= 0.0))
    {
        Some(p) => Err(format!("{file} has a pixel {p:?}")),
        None => Ok(()),
    }
}

fn run_case(c: &Case, root: &Path) -> Result<(), String> {
    let dir = root.join(format!("{:03}-{}", c.line, c.name));
    fs::create_dir_all(&dir).unwrap();
    make_files(&c.files, &dir);
    let before = snapshot(&dir);
    let start = Instant::now();
    let o = run_candela(&dir, &c.command);
    let took = start.elapsed();
    let stderr = String::from_utf8_lossy(&o.stderr);
    let code = o.status.code().unwrap_or(-1);
    let fail = |why: String| {
        Err(format!(
            "cases.txt:{} {}: {why}\n  command: candela {}\n  status {code} after {:.1} s\n  stderr: {}",
            c.line,
            c.name,
            c.command,
            took.as_secs_f64(),
            stderr.trim_end()
        ))
    };
    if took >= Duration::from_secs(TIMEOUT_SECONDS as u64) || code == 137 || code == -1 {
        return fail("timed out or killed".into());
    }
    if code == 101 || stderr.contains("panicked") || stderr.contains("memory allocation") {
        return fail("panicked or aborted".into());
    }
    if code != c.status {
        return fail(format!("expected status {}", c.status));
    }
    let re = regex_lite::Regex::new(&c.pattern).map_err(|e| format!("{}: {e}", c.name))?;
    if !re.is_match(&stderr) {
        return fail(format!("stderr does not match /{}/", c.pattern));
    }
    let after = snapshot(&dir);
    for (name, what) in &before {
        let may_change = c
            .post
            .split(',')
            .any(|p| p.trim() == format!("changed:{name}"));
        if !may_change && after.get(name) != Some(what) {
            return fail(format!("{name} was changed or removed"));
        }
    }
    for name in after.keys() {
        if name.contains(".tmp-") {
            return fail(format!("temporary file {name} left behind"));
        }
        if c.status != 0 && !before.contains_key(name) {
            return fail(format!("{name} was written although the run failed"));
        }
    }
    if let Err(e) = post_check(&c.post, &dir) {
        return fail(e);
    }
    let _ = fs::remove_dir_all(&dir);
    Ok(())
}

#[test]
fn every_bad_input_ends_with_a_clear_message() {
    let cases = parse_cases();
    assert!(cases.len() >= 150, "only {} cases", cases.len());
    let mut names = std::collections::HashSet::new();
    for c in &cases {
        assert!(names.insert(&c.name), "case {} twice", c.name);
    }
    let root = std::env::temp_dir().join(format!("candela-bad-input-{}", std::process::id()));
    let _ = fs::remove_dir_all(&root);
    fs::create_dir_all(&root).unwrap();
    let next = AtomicUsize::new(0);
    let failures = Mutex::new(Vec::new());
    let workers = std::thread::available_parallelism().map_or(2, |n| n.get().clamp(2, 4));
    std::thread::scope(|s| {
        for _ in 0..workers {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(c) = cases.get(i) else { break };
                if let Err(e) = run_case(c, &root) {
                    failures.lock().unwrap().push(e);
                }
            });
        }
    });
    let failures = failures.into_inner().unwrap();
    let _ = fs::remove_dir_all(&root);
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}
