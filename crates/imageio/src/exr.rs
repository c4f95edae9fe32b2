//! OpenEXR through the `exr` crate.
//!
//! Reading takes the full-resolution level of the first layer that has an `R`, `G` or `B`
//! channel; failing that, the first layer with a `Y` (luminance) channel, whose value is
//! replicated to all three channels. Channels that are missing (or subsampled) read as 0;
//! alpha and other channels are ignored. Samples may be f16, f32 or u32. Pixel `(0, 0)` is
//! the top-left corner of the data window, as in [`Image`].
//!
//! Writing produces a single-layer scan-line file with f32 `R`, `G`, `B` channels, no alpha,
//! and lossless compression.

use std::io::Cursor;

use ::exr::prelude::{
    traits::*, AnyChannel, AnyChannels, Encoding, FlatSamples, Image as ExrImage, Layer,
    LayerAttributes,
};
use candela_render::{Image, Rgb};

use crate::{check_size, image_from_pixels, ImageError, Limits};

/// A decoded layer with all its channels.
type FlatLayer = Layer<AnyChannels<FlatSamples>>;

/// Decodes an OpenEXR file held in memory, within the default [`Limits`].
pub fn read_exr(bytes: &[u8]) -> Result<Image, ImageError> {
    read_exr_within(bytes, &Limits::default())
}

/// Decodes an OpenEXR file held in memory, refusing (from its headers, before any pixel is
/// decoded) a file whose layers hold more than `limits` allow.
pub fn read_exr_within(bytes: &[u8], limits: &Limits) -> Result<Image, ImageError> {
    check_exr_limits(bytes, limits)?;
    read_checked_exr(bytes)
}

/// Fails, from the headers, when the layers of the OpenEXR file `bytes` hold more than
/// `limits` allow to decode.
fn check_exr_limits(bytes: &[u8], limits: &Limits) -> Result<(), ImageError> {
    let meta =
        ::exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false).map_err(|cause| {
            ImageError::Exr {
                action: "decode",
                cause,
            }
        })?;
    let mut samples = 0u64;
    for header in meta.headers.iter() {
        let size = header.layer_size;
        limits
            .check_pixels(size.width() as u64, size.height() as u64)
            .map_err(|reason| ImageError::Limit { reason })?;
        let channels = header.channels.list.len().max(1) as u64;
        samples = samples.saturating_add(size.area() as u64 * channels);
    }
    // Every channel of every layer is decoded (4 bytes a sample at most).
    if samples.saturating_mul(4) > limits.max_memory / 2 {
        return Err(ImageError::Limit {
            reason: format!(
                "the OpenEXR layers hold {samples} samples, more than half of --max-memory {} can decode",
                limits.max_memory
            ),
        });
    }
    Ok(())
}

/// Decodes an OpenEXR file whose size was checked.
fn read_checked_exr(bytes: &[u8]) -> Result<Image, ImageError> {
    let decoded = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(|cause| ImageError::Exr {
            action: "decode",
            cause,
        })?;
    let layers = &decoded.layer_data;
    let with_any = |names: &[&str]| {
        layers
            .iter()
            .find(|layer| names.iter().any(|name| channel(layer, name).is_some()))
    };
    let layer = with_any(&["R", "G", "B"])
        .or_else(|| with_any(&["Y"]))
        .ok_or_else(|| ImageError::ExrNoColour {
            found: channel_names(layers.first()),
        })?;

    let [r, g, b] = match ["R", "G", "B"].map(|name| channel(layer, name)) {
        [None, None, None] => [channel(layer, "Y"); 3],
        rgb => rgb,
    };
    let sample = |c: Option<&FlatSamples>, i| c.map_or(0.0, |s| s.value_by_flat_index(i).to_f32());
    let (width, height) = (layer.size.width(), layer.size.height());
    let pixels = (0..width * height).map(|i| Rgb::new(sample(r, i), sample(g, i), sample(b, i)));
    Ok(image_from_pixels(width, height, pixels))
}

/// Encodes `img` as an OpenEXR file with f32 RGB channels.
pub fn write_exr(img: &Image) -> Result<Vec<u8>, ImageError> {
    write_exr_layers(img, &[])
}

/// Extra per-pixel data written beside the colour: arbitrary output variables.
#[derive(Clone, Debug, PartialEq)]
pub struct AovLayer {
    /// The layer's name (`albedo`, `normal`, …).
    pub name: String,
    /// Its channel names (`R`, `G`, `B`; `X`, `Y`, `Z`; …).
    pub channels: Vec<String>,
    /// Per pixel (top row first), one value per channel.
    pub data: Vec<f32>,
}

/// Encodes `img` with f32 `R`, `G`, `B` channels and, for each layer, channels named
/// `layer.channel` (the OpenEXR layer convention that Nuke, Blender and Mitsuba read).
pub fn write_exr_layers(img: &Image, layers: &[AovLayer]) -> Result<Vec<u8>, ImageError> {
    check_size(img.width(), img.height())?;
    let n = img.width() * img.height();
    let mut list = Vec::new();
    for (k, name) in ["R", "G", "B"].into_iter().enumerate() {
        let v: Vec<f32> = img.pixels().iter().map(|p| [p.r, p.g, p.b][k]).collect();
        list.push(AnyChannel::new(name, FlatSamples::F32(v)));
    }
    for layer in layers {
        let c = layer.channels.len();
        if c == 0 || layer.data.len() != n * c {
            return Err(ImageError::EmptyImage {
                width: layer.data.len(),
                height: c,
            });
        }
        for (k, ch) in layer.channels.iter().enumerate() {
            let v: Vec<f32> = layer.data.iter().skip(k).step_by(c).copied().collect();
            list.push(AnyChannel::new(
                format!("{}.{ch}", layer.name).as_str(),
                FlatSamples::F32(v),
            ));
        }
    }
    let channels = AnyChannels::sort(list.into());
    let layer = Layer::new(
        (img.width(), img.height()),
        LayerAttributes::default(),
        Encoding::default(),
        channels,
    );
    let mut out = Cursor::new(Vec::new());
    ExrImage::from_layer(layer)
        .write()
        .to_buffered(&mut out)
        .map_err(|cause| ImageError::Exr {
            action: "encode",
            cause,
        })?;
    Ok(out.into_inner())
}

/// Channels by name, one value per pixel each.
pub type NamedChannels = Vec<(String, Vec<f32>)>;

/// [`read_exr_channels`] within `limits`, checked from the headers before any pixel is
/// decoded.
pub fn read_exr_channels_within(
    bytes: &[u8],
    limits: &Limits,
) -> Result<(usize, usize, NamedChannels), ImageError> {
    check_exr_limits(bytes, limits)?;
    read_exr_channels(bytes)
}

/// Every full-resolution channel of the first layer of an OpenEXR file, by name, as f32, with
/// the layer's size.
pub fn read_exr_channels(bytes: &[u8]) -> Result<(usize, usize, NamedChannels), ImageError> {
    let decoded = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(|cause| ImageError::Exr {
            action: "decode",
            cause,
        })?;
    let layer = &decoded.layer_data;
    let (w, h) = (layer.size.width(), layer.size.height());
    let channels = layer
        .channel_data
        .list
        .iter()
        .filter(|c| c.sample_data.len() == w * h)
        .map(|c| {
            let v = (0..w * h)
                .map(|i| c.sample_data.value_by_flat_index(i).to_f32())
                .collect();
            (c.name.to_string(), v)
        })
        .collect();
    Ok((w, h, channels))
}

/// The samples of the channel called `name`, if it has one sample per pixel.
fn channel<'a>(layer: &'a FlatLayer, name: &str) -> Option<&'a FlatSamples> {
    let pixels = layer.size.width().checked_mul(layer.size.height());
    layer
        .channel_data
        .list
        .iter()
        .find(|c| c.name.eq(name))
        .map(|c| &c.sample_data)
        .filter(|s| Some(s.len()) == pixels)
}

/// The channel names of `layer`, for error messages.
fn channel_names(layer: Option<&FlatLayer>) -> String {
    let names: Vec<String> = layer
        .into_iter()
        .flat_map(|l| &l.channel_data.list)
        .map(|c| c.name.to_string())
        .collect();
    if names.is_empty() {
        "none".into()
    } else {
        names.join(", ")
    }
}

#[cfg(test)]
mod tests {
    use ::exr::prelude::{
        f16, Encoding, ImageAttributes, IntegerBounds, LayerAttributes, SpecificChannels, Vec2,
    };

    use super::*;

    /// A 3×2 image with distinct HDR values, including a negative one and fractions.
    fn sample_image() -> Image {
        let mut img = Image::new(3, 2);
        for (i, p) in img.pixels_mut().iter_mut().enumerate() {
            let i = i as f32;
            *p = Rgb::new(i * 1000.5, -i / 7.0, i + 0.25);
        }
        img
    }

    /// Encodes a layer built by the caller.
    fn encode<C>(channels: C) -> Vec<u8>
    where
        C: for<'s> ::exr::image::write::channels::WritableChannels<'s>,
    {
        let mut out = Cursor::new(Vec::new());
        ExrImage::from_channels((2, 1), channels)
            .write()
            .to_buffered(&mut out)
            .unwrap();
        out.into_inner()
    }

    #[test]
    fn round_trips_exactly_in_memory() {
        let img = sample_image();
        assert_eq!(read_exr(&write_exr(&img).unwrap()).unwrap(), img);
    }

    #[test]
    fn round_trips_through_a_temporary_file() {
        let path =
            std::env::temp_dir().join(format!("candela-imageio-exr-{}.exr", std::process::id()));
        let img = sample_image();
        std::fs::write(&path, write_exr(&img).unwrap()).unwrap();
        let back = read_exr(&std::fs::read(&path).unwrap());
        std::fs::remove_file(&path).unwrap();
        assert_eq!(back.unwrap(), img);
    }

    #[test]
    fn grey_files_are_replicated_and_missing_channels_are_zero() {
        let y = SpecificChannels::build()
            .with_channel("Y")
            .with_pixel_fn(|Vec2(x, _)| (x as f32 + 0.5,));
        let img = read_exr(&encode(y)).unwrap();
        assert_eq!(img.pixels(), [Rgb::splat(0.5), Rgb::splat(1.5)]);

        // Red only (as f16) plus alpha: green and blue are 0, alpha is ignored.
        let ra = SpecificChannels::build()
            .with_channel("A")
            .with_channel("R")
            .with_pixel_fn(|Vec2(x, _)| (0.25f32, f16::from_f32(x as f32 + 2.0)));
        let img = read_exr(&encode(ra)).unwrap();
        assert_eq!(
            img.pixels(),
            [Rgb::new(2.0, 0.0, 0.0), Rgb::new(3.0, 0.0, 0.0)]
        );
    }

    #[test]
    fn reads_the_first_layer_with_colour() {
        let size = Vec2(2, 1);
        let depth = Layer::new(
            size,
            LayerAttributes::named("depth"),
            Encoding::FAST_LOSSLESS,
            SpecificChannels::build()
                .with_channel("Z")
                .with_pixel_fn(|_| (9.0f32,)),
        );
        let colour = Layer::new(
            size,
            LayerAttributes::named("colour"),
            Encoding::FAST_LOSSLESS,
            SpecificChannels::rgba(|Vec2(x, _)| (x as f32, 2.0f32, 3.0f32, 0.5f32)),
        );
        let image = ExrImage::empty(ImageAttributes::new(IntegerBounds::from_dimensions(size)))
            .with_layer(depth)
            .with_layer(colour);
        let mut out = Cursor::new(Vec::new());
        image.write().to_buffered(&mut out).unwrap();
        let img = read_exr(&out.into_inner()).unwrap();
        assert_eq!(
            img.pixels(),
            [Rgb::new(0.0, 2.0, 3.0), Rgb::new(1.0, 2.0, 3.0)]
        );
    }

    #[test]
    fn rejects_bad_input() {
        let z = SpecificChannels::build()
            .with_channel("Z")
            .with_pixel_fn(|_| (1.0f32,));
        let err = read_exr(&encode(z)).unwrap_err();
        assert!(matches!(err, ImageError::ExrNoColour { .. }), "{err}");
        assert!(err.to_string().contains("channels found: Z"), "{err}");

        let err = read_exr(b"definitely not an EXR file").unwrap_err();
        assert!(
            matches!(
                err,
                ImageError::Exr {
                    action: "decode",
                    ..
                }
            ),
            "{err}"
        );
        let good = write_exr(&sample_image()).unwrap();
        for len in [0, 4, 50, good.len() / 2, good.len() - 1] {
            assert!(read_exr(&good[..len]).is_err(), "{len}");
        }

        assert!(matches!(
            write_exr(&Image::new(0, 4)),
            Err(ImageError::EmptyImage { .. })
        ));
    }
}
