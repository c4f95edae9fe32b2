//! `candela convert IN OUT`: between PFM, OpenEXR, Radiance HDR and PNG, tone mapping for PNG
//! outputs (`-` as OUT: a PNG on standard output).

use crate::args::ConvertArgs;
use anyhow::Result;

/// Runs the conversion (the options were checked by [`crate::inputs::validate`]).
pub fn run(a: ConvertArgs) -> Result<()> {
    let limits = candela_imageio::Limits::from_memory(crate::inputs::max_memory(a.max_memory));
    let img = candela_imageio::read_image_within(&a.input, &limits)?;
    crate::outputs::write_all(
        std::slice::from_ref(&a.output),
        &img,
        &crate::images::tone_map(&a.tone, 1.0),
    )
}
