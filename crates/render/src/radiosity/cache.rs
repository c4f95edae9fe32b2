//! The solution as bytes, for `--radiosity-cache FILE` (the render core does no I/O: the
//! command line reads and writes the file).
//!
//! Layout (little-endian): the magic `CNDLRAD\0`, the format version (u32), the fingerprint of
//! the scene and the options (u64), the number of elements (u32) and of patches (u32), the
//! elements split by adaptive refinement in order (u32 count, then u32 indices), B per patch
//! (3 × f64), whether each patch is hidden (u8), the solver's iterations (u64), residual (f64) and convergence flag (u8), and an
//! FNV-1a checksum (u64) of everything before it.
//!
//! Loading re-meshes the scene (deterministic), replays the splits and checks the counts; the
//! fingerprint covers every shape, mesh, material, emission, light and the background, and
//! every option that changes the solution, so a cache made for another scene or other options
//! is reported as stale and the solution recomputed.

use super::RadiosityOptions;
use crate::scene::Scene;
use std::fmt::Write as _;

const MAGIC: &[u8; 8] = b"CNDLRAD\0";
const VERSION: u32 = 2;

/// FNV-1a, 64 bits: a stable hash (unlike `std`'s, it does not change between Rust releases).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Fnv(pub u64);

impl Default for Fnv {
    fn default() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv {
    /// Hashes bytes.
    pub fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 ^= x as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    fn u64(&mut self, x: u64) {
        self.bytes(&x.to_le_bytes());
    }
    fn f32(&mut self, x: f32) {
        self.bytes(&x.to_bits().to_le_bytes());
    }
}

impl std::fmt::Write for Fnv {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        self.bytes(s.as_bytes());
        Ok(())
    }
}

/// The fingerprint of what a solution depends on: the scene (geometry, materials, emitters,
/// lights, background) and the options that change it.
pub(crate) fn fingerprint(scene: &Scene, opts: &RadiosityOptions, patch_size: f32) -> u64 {
    let mut h = Fnv::default();
    h.u64(VERSION as u64);
    h.f32(patch_size);
    let _ = write!(
        h,
        "{:?}{:?}{}{}{}{}{}{}{}{}{}",
        opts.form_factors,
        opts.solver,
        opts.threshold,
        opts.max_iterations,
        opts.hemicube_resolution,
        opts.rays_per_patch,
        opts.refinements,
        opts.refine_threshold,
        opts.max_patches,
        opts.cull_hidden_sides,
        opts.reciprocal_gather
    );
    h.u64(opts.seed);
    let geo = &scene.geometry;
    for o in geo.objects() {
        let _ = write!(h, "{:?}{:?}", o.shape, o.props);
    }
    for m in geo.meshes() {
        h.u64(m.positions.len() as u64);
        for p in &m.positions {
            h.f32(p.x);
            h.f32(p.y);
            h.f32(p.z);
        }
        for n in &m.normals {
            h.f32(n.x);
            h.f32(n.y);
            h.f32(n.z);
        }
        for uv in &m.uvs {
            h.f32(uv.x);
            h.f32(uv.y);
        }
        for t in &m.indices {
            for &i in t {
                h.bytes(&i.to_le_bytes());
            }
        }
        let _ = write!(h, "{:?}", m.props);
    }
    let _ = write!(
        h,
        "{:?}{:?}{:?}{:?}",
        scene.materials, scene.emissions, scene.lights, scene.background
    );
    h.0
}

/// What a cache holds.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct CacheData {
    /// The fingerprint of the scene and options it was solved for.
    pub fingerprint: u64,
    /// Elements of the refined mesh.
    pub elements: u32,
    /// Patches of the refined mesh.
    pub patches: u32,
    /// Elements split by refinement, in order.
    pub splits: Vec<u32>,
    /// Radiosity per patch.
    pub b: Vec<[f64; 3]>,
    /// Patches whose centre is hidden (display weights).
    pub hidden: Vec<bool>,
    /// Sweeps or shots of the solve.
    pub iterations: u64,
    /// Relative residual reached.
    pub residual: f64,
    /// Whether it reached the threshold.
    pub converged: bool,
}

/// Why bytes could not be read back.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum CacheError {
    /// Not a cache of this format (or corrupt).
    Invalid(String),
    /// A valid cache of another scene or other options.
    Stale,
}

/// Serialises a solution.
pub(crate) fn encode(d: &CacheData) -> Vec<u8> {
    let mut out = Vec::with_capacity(64 + d.splits.len() * 4 + d.b.len() * 24);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&d.fingerprint.to_le_bytes());
    out.extend_from_slice(&d.elements.to_le_bytes());
    out.extend_from_slice(&d.patches.to_le_bytes());
    out.extend_from_slice(&(d.splits.len() as u32).to_le_bytes());
    for s in &d.splits {
        out.extend_from_slice(&s.to_le_bytes());
    }
    for b in &d.b {
        for c in b {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    out.extend(d.hidden.iter().map(|&h| h as u8));
    out.extend_from_slice(&d.iterations.to_le_bytes());
    out.extend_from_slice(&d.residual.to_le_bytes());
    out.push(d.converged as u8);
    let mut h = Fnv::default();
    h.bytes(&out);
    out.extend_from_slice(&h.0.to_le_bytes());
    out
}

/// A little-endian reader over bytes.
struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], CacheError> {
        let end = self
            .at
            .checked_add(n)
            .filter(|&e| e <= self.b.len())
            .ok_or_else(|| CacheError::Invalid("truncated".into()))?;
        let s = &self.b[self.at..end];
        self.at = end;
        Ok(s)
    }
    fn u32(&mut self) -> Result<u32, CacheError> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().unwrap_or([0; 4]),
        ))
    }
    fn u64(&mut self) -> Result<u64, CacheError> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().unwrap_or([0; 8]),
        ))
    }
    fn f64(&mut self) -> Result<f64, CacheError> {
        Ok(f64::from_bits(self.u64()?))
    }
}

/// Reads a solution, checking the format, the checksum and the fingerprint.
pub(crate) fn decode(bytes: &[u8], fingerprint: u64) -> Result<CacheData, CacheError> {
    if bytes.len() < MAGIC.len() + 12 || &bytes[..8] != MAGIC {
        return Err(CacheError::Invalid("not a candela radiosity cache".into()));
    }
    let body = &bytes[..bytes.len() - 8];
    let mut h = Fnv::default();
    h.bytes(body);
    if h.0.to_le_bytes() != bytes[bytes.len() - 8..] {
        return Err(CacheError::Invalid(
            "checksum mismatch (corrupt file)".into(),
        ));
    }
    let mut r = Reader { b: body, at: 8 };
    let version = r.u32()?;
    if version != VERSION {
        return Err(CacheError::Stale);
    }
    let fp = r.u64()?;
    if fp != fingerprint {
        return Err(CacheError::Stale);
    }
    let elements = r.u32()?;
    let patches = r.u32()?;
    let ns = r.u32()? as usize;
    if ns > body.len() / 4 || patches as usize > body.len() / 24 {
        return Err(CacheError::Invalid("bad counts".into()));
    }
    let mut splits = Vec::with_capacity(ns);
    for _ in 0..ns {
        splits.push(r.u32()?);
    }
    let mut b = Vec::with_capacity(patches as usize);
    for _ in 0..patches {
        b.push([r.f64()?, r.f64()?, r.f64()?]);
    }
    let hidden = r.take(patches as usize)?.iter().map(|&x| x != 0).collect();
    let iterations = r.u64()?;
    let residual = r.f64()?;
    let converged = r.take(1)?[0] != 0;
    if r.at != body.len() {
        return Err(CacheError::Invalid("trailing bytes".into()));
    }
    if b.iter().any(|x| x.iter().any(|c| !c.is_finite())) {
        return Err(CacheError::Invalid("non-finite radiosity".into()));
    }
    Ok(CacheData {
        fingerprint: fp,
        elements,
        patches,
        splits,
        b,
        hidden,
        iterations,
        residual,
        converged,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data() -> CacheData {
        CacheData {
            fingerprint: 42,
            elements: 7,
            patches: 2,
            splits: vec![3, 5],
            b: vec![[1.0, 2.0, 3.0], [0.5, 0.25, 0.125]],
            hidden: vec![false, true],
            iterations: 9,
            residual: 1e-5,
            converged: true,
        }
    }

    #[test]
    fn bytes_round_trip() {
        let d = data();
        assert_eq!(decode(&encode(&d), 42), Ok(d));
    }

    #[test]
    fn stale_and_corrupt_bytes_are_told_apart() {
        let bytes = encode(&data());
        assert_eq!(decode(&bytes, 43), Err(CacheError::Stale));
        for k in [0, 9, 20, bytes.len() / 2, bytes.len() - 1] {
            let mut bad = bytes.clone();
            bad[k] ^= 1;
            assert!(
                matches!(decode(&bad, 42), Err(CacheError::Invalid(_))),
                "byte {k}"
            );
        }
        assert!(matches!(
            decode(&bytes[..bytes.len() - 3], 42),
            Err(CacheError::Invalid(_))
        ));
        assert!(matches!(decode(b"", 42), Err(CacheError::Invalid(_))));
    }
}
