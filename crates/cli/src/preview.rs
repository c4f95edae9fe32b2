//! `--preview`: a page on `127.0.0.1` that shows the image refining pass by pass, with exposure
//! and gamma controls, the sample count, rays/s and ETA; `/image.png` (the current image, tone
//! mapped: `?exposure=E&gamma=G`) and `/status.json` (the progress) for scripts.
//!
//! The server (`tiny_http`) runs on its own thread and only reads what the render loop
//! publishes after each pass (a copy of the image and the counters), so the render never waits
//! for it; PNGs are encoded on the server's thread, once per pass and exposure/gamma. It listens
//! on the loopback address only, while the render runs (or, with `--preview-hold`, until
//! Ctrl-C).

use crate::progress::json_string;
use anyhow::{Context, Result};
use candela_render::Image;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

/// What the page shows of the render's progress.
#[derive(Clone, Debug, Default)]
pub struct Status {
    /// `rendering`, `done` or `denoised`.
    pub state: &'static str,
    /// Samples per pixel in the image.
    pub spp_done: u32,
    /// Samples per pixel when the job is complete.
    pub spp_total: u32,
    /// Rays per second, once known.
    pub rays_per_s: Option<f64>,
    /// Seconds to go, once known.
    pub eta_s: Option<f64>,
    /// Seconds since the render started.
    pub elapsed_s: f64,
}

/// The latest image and status.
#[derive(Default)]
struct Published {
    /// Increases with every new image.
    version: u64,
    image: Option<Arc<Image>>,
    status: Status,
}

/// The PNG of one version, exposure and gamma.
type CachedPng = (u64, u32, u32, Arc<Vec<u8>>);

struct Shared {
    published: Mutex<Published>,
    png: Mutex<Option<CachedPng>>,
    stop: AtomicBool,
}

/// A running preview server.
pub struct Preview {
    shared: Arc<Shared>,
    thread: Option<JoinHandle<()>>,
    url: String,
}

impl Preview {
    /// Starts serving on `127.0.0.1:port` (a free port for `None` or 0) and prints the address.
    pub fn start(port: Option<u16>) -> Result<Preview> {
        let server = tiny_http::Server::http(("127.0.0.1", port.unwrap_or(0)))
            .map_err(|e| anyhow::anyhow!("{e}"))
            .with_context(|| {
                format!(
                    "--preview-port {}: cannot listen on 127.0.0.1",
                    port.unwrap_or(0)
                )
            })?;
        let port = server
            .server_addr()
            .to_ip()
            .map(|a| a.port())
            .context("--preview: the server has no TCP address")?;
        let url = format!("http://127.0.0.1:{port}/");
        eprintln!("preview: {url}");
        let shared = Arc::new(Shared {
            published: Mutex::new(Published {
                status: Status {
                    state: "loading",
                    ..Status::default()
                },
                ..Published::default()
            }),
            png: Mutex::new(None),
            stop: AtomicBool::new(false),
        });
        let s = shared.clone();
        let thread = std::thread::Builder::new()
            .name("preview".into())
            .spawn(move || serve(&server, &s))
            .context("--preview: cannot start the server thread")?;
        Ok(Preview {
            shared,
            thread: Some(thread),
            url,
        })
    }

    /// Shows a new image (after a pass) with its status.
    pub fn publish(&self, image: Image, status: Status) {
        if let Ok(mut p) = self.shared.published.lock() {
            p.version += 1;
            p.image = Some(Arc::new(image));
            p.status = status;
        }
    }

    /// Updates the status only (the render has started, no pass has finished).
    pub fn set_status(&self, status: Status) {
        if let Ok(mut p) = self.shared.published.lock() {
            p.status = status;
        }
    }

    /// Keeps serving until SIGINT/SIGTERM (`--preview-hold`).
    pub fn hold(&self) {
        eprintln!("preview: {} stays up until Ctrl-C", self.url);
        while !crate::session::INTERRUPTED.load(Ordering::SeqCst) {
            std::thread::sleep(Duration::from_millis(100));
        }
    }
}

impl Drop for Preview {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::SeqCst);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Answers requests until told to stop.
fn serve(server: &tiny_http::Server, shared: &Shared) {
    while !shared.stop.load(Ordering::SeqCst) {
        let request = match server.recv_timeout(Duration::from_millis(50)) {
            Ok(Some(r)) => r,
            Ok(None) => continue,
            Err(_) => break,
        };
        let url = request.url().to_string();
        let (path, query) = url.split_once('?').unwrap_or((&url, ""));
        let response = match path {
            "/" | "/index.html" => respond(PAGE.as_bytes().to_vec(), "text/html; charset=utf-8"),
            "/status.json" => respond(status_json(shared).into_bytes(), "application/json"),
            "/image.png" => match png(shared, query) {
                Some(bytes) => respond(bytes.to_vec(), "image/png"),
                None => not_found("no image yet"),
            },
            _ => not_found("not found"),
        };
        let _ = request.respond(response);
    }
}

fn respond(body: Vec<u8>, kind: &str) -> tiny_http::Response<std::io::Cursor<Vec<u8>>> {
    let mut r = tiny_http::Response::from_data(body);
    for (k, v) in [("Content-Type", kind), ("Cache-Control", "no-store")] {
        if let Ok(h) = tiny_http::Header::from_bytes(k.as_bytes(), v.as_bytes()) {
            r.add_header(h);
        }
    }
    r
}

fn not_found(why: &str) -> tiny_http::Response<std::io::Cursor<Vec<u8>>> {
    respond(why.as_bytes().to_vec(), "text/plain").with_status_code(404)
}

/// The status as JSON.
fn status_json(shared: &Shared) -> String {
    let (s, version, size) = match shared.published.lock() {
        Ok(p) => (
            p.status.clone(),
            p.version,
            p.image.as_ref().map(|i| (i.width(), i.height())),
        ),
        Err(_) => (Status::default(), 0, None),
    };
    let num = |v: Option<f64>| v.map_or("null".to_string(), |x| format!("{x:.3}"));
    let (w, h) = size.unwrap_or((0, 0));
    format!(
        "{{\"state\":{},\"pass\":{version},\"spp_done\":{},\"spp_total\":{},\"rays_per_s\":{},\"eta_s\":{},\"elapsed_s\":{:.3},\"width\":{w},\"height\":{h}}}",
        json_string(s.state),
        s.spp_done,
        s.spp_total,
        num(s.rays_per_s),
        num(s.eta_s),
        s.elapsed_s
    )
}

/// The current image as a PNG: linear radiance × 2^exposure, encoded with 1/gamma.
fn png(shared: &Shared, query: &str) -> Option<Arc<Vec<u8>>> {
    let mut exposure = 0.0f32;
    let mut gamma = 2.2f32;
    for pair in query.split('&') {
        match pair.split_once('=') {
            Some(("exposure", v)) => exposure = v.parse().unwrap_or(0.0f32).clamp(-20.0, 20.0),
            Some(("gamma", v)) => gamma = v.parse().unwrap_or(2.2f32).clamp(0.2, 5.0),
            _ => {}
        }
    }
    let (version, image) = {
        let p = shared.published.lock().ok()?;
        (p.version, p.image.clone()?)
    };
    let key = (version, exposure.to_bits(), gamma.to_bits());
    if let Ok(cache) = shared.png.lock() {
        if let Some((v, e, g, bytes)) = cache.as_ref() {
            if (*v, *e, *g) == key {
                return Some(bytes.clone());
            }
        }
    }
    let scale = 2f32.powf(exposure);
    let inv = 1.0 / gamma;
    let rgb: Vec<u8> = image
        .pixels()
        .iter()
        .flat_map(|p| [p.r, p.g, p.b])
        .map(|v| {
            let v = (v * scale).clamp(0.0, 1.0);
            let v = if v.is_finite() { v.powf(inv) } else { 0.0 };
            (v * 255.0 + 0.5) as u8
        })
        .collect();
    let bytes =
        Arc::new(candela_imageio::png::write_png(image.width(), image.height(), &rgb).ok()?);
    if let Ok(mut cache) = shared.png.lock() {
        *cache = Some((key.0, key.1, key.2, bytes.clone()));
    }
    Some(bytes)
}

/// The page: the image, exposure and gamma sliders, and the status line.
const PAGE: &str = r#"<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>candela preview</title>
<style>
body { background: #1e1e1e; color: #ddd; font: 14px system-ui, sans-serif; margin: 16px; }
#bar { display: flex; gap: 24px; align-items: center; flex-wrap: wrap; margin-bottom: 12px; }
#status { font-variant-numeric: tabular-nums; }
img { image-rendering: pixelated; max-width: 100%; border: 1px solid #444; background: #000; }
</style></head>
<body>
<div id="bar">
  <strong>candela</strong>
  <span id="status">waiting for the first pass…</span>
  <label>exposure <input id="exposure" type="range" min="-6" max="6" step="0.1" value="0">
    <span id="ev">0.0</span></label>
  <label>gamma <input id="gamma" type="range" min="1" max="3" step="0.05" value="2.2">
    <span id="gv">2.20</span></label>
</div>
<img id="image" alt="the render">
<script>
"use strict";
let pass = -1;
const $ = (id) => document.getElementById(id);
function src() {
  return "/image.png?exposure=" + $("exposure").value + "&gamma=" + $("gamma").value + "&pass=" + pass;
}
function fmt(x) {
  if (x === null) return "?";
  if (x >= 1e9) return (x / 1e9).toFixed(2) + " G";
  if (x >= 1e6) return (x / 1e6).toFixed(2) + " M";
  if (x >= 1e3) return (x / 1e3).toFixed(1) + " k";
  return x.toFixed(0) + " ";
}
function time(s) {
  if (s === null) return "?";
  return s >= 60 ? Math.floor(s / 60) + " min " + Math.round(s % 60) + " s" : s.toFixed(1) + " s";
}
async function tick() {
  try {
    const r = await fetch("/status.json", { cache: "no-store" });
    const s = await r.json();
    $("status").textContent = s.state + " · " + s.spp_done + " / " + s.spp_total + " spp · " +
      fmt(s.rays_per_s) + "rays/s · ETA " + time(s.eta_s) + " · " + time(s.elapsed_s) + " elapsed";
    if (s.pass !== pass && s.pass > 0) { pass = s.pass; $("image").src = src(); }
    setTimeout(tick, 400);
  } catch (e) {
    $("status").textContent += " · the render has finished (server stopped)";
  }
}
for (const id of ["exposure", "gamma"]) {
  $(id).addEventListener("input", () => {
    $("ev").textContent = Number($("exposure").value).toFixed(1);
    $("gv").textContent = Number($("gamma").value).toFixed(2);
    if (pass > 0) $("image").src = src();
  });
}
tick();
</script>
</body></html>
"#;
