//! Feeds arbitrary bytes to the EXR decoder, within small limits (an image of a few megabytes):
//! it must return an image or an error, never panic or allocate beyond the limits.
#![no_main]

use candela_imageio::{Format, Limits};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    let limits = Limits::from_memory(64 << 20);
    if let Err(e) = Format::Exr.decode_within(bytes, &limits) {
        let _ = e.to_string();
    }
});
