//! Loading a scene file of either format, and the built-in demo scene.

use crate::builder::build_scene;
use crate::error::SceneError;
use crate::lang::parse_scene;
use crate::loaded::{LoadOptions, LoadedScene, RenderHints, STDIN_NAME};
use candela_imageio::Limits;
use std::collections::HashMap;
use std::path::Path;

/// Loads a scene file: Mitsuba 3 XML when the extension is `.xml`, the candela language
/// otherwise.
pub fn load_scene(path: &Path, opts: &LoadOptions) -> Result<LoadedScene, SceneError> {
    let (loaded, inputs) = crate::inputs::collecting(|| load_scene_file(path, opts));
    let mut loaded = loaded?;
    loaded.inputs = inputs;
    Ok(loaded)
}

fn load_scene_file(path: &Path, opts: &LoadOptions) -> Result<LoadedScene, SceneError> {
    crate::inputs::record(path);
    let text = read_scene_text(path, &opts.limits)?;
    let is_xml = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("xml"));
    let mut loaded = if is_xml {
        crate::mitsuba::load_mitsuba(path, &text, opts)
    } else {
        load_candela(path, &text, opts, RenderHints::default())
    }?;
    loaded.inputs.insert(0, path.to_path_buf());
    Ok(loaded)
}

/// Reads a whole scene from standard input: at most `limits.max_file_bytes` bytes (the limit of
/// scene files; more is refused without reading further), not empty, in UTF-8 (an invalid byte
/// is reported at its line and column of `<stdin>`).
pub fn read_stdin_scene(limits: &Limits) -> Result<String, SceneError> {
    use candela_imageio::input::InputError;
    let bytes = candela_imageio::input::read_stdin(limits.max_file_bytes).map_err(|e| {
        SceneError::new(
            STDIN_NAME,
            match e {
                InputError::TooLarge { max, .. } => format!(
                    "standard input holds more than {max} bytes, the limit of a scene file (a quarter of --max-memory)"
                ),
                e => format!("cannot read the scene from standard input: {e}"),
            },
        )
    })?;
    if bytes.is_empty() {
        return Err(SceneError::new(
            STDIN_NAME,
            "standard input is empty: no scene to render",
        ));
    }
    String::from_utf8(bytes).map_err(|e| SceneError::invalid_utf8(STDIN_NAME, &e))
}

/// True when `text` is Mitsuba XML: its first character other than white space (after a
/// byte-order mark) is `<` (no statement of the candela language starts with one).
pub fn is_xml_text(text: &str) -> bool {
    text.trim_start_matches('\u{feff}')
        .trim_start()
        .starts_with('<')
}

/// Loads a scene read from standard input ([`read_stdin_scene`]): Mitsuba 3 XML when
/// [`is_xml_text`], the candela language otherwise. Messages name it `<stdin>`, and the files it
/// names (meshes, images, includes) are found relative to the current directory. The inputs
/// of the result are the files it read (no scene file).
pub fn load_scene_text(text: &str, opts: &LoadOptions) -> Result<LoadedScene, SceneError> {
    let path = Path::new(STDIN_NAME);
    let (loaded, inputs) = crate::inputs::collecting(|| {
        if is_xml_text(text) {
            crate::mitsuba::load_mitsuba(path, text, opts)
        } else {
            load_candela(path, text, opts, RenderHints::default())
        }
    });
    let mut loaded = loaded?;
    loaded.inputs = inputs;
    Ok(loaded)
}

/// Reads a scene file: a regular file within the size limit, in UTF-8 (an invalid byte is
/// reported at its line and column).
pub fn read_scene_text(path: &Path, limits: &Limits) -> Result<String, SceneError> {
    let bytes = candela_imageio::input::read_file(path, limits.max_file_bytes)
        .map_err(|e| SceneError::new(path, format!("cannot read the scene file: {e}")))?;
    String::from_utf8(bytes).map_err(|e| SceneError::invalid_utf8(path, &e))
}

/// The `-d` overrides as numbers (the candela language only has float variables).
fn numeric_defines(
    path: &Path,
    defines: &[(String, String)],
) -> Result<HashMap<String, f32>, SceneError> {
    let mut out = HashMap::new();
    for (name, value) in defines {
        match value.trim().parse::<f32>() {
            Ok(v) if v.is_finite() => {
                out.insert(name.clone(), v);
            }
            _ => {
                return Err(SceneError::new(
                    path,
                    format!("--define {name}={value}: '{value}' is not a finite number"),
                ));
            }
        }
    }
    Ok(out)
}

fn load_candela(
    path: &Path,
    text: &str,
    opts: &LoadOptions,
    mut hints: RenderHints,
) -> Result<LoadedScene, SceneError> {
    let defines = numeric_defines(path, &opts.defines)?;
    let desc = parse_scene(text, path, &defines)?;
    if let Some((filter, _)) = desc.filter {
        hints.filter = Some(filter);
    }
    let (scene, report) = build_scene(&desc, opts.accel, &opts.limits)?;
    Ok(LoadedScene {
        scene,
        hints,
        warnings: report.warnings,
        mesh_stats: report.bytes_per_triangle.map(|b| (report.triangles, b)),
        local_model_terms: report.local_model_terms,
        inputs: report.inputs,
    })
}

/// The source of the built-in demo scene (candela language).
pub const DEMO_SCENE: &str = include_str!("demo.scene");

/// The built-in demo scene: path traced at 16 samples per pixel unless told otherwise.
pub fn demo_scene(opts: &LoadOptions) -> Result<LoadedScene, SceneError> {
    let hints = RenderHints {
        spp: Some(16),
        integrator: Some("path".to_string()),
        ..RenderHints::default()
    };
    load_candela(Path::new("<demo>"), DEMO_SCENE, opts, hints)
}
