//! Arbitrary output variables: what the camera sees besides radiance, averaged over a pixel's
//! samples like the image (`--aov`; layers of the OpenEXR output, the denoiser's auxiliaries).
//!
//! Albedo and normal follow Intel Open Image Denoise's definitions: they are taken at the first
//! hit that is not a perfect mirror or smooth glass, following such surfaces (mirrors reflect,
//! glass refracts unless the light is totally reflected) for up to [`SPECULAR_CHAIN`] bounces;
//! the albedo is the material's main colour there (an emitter's: the colour of its emission,
//! scaled to a maximum of 1), the normal the world-space shading normal
//! facing the ray. Depth, position, uv and shape are those of the camera ray's first hit
//! (depth as the distance along the ray; shape as the shape's index, objects first, then
//! meshes); emission is the radiance the first hit emits towards the camera (what a path
//! tracer adds at its first vertex: the denoiser leaves it out and adds it back, so that
//! directly seen lights stay exact). Where a ray escapes, every value is 0.

use crate::interaction::SurfaceInteraction;
use crate::math::Ray;
use crate::scene::Scene;
use crate::spectrum::Wavelengths;
use crate::stats::RayStats;

/// Longest chain of mirror and glass bounces followed for albedo and normal.
pub const SPECULAR_CHAIN: usize = 8;

/// One output variable.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Aov {
    /// Reflectance at the first non-specular hit (`albedo.R/G/B`).
    Albedo,
    /// World-space shading normal at the first non-specular hit (`normal.X/Y/Z`).
    Normal,
    /// Distance to the first hit (`depth.Z`).
    Depth,
    /// World-space position of the first hit (`position.X/Y/Z`).
    Position,
    /// Texture coordinates of the first hit (`uv.U/V`).
    Uv,
    /// Index of the first hit's shape (`shape.Y`).
    Shape,
    /// Radiance emitted by the first hit towards the camera (`emission.R/G/B`).
    Emission,
    /// The same, antialiased: at the edges of lights (where a pixel's footprint sees both a
    /// light and something else) each sample traces [`EDGE_RAYS`] stratified camera rays for it
    /// (`emission_aa.R/G/B`). The denoiser adds this back instead of `emission`.
    EmissionAa,
}

/// Camera rays per sample for [`Aov::EmissionAa`] at the edges of lights.
pub const EDGE_RAYS: u32 = 16;

/// True when the footprint of a pixel, widened by 0.4 pixel on every side (so that a light
/// covering a sliver of the pixel is seen in the neighbour), sees an emitter in some places and
/// not in others: probes on a 6 × 6 grid of `extent` pixels around the pixel's centre
/// (`ray_at` gives the camera ray through a point of the image plane, in pixels from the
/// pixel's corner).
pub fn near_light_edge(
    scene: &Scene,
    extent: f32,
    ray_at: &mut dyn FnMut([f32; 2]) -> Ray,
    stats: &mut RayStats,
) -> bool {
    let (mut lit, mut dark) = (false, false);
    let half = 0.5 * extent + 0.4;
    for k in 0..36 {
        let at = |i: usize| 0.5 - half + 2.0 * half * i as f32 / 5.0;
        let ray = ray_at([at(k % 6), at(k / 6)]);
        let emits = scene.interact(&ray, stats).is_some_and(|si| {
            scene
                .emitted(&si, &Wavelengths::Rgb)
                .to_rgb()
                .max_component()
                > 0.0
        });
        lit |= emits;
        dark |= !emits;
    }
    lit && dark
}

/// The filter-weighted emission seen by [`EDGE_RAYS`] camera rays at stratified points of the
/// filter's square, jittered by `key` (a hash of the pixel and the sample), averaged.
pub fn emission_aa(
    scene: &Scene,
    ray_at: &mut dyn FnMut([f32; 2]) -> (Ray, f32),
    key: u64,
    stats: &mut RayStats,
) -> [f32; 3] {
    let side = (EDGE_RAYS as f32).sqrt() as u32;
    let mut sum = [0.0f32; 3];
    for k in 0..EDGE_RAYS {
        let h = crate::sampling::pcg::hash2(key, k as u64);
        let [jx, jy] = crate::sampling::pcg::unit_pair(h);
        let u = [
            ((k % side) as f32 + jx) / side as f32,
            ((k / side) as f32 + jy) / side as f32,
        ];
        let (ray, w) = ray_at(u);
        if let Some(si) = scene.interact(&ray, stats) {
            let e = scene.emitted(&si, &Wavelengths::Rgb).to_rgb() * w;
            sum[0] += e.r;
            sum[1] += e.g;
            sum[2] += e.b;
        }
    }
    sum.map(|v| v / EDGE_RAYS as f32)
}

impl Aov {
    /// Every output variable, in output order.
    pub const ALL: [Aov; 8] = [
        Aov::Albedo,
        Aov::Normal,
        Aov::Depth,
        Aov::Position,
        Aov::Uv,
        Aov::Shape,
        Aov::Emission,
        Aov::EmissionAa,
    ];

    /// The name of the variable (`--aov` and the layer name).
    pub fn name(self) -> &'static str {
        match self {
            Aov::Albedo => "albedo",
            Aov::Normal => "normal",
            Aov::Depth => "depth",
            Aov::Position => "position",
            Aov::Uv => "uv",
            Aov::Shape => "shape",
            Aov::Emission => "emission",
            Aov::EmissionAa => "emission_aa",
        }
    }

    /// The variable named `name`.
    pub fn from_name(name: &str) -> Option<Aov> {
        Self::ALL.into_iter().find(|a| a.name() == name)
    }

    /// The channel names within the layer (OpenEXR convention: `layer.channel`).
    pub fn channels(self) -> &'static [&'static str] {
        match self {
            Aov::Albedo | Aov::Emission | Aov::EmissionAa => &["R", "G", "B"],
            Aov::Normal | Aov::Position => &["X", "Y", "Z"],
            Aov::Depth => &["Z"],
            Aov::Uv => &["U", "V"],
            Aov::Shape => &["Y"],
        }
    }
}

/// A set of output variables (kept in [`Aov::ALL`] order).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct AovSet(u8);

impl AovSet {
    /// No variables.
    pub const NONE: AovSet = AovSet(0);

    /// The set with `aov` added.
    pub fn with(self, aov: Aov) -> AovSet {
        AovSet(self.0 | 1 << Aov::ALL.iter().position(|&a| a == aov).unwrap_or(0))
    }

    /// True when `aov` is in the set.
    pub fn contains(self, aov: Aov) -> bool {
        self.iter().any(|a| a == aov)
    }

    /// True when the set is empty.
    pub fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// The variables, in output order.
    pub fn iter(self) -> impl Iterator<Item = Aov> {
        Aov::ALL
            .into_iter()
            .enumerate()
            .filter(move |(i, _)| self.0 & (1 << i) != 0)
            .map(|(_, a)| a)
    }

    /// Values per sample of all the variables.
    pub fn channels(self) -> usize {
        self.iter().map(|a| a.channels().len()).sum()
    }
}

/// Writes the variables of `set` seen along the camera ray `ray` into `out` (in order,
/// [`AovSet::channels`] values).
pub fn aov_sample(scene: &Scene, ray: &Ray, set: AovSet, out: &mut [f32], stats: &mut RayStats) {
    out.fill(0.0);
    let Some(hit) = scene.intersect(ray, stats) else {
        return;
    };
    let first = scene.geometry.interaction(ray, &hit);
    // The first hit that is not a perfect mirror or smooth glass.
    let mut diffuse: Option<SurfaceInteraction> = None;
    if set.contains(Aov::Albedo) || set.contains(Aov::Normal) {
        let mut si = first;
        for _ in 0..=SPECULAR_CHAIN {
            let bsdf = scene
                .material(&si)
                .bsdf(si.shading_frame(), si.uv, &mut Wavelengths::Rgb);
            if !bsdf.is_delta() {
                diffuse = Some(si);
                break;
            }
            // Lobe choice 0.999: transmission through glass unless it reflects nearly all.
            let Some(bs) = bsdf.sample(si.wo, 0.999, [0.5, 0.5]) else {
                break;
            };
            match scene.interact(&si.spawn_ray(bs.wi), stats) {
                Some(next) => si = next,
                None => break,
            }
        }
    }
    let mut k = 0;
    for aov in set.iter() {
        let vals: &[f32] = match aov {
            Aov::Albedo => &diffuse.map_or([0.0; 3], |si| {
                // An emitter's albedo is its colour (the emission scaled to a maximum of 1), so
                // that the denoiser keeps lights apart from the dark surfaces around them.
                let e = scene.emitted(&si, &Wavelengths::Rgb).to_rgb();
                let c = if e.max_component() > 0.0 {
                    e * (1.0 / e.max_component())
                } else {
                    scene.material(&si).base_color(si.uv)
                };
                [c.r, c.g, c.b].map(|v| v.clamp(0.0, 1.0))
            }),
            Aov::Normal => &diffuse.map_or([0.0; 3], |si| {
                let n = si.facing_shading_normal();
                [n.x, n.y, n.z]
            }),
            Aov::Depth => &[(first.p - ray.o).norm()],
            Aov::Position => &[first.p.x, first.p.y, first.p.z],
            Aov::Uv => &[first.uv.x, first.uv.y],
            Aov::Shape => &[scene.shape_index(&hit) as f32],
            // The antialiased emission starts as the sample's own (the caller refines it at
            // the edges of lights).
            Aov::Emission | Aov::EmissionAa => &{
                let e = scene.emitted(&first, &Wavelengths::Rgb).to_rgb();
                [e.r, e.g, e.b]
            },
        };
        out[k..k + vals.len()].copy_from_slice(vals);
        k += vals.len();
    }
}
