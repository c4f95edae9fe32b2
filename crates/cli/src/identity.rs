//! What a partial render must agree on to be merged with another: the scene (a hash of the
//! contents of every file it loads) and the settings that change pixels.

use crate::args::RenderArgs;
use candela_render::integrator::{IntegratorKind, IntegratorSettings};
use candela_render::render::RenderSettings;
use sha2::{Digest, Sha256};
use std::path::PathBuf;

/// The SHA-256 (hex) of the scene's `text` when it is not a file (the built-in demo, a scene
/// read from standard input), then of the contents of `inputs` (the scene file and every file
/// it loads), in order, each prefixed by its length. File names are left out, so the same
/// files at other paths (another machine's mount point) hash the same, and a scene read from
/// standard input hashes as the same text in a file.
pub fn scene_hash(text: Option<&str>, inputs: &[PathBuf]) -> std::io::Result<String> {
    let mut h = Sha256::new();
    if let Some(text) = text {
        h.update((text.len() as u64).to_le_bytes());
        h.update(text.as_bytes());
    }
    for path in inputs {
        let bytes = std::fs::read(path)?;
        h.update((bytes.len() as u64).to_le_bytes());
        h.update(&bytes);
    }
    Ok(h.finalize()
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect::<String>())
}

/// The settings that change pixels, besides the image size, spp, crop and sample range
/// (which a partial file records on its own), in a fixed order.
pub fn pixel_settings(
    args: &RenderArgs,
    defines: &[(String, String)],
    settings: &RenderSettings,
    kind: IntegratorKind,
    integrator: &IntegratorSettings,
) -> Vec<(String, String)> {
    let mut s = vec![
        ("candela".to_string(), env!("CARGO_PKG_VERSION").to_string()),
        ("seed".to_string(), settings.seed.to_string()),
        ("sampler".to_string(), format!("{:?}", settings.sampler)),
        ("filter".to_string(), format!("{:?}", settings.filter)),
        ("spectral".to_string(), settings.spectral.to_string()),
        ("integrator".to_string(), format!("{kind:?}")),
        (
            "max_depth".to_string(),
            format!("{:?}", integrator.max_depth),
        ),
        (
            "num_of_rays".to_string(),
            integrator.num_of_rays.to_string(),
        ),
        ("rr_depth".to_string(), format!("{:?}", integrator.rr_depth)),
        (
            "hide_emitters".to_string(),
            integrator.hide_emitters.to_string(),
        ),
        (
            "accel".to_string(),
            args.accel.clone().unwrap_or_else(|| "default".into()),
        ),
    ];
    let aovs: Vec<&str> = settings.aovs.iter().map(|a| a.name()).collect();
    s.push(("aovs".to_string(), aovs.join(",")));
    let defines: Vec<String> = defines.iter().map(|(k, v)| format!("{k}={v}")).collect();
    s.push(("defines".to_string(), defines.join(";")));
    if kind == IntegratorKind::Radiosity {
        let r = &integrator.radiosity;
        s.push((
            "radiosity".to_string(),
            format!(
                "patch_size={:?} form_factors={:?} solver={:?}",
                r.patch_size, r.form_factors, r.solver
            ),
        ));
    }
    s
}
