//! Mitsuba's `serialized` mesh files (format versions 3 and 4), as documented in Mitsuba 3's
//! `src/shapes/serialized.cpp`.
//!
//! A file is a sequence of meshes, each a little-endian header (`u16` 0x041C, `u16` version)
//! followed by a zlib stream: `u32` flags (0x1 vertex normals, 0x2 texture coordinates, 0x8
//! vertex colours, 0x10 face normals, 0x1000 single / 0x2000 double precision), in version 4 a
//! NUL-terminated name, `u64` vertex and triangle counts, then the positions, the normals, the
//! uv and the colours (when flagged; colours are skipped), in `f32` or `f64`, and `u32` indices.
//! The file ends with the offset of every mesh (`u64`, `u32` in version 3) and their number
//! (`u32`); `shape_index` picks a mesh.
//!
//! Counts are checked against what the compressed data can hold before anything is allocated;
//! indices are validated and degenerate triangles dropped, as for OBJ and PLY.

use candela_render::math::{Normal3, Point2, Point3};
use candela_render::shape::Mesh;
use flate2::read::ZlibDecoder;
use std::io::Read;
use std::path::Path;

const HEADER: u16 = 0x041C;
const HAS_NORMALS: u32 = 0x0001;
const HAS_UVS: u32 = 0x0002;
const HAS_COLORS: u32 = 0x0008;
/// Use face normals (the file's equivalent of `face_normals=true`).
pub const FACE_NORMALS: u32 = 0x0010;
const DOUBLE: u32 = 0x2000;

/// deflate cannot expand data by more than about 1032:1.
const MAX_RATIO: u64 = 1100;

/// A mesh of a serialized file, with the flags it was stored with.
#[derive(Debug)]
pub struct SerializedMesh {
    /// The mesh (positions, normals and uv as stored).
    pub mesh: Mesh,
    /// The mesh's flags (see [`FACE_NORMALS`]).
    pub flags: u32,
    /// The mesh's name (version 4), possibly empty.
    pub name: String,
}

/// Reads mesh `index` of the serialized file at `path`. The error is a message for the user
/// (the caller adds the position).
///
/// The file is read as OBJ and PLY files are (a regular file of at most `limits.max_memory /`
/// [`FILE_FRACTION`] bytes), and the mesh it announces may decompress to at most
/// `limits.max_memory /` [`DECODED_FRACTION`] bytes.
pub fn load_serialized(
    path: &Path,
    index: u32,
    limits: &candela_imageio::Limits,
) -> Result<SerializedMesh, String> {
    crate::inputs::record(path);
    let bytes = candela_imageio::input::read_file(path, limits.max_memory / FILE_FRACTION)
        .map_err(|e| format!("cannot read serialized mesh '{}': {e}", path.display()))?;
    parse_serialized_within(&bytes, index, limits.max_memory / DECODED_FRACTION)
        .map_err(|e| format!("serialized mesh '{}': {e}", path.display()))
}

/// The share of the memory budget a serialized file may take (that of OBJ and PLY files).
pub const FILE_FRACTION: u64 = 16;

/// The share of the memory budget a serialized mesh may decompress to (its data is held about
/// twice while it is converted).
pub const DECODED_FRACTION: u64 = 8;

fn u16_at(b: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_le_bytes(b.get(at..at + 2)?.try_into().ok()?))
}
fn u32_at(b: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(b.get(at..at + 4)?.try_into().ok()?))
}
fn u64_at(b: &[u8], at: usize) -> Option<u64> {
    Some(u64::from_le_bytes(b.get(at..at + 8)?.try_into().ok()?))
}

/// Parses mesh `index` of the serialized file `bytes`.
pub fn parse_serialized(bytes: &[u8], index: u32) -> Result<SerializedMesh, String> {
    parse_serialized_within(bytes, index, u64::MAX)
}

/// Parses mesh `index` of the serialized file `bytes`, refusing a mesh whose data takes more
/// than `max_decoded` bytes once decompressed.
pub fn parse_serialized_within(
    bytes: &[u8],
    index: u32,
    max_decoded: u64,
) -> Result<SerializedMesh, String> {
    let bad = |what: &str| what.to_string();
    let (Some(format), Some(version)) = (u16_at(bytes, 0), u16_at(bytes, 2)) else {
        return Err(bad("the file is too short"));
    };
    if format != HEADER {
        return Err(bad("not a serialized mesh file (wrong header)"));
    }
    if version != 3 && version != 4 {
        return Err(format!(
            "unsupported format version {version} (3 and 4 are read)"
        ));
    }
    let offset = if index == 0 {
        0usize
    } else {
        let n = bytes.len();
        let count = n
            .checked_sub(4)
            .and_then(|at| u32_at(bytes, at))
            .ok_or_else(|| bad("the file is too short"))?;
        if index >= count {
            return Err(format!(
                "shape_index {index} is out of range: the file has {count} mesh{}",
                if count == 1 { "" } else { "es" }
            ));
        }
        let entry = if version == 4 { 8 } else { 4 };
        let at = (count - index) as usize * entry + 4;
        let pos = n
            .checked_sub(at)
            .ok_or_else(|| bad("the table of mesh offsets is truncated"))?;
        let off = if version == 4 {
            u64_at(bytes, pos)
        } else {
            u32_at(bytes, pos).map(u64::from)
        }
        .ok_or_else(|| bad("the table of mesh offsets is truncated"))?;
        usize::try_from(off)
            .ok()
            .filter(|&o| o + 4 <= n)
            .ok_or_else(|| format!("mesh {index} starts past the end of the file"))?
    };
    if offset != 0 && (u16_at(bytes, offset) != Some(HEADER)) {
        return Err(format!("mesh {index} has no header at offset {offset}"));
    }
    let compressed = &bytes[offset + 4..];
    let mut z = ZlibDecoder::new(compressed);
    let trunc = |e: std::io::Error| format!("the compressed data is truncated or corrupt ({e})");
    let mut buf4 = [0u8; 4];
    z.read_exact(&mut buf4).map_err(trunc)?;
    let flags = u32::from_le_bytes(buf4);
    let mut name = Vec::new();
    if version == 4 {
        let mut c = [0u8; 1];
        loop {
            z.read_exact(&mut c).map_err(trunc)?;
            if c[0] == 0 {
                break;
            }
            if name.len() >= 4096 {
                return Err(bad("the mesh name is too long"));
            }
            name.push(c[0]);
        }
    }
    let mut buf8 = [0u8; 8];
    z.read_exact(&mut buf8).map_err(trunc)?;
    let vertices = u64::from_le_bytes(buf8);
    z.read_exact(&mut buf8).map_err(trunc)?;
    let triangles = u64::from_le_bytes(buf8);
    let real = if flags & DOUBLE != 0 { 8u64 } else { 4 };
    let mut per_vertex = 3;
    for (flag, n) in [(HAS_NORMALS, 3), (HAS_UVS, 2), (HAS_COLORS, 3)] {
        if flags & flag != 0 {
            per_vertex += n;
        }
    }
    let need = vertices
        .checked_mul(per_vertex * real)
        .and_then(|v| triangles.checked_mul(12).and_then(|t| t.checked_add(v)));
    let limit = (compressed.len() as u64).saturating_mul(MAX_RATIO) + 4096;
    if need.is_none_or(|n| n > limit) || vertices > u32::MAX as u64 {
        return Err(format!(
            "{vertices} vertices and {triangles} triangles do not fit in the file"
        ));
    }
    if need.is_some_and(|n| n > max_decoded) {
        return Err(format!(
            "{vertices} vertices and {triangles} triangles take more than {} MB, the share of --max-memory a serialized mesh may use (docs/limits.md)",
            max_decoded >> 20
        ));
    }
    let vertices = vertices as usize;
    let triangles = triangles as usize;
    let mut read_reals = |count: usize| -> Result<Vec<f32>, String> {
        let mut raw = vec![0u8; count * real as usize];
        z.read_exact(&mut raw).map_err(trunc)?;
        Ok(if real == 8 {
            raw.chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])) as f32)
                .collect()
        } else {
            raw.chunks_exact(4)
                .map(|c| f32::from_le_bytes(c.try_into().unwrap_or([0; 4])))
                .collect()
        })
    };
    let p = read_reals(vertices * 3)?;
    let positions: Vec<Point3> = p
        .chunks_exact(3)
        .map(|c| Point3::new(c[0], c[1], c[2]))
        .collect();
    if positions.iter().any(|p| !p.is_finite()) {
        return Err(bad("a vertex position is not a finite number"));
    }
    let normals: Vec<Normal3> = if flags & HAS_NORMALS != 0 {
        read_reals(vertices * 3)?
            .chunks_exact(3)
            .map(|c| Normal3::new(c[0], c[1], c[2]))
            .collect()
    } else {
        Vec::new()
    };
    let uvs: Vec<Point2> = if flags & HAS_UVS != 0 {
        read_reals(vertices * 2)?
            .chunks_exact(2)
            .map(|c| Point2::new(c[0], c[1]))
            .collect()
    } else {
        Vec::new()
    };
    if flags & HAS_COLORS != 0 {
        read_reals(vertices * 3)?;
    }
    let mut raw = vec![0u8; triangles * 12];
    z.read_exact(&mut raw).map_err(trunc)?;
    let mut mesh = Mesh {
        positions,
        normals,
        uvs,
        indices: Vec::with_capacity(triangles),
        props: Default::default(),
    };
    for (i, t) in raw.chunks_exact(12).enumerate() {
        let idx = [0, 1, 2].map(|k| u32_at(t, 4 * k).unwrap_or(u32::MAX));
        if idx.iter().any(|&v| v as usize >= vertices) {
            return Err(format!(
                "triangle {i} has a vertex index out of range ({vertices} vertices)"
            ));
        }
        if idx[0] != idx[1] && idx[1] != idx[2] && idx[0] != idx[2] {
            mesh.indices.push(idx);
        }
    }
    if !mesh.normals.is_empty()
        && mesh
            .normals
            .iter()
            .any(|n| !(n.x.is_finite() && n.y.is_finite() && n.z.is_finite()))
    {
        mesh.normals.clear();
    }
    Ok(SerializedMesh {
        mesh,
        flags,
        name: String::from_utf8_lossy(&name).into_owned(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use flate2::write::ZlibEncoder;
    use flate2::Compression;
    use std::io::Write;

    /// One mesh in format `version`: a unit square of two triangles, with normals and uv, in
    /// double precision when `double`.
    fn mesh_bytes(version: u16, double: bool, z: f64) -> Vec<u8> {
        let mut body = Vec::new();
        let flags = HAS_NORMALS | HAS_UVS | if double { DOUBLE } else { 0x1000 };
        body.extend(flags.to_le_bytes());
        if version == 4 {
            body.extend(b"square\0");
        }
        body.extend(4u64.to_le_bytes());
        body.extend(2u64.to_le_bytes());
        let mut reals = |v: &[f64]| {
            for &x in v {
                if double {
                    body.extend(x.to_le_bytes());
                } else {
                    body.extend((x as f32).to_le_bytes());
                }
            }
        };
        reals(&[0., 0., z, 1., 0., z, 1., 1., z, 0., 1., z]);
        reals(&[0., 0., 1., 0., 0., 1., 0., 0., 1., 0., 0., 1.]);
        reals(&[0., 0., 1., 0., 1., 1., 0., 1.]);
        for i in [0u32, 1, 2, 0, 2, 3] {
            body.extend(i.to_le_bytes());
        }
        let mut e = ZlibEncoder::new(Vec::new(), Compression::default());
        e.write_all(&body).unwrap();
        let mut out = Vec::new();
        out.extend(HEADER.to_le_bytes());
        out.extend(version.to_le_bytes());
        out.extend(e.finish().unwrap());
        out
    }

    #[test]
    fn reads_meshes_by_index_in_both_versions_and_precisions() {
        for version in [3u16, 4] {
            let a = mesh_bytes(version, false, 0.0);
            let b = mesh_bytes(version, true, 2.0);
            let mut file = a.clone();
            file.extend(&b);
            if version == 4 {
                file.extend(0u64.to_le_bytes());
                file.extend((a.len() as u64).to_le_bytes());
            } else {
                file.extend(0u32.to_le_bytes());
                file.extend((a.len() as u32).to_le_bytes());
            }
            file.extend(2u32.to_le_bytes());
            let m0 = parse_serialized(&file, 0).unwrap();
            let m1 = parse_serialized(&file, 1).unwrap();
            assert_eq!(m0.mesh.indices, vec![[0, 1, 2], [0, 2, 3]]);
            assert_eq!(m0.mesh.positions[2], Point3::new(1.0, 1.0, 0.0));
            assert_eq!(m1.mesh.positions[2], Point3::new(1.0, 1.0, 2.0));
            assert_eq!(m1.mesh.uvs[3], Point2::new(0.0, 1.0));
            assert_eq!(m1.mesh.normals.len(), 4);
            if version == 4 {
                assert_eq!(m1.name, "square");
            }
            let e = parse_serialized(&file, 2).unwrap_err();
            assert!(e.contains("out of range"), "{e}");
        }
    }

    #[test]
    fn bad_files_are_errors_not_panics() {
        let good = mesh_bytes(4, false, 0.0);
        assert!(parse_serialized(&good[..3], 0).is_err());
        assert!(parse_serialized(&good[..good.len() - 5], 0).is_err());
        let mut wrong = good.clone();
        wrong[0] = 0;
        assert!(parse_serialized(&wrong, 0).is_err());
        // A mesh over the decoding budget is refused before its data is allocated.
        let e = parse_serialized_within(&good, 0, 16).unwrap_err();
        assert!(e.contains("--max-memory"), "{e}");
        assert!(parse_serialized_within(&good, 0, 1 << 20).is_ok());
        // Every truncation and a few corruptions: never a panic.
        for n in 0..good.len() {
            let _ = parse_serialized(&good[..n], 0);
            let _ = parse_serialized(&good[..n], 3);
            let mut c = good.clone();
            c[n] ^= 0x5a;
            let _ = parse_serialized(&c, 0);
        }
    }
}
