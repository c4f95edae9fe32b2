//! Denoising with Intel Open Image Denoise (OIDN) 2.x, **loaded at run time**, not linked: the
//! default build needs nothing but a Rust toolchain, and without OIDN only `--denoise` fails
//! (with a message that says how to get it).
//!
//! The library is looked for in `$OIDN_DIR/lib` (and `$OIDN_DIR` itself), then on the system's
//! library path. Intel's release archives and the `pyoidn` wheel (`pip install pyoidn`: the
//! libraries are in `site-packages/pyoidn/oidn/lib`) both work.
//!
//! [`denoise`] runs OIDN's `RT` filter on an HDR image with albedo and normal auxiliaries:
//! the auxiliaries are prefiltered first (each by its own `RT` filter), then the beauty is
//! filtered with `cleanAux`, as OIDN's documentation recommends for final frames.
//!
//! Why unsafe code is allowed here: calling a C library through function pointers obtained
//! from `dlopen` is unsafe by nature. Every call passes buffers that outlive the filter
//! execution, sized `width × height × 3` f32 as declared to OIDN, and checks the device error
//! after executing.
#![allow(unsafe_code)]

use libloading::Library;
use std::ffi::{c_char, c_void, CStr};
use std::path::PathBuf;

/// Why denoising failed.
#[derive(Debug)]
pub enum DenoiseError {
    /// OIDN could not be loaded (the places tried and how to get it).
    NotFound(String),
    /// OIDN reported an error.
    Oidn(String),
    /// The buffers do not match the size.
    BadInput(String),
}

impl std::fmt::Display for DenoiseError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            DenoiseError::NotFound(s) | DenoiseError::Oidn(s) | DenoiseError::BadInput(s) => {
                f.write_str(s)
            }
        }
    }
}

impl std::error::Error for DenoiseError {}

/// How to get OIDN, for error messages.
pub const HOW_TO_GET_OIDN: &str = "get Intel Open Image Denoise 2.x from \
https://github.com/RenderKit/oidn/releases (set OIDN_DIR to the unpacked folder) or with \
`pip install pyoidn` (set OIDN_DIR to site-packages/pyoidn/oidn)";

type Device = *mut c_void;
type Filter = *mut c_void;

/// The OIDN entry points candela uses.
struct Api {
    _lib: Library,
    new_device: unsafe extern "C" fn(i32) -> Device,
    commit_device: unsafe extern "C" fn(Device),
    release_device: unsafe extern "C" fn(Device),
    device_error: unsafe extern "C" fn(Device, *mut *const c_char) -> i32,
    new_filter: unsafe extern "C" fn(Device, *const c_char) -> Filter,
    set_image: unsafe extern "C" fn(
        Filter,
        *const c_char,
        *mut c_void,
        i32,
        usize,
        usize,
        usize,
        usize,
        usize,
    ),
    set_bool: unsafe extern "C" fn(Filter, *const c_char, bool),
    commit_filter: unsafe extern "C" fn(Filter),
    execute_filter: unsafe extern "C" fn(Filter),
    release_filter: unsafe extern "C" fn(Filter),
}

/// OIDN's `OIDN_FORMAT_FLOAT3`.
const FORMAT_FLOAT3: i32 = 3;
/// OIDN's `OIDN_DEVICE_TYPE_DEFAULT`.
const DEVICE_DEFAULT: i32 = 0;

/// The library files tried, in order.
fn candidates() -> Vec<PathBuf> {
    let names = [
        "libOpenImageDenoise.so.2",
        "libOpenImageDenoise.so",
        "libOpenImageDenoise.2.dylib",
        "libOpenImageDenoise.dylib",
        "OpenImageDenoise.dll",
    ];
    let mut out = Vec::new();
    if let Some(dir) = std::env::var_os("OIDN_DIR") {
        let dir = PathBuf::from(dir);
        for sub in ["lib", "lib64", "bin", ""] {
            for n in names {
                out.push(dir.join(sub).join(n));
            }
        }
    }
    out.extend(names.iter().map(PathBuf::from));
    out
}

impl Api {
    fn load() -> Result<Api, DenoiseError> {
        let mut tried = Vec::new();
        for path in candidates() {
            // SAFETY: loading OIDN runs its initialisers, which have no preconditions.
            match unsafe { Library::new(&path) } {
                Ok(lib) => return Self::from_library(lib),
                Err(_) => tried.push(path.display().to_string()),
            }
        }
        Err(DenoiseError::NotFound(format!(
            "Intel Open Image Denoise is not installed (tried OIDN_DIR{} and the system library path): {HOW_TO_GET_OIDN}",
            if std::env::var_os("OIDN_DIR").is_some() { "" } else { " (not set)" }
        )))
    }

    fn from_library(lib: Library) -> Result<Api, DenoiseError> {
        macro_rules! sym {
            ($name:literal) => {
                // SAFETY: the symbol's type is the one OIDN 2.x declares in oidn.h.
                *unsafe { lib.get(concat!($name, "\0").as_bytes()) }.map_err(|e| {
                    DenoiseError::NotFound(format!(
                        "the OIDN library has no {} ({e}): OIDN 2.x is needed; {HOW_TO_GET_OIDN}",
                        $name
                    ))
                })?
            };
        }
        Ok(Api {
            new_device: sym!("oidnNewDevice"),
            commit_device: sym!("oidnCommitDevice"),
            release_device: sym!("oidnReleaseDevice"),
            device_error: sym!("oidnGetDeviceError"),
            new_filter: sym!("oidnNewFilter"),
            set_image: sym!("oidnSetSharedFilterImage"),
            set_bool: sym!("oidnSetFilterBool"),
            commit_filter: sym!("oidnCommitFilter"),
            execute_filter: sym!("oidnExecuteFilter"),
            release_filter: sym!("oidnReleaseFilter"),
            _lib: lib,
        })
    }
}

/// True when OIDN can be loaded.
pub fn available() -> bool {
    Api::load().is_ok()
}

/// The auxiliary images of [`denoise`]: per pixel RGB albedo and world-space normal.
#[derive(Clone, Copy)]
pub struct Auxiliaries<'a> {
    /// Albedo, 3 values per pixel.
    pub albedo: &'a [f32],
    /// Normal, 3 values per pixel.
    pub normal: &'a [f32],
}

/// Denoises `color` (HDR linear RGB, 3 values per pixel, row-major) of a `width × height`
/// image, with prefiltered auxiliaries when given. Returns the denoised image.
pub fn denoise(
    color: &[f32],
    aux: Option<Auxiliaries<'_>>,
    width: usize,
    height: usize,
) -> Result<Vec<f32>, DenoiseError> {
    let n = width * height * 3;
    if color.len() != n
        || aux
            .as_ref()
            .is_some_and(|a| a.albedo.len() != n || a.normal.len() != n)
    {
        return Err(DenoiseError::BadInput(format!(
            "the images do not have {width}×{height} RGB pixels"
        )));
    }
    let api = Api::load()?;
    // SAFETY: see the module doc: every buffer lives until the filters are released, holds
    // width × height × 3 f32 as declared, and errors are checked after each execution.
    unsafe {
        let dev = (api.new_device)(DEVICE_DEFAULT);
        if dev.is_null() {
            return Err(DenoiseError::Oidn("OIDN could not create a device".into()));
        }
        (api.commit_device)(dev);
        let result = run(&api, dev, color, aux, width, height);
        (api.release_device)(dev);
        result
    }
}

/// The filters on device `dev`.
unsafe fn run(
    api: &Api,
    dev: Device,
    color: &[f32],
    aux: Option<Auxiliaries<'_>>,
    width: usize,
    height: usize,
) -> Result<Vec<f32>, DenoiseError> {
    let check = |what: &str| -> Result<(), DenoiseError> {
        let mut msg: *const c_char = std::ptr::null();
        let code = (api.device_error)(dev, &mut msg);
        if code == 0 {
            return Ok(());
        }
        let text = if msg.is_null() {
            String::new()
        } else {
            CStr::from_ptr(msg).to_string_lossy().into_owned()
        };
        Err(DenoiseError::Oidn(format!(
            "OIDN failed {what} (error {code}): {text}"
        )))
    };
    check("to start")?;
    let set = |f: Filter, name: &CStr, buf: *mut f32| {
        (api.set_image)(
            f,
            name.as_ptr(),
            buf.cast(),
            FORMAT_FLOAT3,
            width,
            height,
            0,
            0,
            0,
        )
    };
    // One RT filter over `inputs`, into a new buffer.
    let filter = |inputs: &[(&CStr, &[f32])], flags: &[(&CStr, bool)], what: &str| {
        let f = (api.new_filter)(dev, c"RT".as_ptr());
        if f.is_null() {
            check(what)?;
            return Err(DenoiseError::Oidn("OIDN has no RT filter".into()));
        }
        let mut out = vec![0f32; width * height * 3];
        for (name, buf) in inputs {
            // OIDN only reads inputs; the pointer is mutable in its signature.
            set(f, name, buf.as_ptr() as *mut f32);
        }
        set(f, c"output", out.as_mut_ptr());
        for (name, v) in flags {
            (api.set_bool)(f, name.as_ptr(), *v);
        }
        (api.commit_filter)(f);
        (api.execute_filter)(f);
        let status = check(what);
        (api.release_filter)(f);
        status.map(|()| out)
    };
    match aux {
        None => filter(&[(c"color", color)], &[(c"hdr", true)], "denoising"),
        Some(a) => {
            let albedo = filter(&[(c"albedo", a.albedo)], &[], "prefiltering the albedo")?;
            let normal = filter(&[(c"normal", a.normal)], &[], "prefiltering the normals")?;
            filter(
                &[
                    (c"color", color),
                    (c"albedo", &albedo),
                    (c"normal", &normal),
                ],
                &[(c"hdr", true), (c"cleanAux", true)],
                "denoising",
            )
        }
    }
}
