//! The live preview (issue 18): while a render runs, `/`, `/status.json` and `/image.png` are
//! served on 127.0.0.1 and the image changes as passes arrive; the server ends with the render.

mod support;

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// GET `path` from `port`: the status code and the body.
fn get(port: u16, path: &str) -> Option<(u16, Vec<u8>)> {
    let mut s = TcpStream::connect(("127.0.0.1", port)).ok()?;
    s.set_read_timeout(Some(Duration::from_secs(10))).ok()?;
    write!(s, "GET {path} HTTP/1.0\r\nHost: localhost\r\n\r\n").ok()?;
    let mut raw = Vec::new();
    s.read_to_end(&mut raw).ok()?;
    let split = raw.windows(4).position(|w| w == b"\r\n\r\n")?;
    let head = String::from_utf8_lossy(&raw[..split]).into_owned();
    let code = head.split_whitespace().nth(1)?.parse().ok()?;
    Some((code, raw[split + 4..].to_vec()))
}

/// The number after `"key":` in a JSON object.
fn field(json: &str, key: &str) -> Option<f64> {
    let at = json.find(&format!("\"{key}\":"))? + key.len() + 3;
    let rest = &json[at..];
    let end = rest.find([',', '}']).unwrap_or(rest.len());
    rest[..end].trim().parse().ok()
}

#[test]
fn the_preview_serves_the_refining_image_while_the_render_runs() {
    let dir = support::scratch("preview");
    let out = dir.join("p.pfm");
    let mut child = Command::new(env!("CARGO_BIN_EXE_candela"))
        .args([
            "demo", "-q", "--width", "240", "--height", "160", "--spp", "512",
        ])
        .args(["--preview", "-o", out.to_str().unwrap()])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // The address comes first on stderr.
    let mut err = BufReader::new(child.stderr.take().unwrap());
    let mut line = String::new();
    err.read_line(&mut line).unwrap();
    let port: u16 = line
        .trim()
        .strip_prefix("preview: http://127.0.0.1:")
        .and_then(|s| s.strip_suffix('/'))
        .unwrap_or_else(|| panic!("no address in {line:?}"))
        .parse()
        .unwrap();

    let (code, page) = get(port, "/").unwrap();
    assert_eq!(code, 200);
    let page = String::from_utf8(page).unwrap();
    for part in [
        "exposure",
        "gamma",
        "status.json",
        "image.png",
        "rays/s",
        "ETA",
    ] {
        assert!(page.contains(part), "the page has {part}");
    }
    assert_eq!(get(port, "/nothing").unwrap().0, 404);

    // Two images from different passes differ; the status follows the samples.
    let start = Instant::now();
    let mut seen: Vec<(f64, Vec<u8>)> = Vec::new();
    while seen.len() < 2 && start.elapsed() < Duration::from_secs(60) {
        let Some((200, status)) = get(port, "/status.json") else {
            break;
        };
        let status = String::from_utf8(status).unwrap();
        assert!(status.contains("\"state\":"), "{status}");
        let pass = field(&status, "pass").unwrap();
        if status.contains("\"state\":\"loading\"") {
            // The server answers before the scene is loaded: nothing is known yet.
            assert_eq!(pass, 0.0, "{status}");
            std::thread::sleep(Duration::from_millis(20));
            continue;
        }
        assert_eq!(field(&status, "spp_total"), Some(512.0), "{status}");
        if pass > 0.0 && seen.last().is_none_or(|(p, _)| *p != pass) {
            let (code, png) = get(port, "/image.png").unwrap();
            assert_eq!(code, 200);
            assert_eq!(&png[1..4], b"PNG");
            let done = field(&status, "spp_done").unwrap();
            assert!(done > 0.0 && done <= 512.0, "{status}");
            seen.push((pass, png));
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    assert_eq!(seen.len(), 2, "two passes seen while rendering");
    assert_ne!(seen[0].1, seen[1].1, "the image changes as samples arrive");
    // Exposure changes the served image.
    let bright = get(port, "/image.png?exposure=2&gamma=1.8").unwrap().1;
    assert_ne!(bright, get(port, "/image.png").unwrap().1);

    let status = child.wait().unwrap();
    assert!(status.success());
    assert!(out.exists());
    // The server ends with the render.
    assert!(get(port, "/status.json").is_none());
}
