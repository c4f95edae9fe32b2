//! `candela convert IN OUT`: between PFM, OpenEXR and PNG, tone mapping for PNG outputs.

use crate::args::ConvertArgs;
use anyhow::{bail, Context, Result};

/// Runs the conversion.
pub fn run(a: ConvertArgs) -> Result<()> {
    if !candela_imageio::supported_extension(&a.output) {
        bail!(
            "'{}': unknown output format (use .png, .pfm or .exr)",
            a.output.display()
        );
    }
    let img = candela_imageio::read_image(&a.input)
        .with_context(|| format!("reading '{}'", a.input.display()))?;
    candela_imageio::write_image(&a.output, &img, &crate::images::tone_map(&a.tone, 1.0))
        .with_context(|| format!("writing '{}'", a.output.display()))?;
    Ok(())
}
