//! Triangle meshes from Wavefront OBJ (through `tobj`) and PLY (ASCII and binary: the header
//! through `ply-rs-bw`, an ASCII payload through its element parser, a binary one read straight
//! into the mesh by `ply_binary`), loaded into candela's mesh layout: one array per attribute, in
//! world space.
//!
//! Polygons are split into fans of triangles. Vertex normals and texture coordinates are kept
//! when every vertex has them. OBJ texture coordinates are flipped in v (OBJ's v grows upwards,
//! candela's image lookup counts rows from the top, as Mitsuba does). Indices are validated;
//! faces with an out-of-range index are an error, degenerate faces are dropped.

use crate::ply_binary::{is_index_list, vertex_slot};
use candela_imageio::Limits;
use candela_render::math::{Normal3, Point2, Point3, Transform};
use candela_render::shape::Mesh;
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{BeginList, PropertyAccess, PropertyAccessResult};
use std::path::Path;

/// A mesh file may take at most this fraction of the memory budget (parsing expands it by up to
/// this factor).
pub const MESH_FILE_FRACTION: u64 = 16;

/// Loads `path` (`.obj` or `.ply`, case-insensitive) and moves it by `transform`.
/// The error is a message for the user (the caller adds the position). The file must be a
/// regular file of at most `limits.max_memory / MESH_FILE_FRACTION` bytes; an OBJ's `mtllib`
/// is never opened (candela takes materials from the scene, not from the mesh).
pub fn load_mesh(path: &Path, transform: &Transform, limits: &Limits) -> Result<Mesh, String> {
    crate::inputs::record(path);
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let mut mesh = match ext.as_deref() {
        Some("obj") => load_obj(path, &read(path, limits)?)?,
        Some("ply") => load_ply(path, &read(path, limits)?)?,
        _ => {
            return Err(format!(
                "'{}': unknown mesh format (use .obj or .ply)",
                path.display()
            ))
        }
    };
    if mesh.positions.iter().any(|p| !p.is_finite()) {
        return Err(format!(
            "'{}': a vertex position is not a finite number",
            path.display()
        ));
    }
    if !transform.is_identity() {
        mesh = mesh.transformed(transform);
    }
    Ok(mesh)
}

/// Bytes used by a mesh per triangle (attributes, indices and the scene's primitive record).
pub fn bytes_per_triangle(m: &Mesh) -> f64 {
    let bytes =
        m.positions.len() * 12 + m.normals.len() * 12 + m.uvs.len() * 8 + m.indices.len() * 12;
    // Each triangle also takes a 12-byte primitive reference in the scene.
    bytes as f64 / m.indices.len().max(1) as f64 + 12.0
}

fn read_error(path: &Path, e: impl std::fmt::Display) -> String {
    format!("cannot read mesh '{}': {e}", path.display())
}

/// The bytes of the mesh file `path`, within the limits.
fn read(path: &Path, limits: &Limits) -> Result<Vec<u8>, String> {
    candela_imageio::input::read_file(path, limits.max_memory / MESH_FILE_FRACTION)
        .map_err(|e| read_error(path, e))
}

/// Parses an OBJ file held in memory (`path` names it in messages).
pub fn load_obj(path: &Path, bytes: &[u8]) -> Result<Mesh, String> {
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    // Material libraries are not opened: the scene gives the materials.
    let (models, _) = tobj::load_obj_buf(&mut std::io::Cursor::new(bytes), &opts, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| read_error(path, e))?;
    let mut mesh = Mesh::default();
    let mut all_normals = true;
    let mut all_uvs = true;
    for model in &models {
        let m = &model.mesh;
        let nv = m.positions.len() / 3;
        all_normals &= m.normals.len() == nv * 3;
        all_uvs &= m.texcoords.len() == nv * 2;
    }
    for model in models {
        let m = model.mesh;
        let base = mesh.positions.len() as u32;
        let nv = (m.positions.len() / 3) as u32;
        mesh.positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|p| Point3::new(p[0], p[1], p[2])),
        );
        if all_normals {
            mesh.normals.extend(
                m.normals
                    .chunks_exact(3)
                    .map(|n| Normal3::new(n[0], n[1], n[2])),
            );
        }
        if all_uvs {
            mesh.uvs.extend(
                m.texcoords
                    .chunks_exact(2)
                    .map(|t| Point2::new(t[0], 1.0 - t[1])),
            );
        }
        for tri in m.indices.chunks_exact(3) {
            if tri.iter().any(|&i| i >= nv) {
                return Err(format!(
                    "'{}': a face refers to a vertex that does not exist",
                    path.display()
                ));
            }
            push_triangle(&mut mesh, [base + tri[0], base + tri[1], base + tri[2]]);
        }
    }
    Ok(mesh)
}

/// Appends a triangle unless two of its indices coincide.
fn push_triangle(mesh: &mut Mesh, t: [u32; 3]) {
    if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
        mesh.indices.push(t);
    }
}

/// A PLY vertex: the properties candela uses.
#[derive(Clone, Copy, Default)]
struct PlyVertex {
    p: [f32; 3],
    n: [f32; 3],
    uv: [f32; 2],
    has: u8,
}

const HAS_N: u8 = 1;
const HAS_UV: u8 = 2;

impl PlyVertex {
    fn set(&mut self, name: &str, v: f64) -> PropertyAccessResult {
        let Some(k) = vertex_slot(name) else {
            return PropertyAccessResult::Ignored;
        };
        let v = v as f32;
        match k {
            0..=2 => self.p[k] = v,
            3..=5 => self.n[k - 3] = v,
            _ => self.uv[k - 6] = v,
        }
        // (The first normal and texture coordinates say that the vertex has them.)
        match k {
            3 => self.has |= HAS_N,
            6 => self.has |= HAS_UV,
            _ => {}
        }
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for PlyVertex {
    fn new() -> Self {
        Self::default()
    }
    fn set_float(&mut self, name: &str, v: f32) -> PropertyAccessResult {
        self.set(name, v as f64)
    }
    fn set_double(&mut self, name: &str, v: f64) -> PropertyAccessResult {
        self.set(name, v)
    }
    fn set_char(&mut self, name: &str, v: i8) -> PropertyAccessResult {
        self.set(name, v as f64)
    }
    fn set_uchar(&mut self, name: &str, v: u8) -> PropertyAccessResult {
        self.set(name, v as f64)
    }
    fn set_short(&mut self, name: &str, v: i16) -> PropertyAccessResult {
        self.set(name, v as f64)
    }
    fn set_ushort(&mut self, name: &str, v: u16) -> PropertyAccessResult {
        self.set(name, v as f64)
    }
    fn set_int(&mut self, name: &str, v: i32) -> PropertyAccessResult {
        self.set(name, v as f64)
    }
    fn set_uint(&mut self, name: &str, v: u32) -> PropertyAccessResult {
        self.set(name, v as f64)
    }
}

/// A PLY face: its vertex indices (any integer list type).
#[derive(Clone, Default)]
struct PlyFace {
    indices: Vec<i64>,
    bad: bool,
}

macro_rules! face_list {
    ($($f:ident: $t:ty),*) => {
        $(fn $f(&mut self, name: &str, v: Vec<$t>) -> PropertyAccessResult {
            if !is_index_list(name) {
                return PropertyAccessResult::Ignored;
            }
            self.indices = v.into_iter().map(|x| x as i64).collect();
            PropertyAccessResult::Set
        })*
    };
}

impl PropertyAccess for PlyFace {
    fn new() -> Self {
        Self::default()
    }
    face_list!(set_list_char: i8, set_list_uchar: u8, set_list_short: i16, set_list_ushort: u16, set_list_int: i32, set_list_uint: u32);
    fn set_list_float(&mut self, name: &str, _: Vec<f32>) -> PropertyAccessResult {
        self.bad |= is_index_list(name);
        PropertyAccessResult::Ignored
    }
    fn set_list_double(&mut self, name: &str, _: Vec<f64>) -> PropertyAccessResult {
        self.set_list_float(name, Vec::new())
    }
    fn begin_list_int(&mut self, _: &str, _: usize) -> BeginList<'_, i32> {
        BeginList::UseSetter
    }
}

/// Parses a PLY file held in memory (`path` names it in messages). A binary payload is read
/// straight into the mesh (`ply_binary`), an ASCII one through `ply-rs-bw`'s element parser.
pub fn load_ply(path: &Path, bytes: &[u8]) -> Result<Mesh, String> {
    load_ply_with(path, bytes, true)
}

/// [`load_ply`], the binary payload read by `ply_binary` when `fast`, else by the element
/// parser as ASCII is (the tests compare the two).
fn load_ply_with(path: &Path, bytes: &[u8], fast: bool) -> Result<Mesh, String> {
    let file_len = bytes.len() as u64;
    let mut reader = Reader::new(std::io::Cursor::new(bytes));
    let vparser = Parser::<PlyVertex>::new();
    let fparser = Parser::<PlyFace>::new();
    let header = vparser
        .read_header(&mut reader)
        .map_err(|e| read_error(path, e))?;
    for (name, def) in &header.elements {
        // Every element takes at least one byte (binary) or one character (ASCII).
        if def.count as u64 > file_len {
            return Err(format!(
                "'{}': the header announces {} {name} elements, more than the file holds",
                path.display(),
                def.count
            ));
        }
    }
    if fast && header.encoding != ply_rs_bw::ply::Encoding::Ascii {
        let at = (reader.get_ref().position() as usize).min(bytes.len());
        let Some((mut mesh, faces)) = crate::ply_binary::read(&header, &bytes[at..]) else {
            return Err(read_error(
                path,
                "the file ends before the elements its header announces",
            ));
        };
        add_faces(path, &mut mesh, faces.iter(), faces.bad)?;
        return Ok(mesh);
    }
    let mut vertices: Vec<PlyVertex> = Vec::new();
    let mut faces: Vec<PlyFace> = Vec::new();
    for (name, def) in &header.elements {
        match name.as_str() {
            "vertex" => {
                vertices = vparser
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(|e| read_error(path, e))?
            }
            "face" => {
                faces = fparser
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(|e| read_error(path, e))?
            }
            // Other elements must still be consumed to reach the ones after them.
            _ => {
                fparser
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(|e| read_error(path, e))?;
            }
        }
    }
    let mut mesh = Mesh {
        positions: vertices
            .iter()
            .map(|v| Point3::new(v.p[0], v.p[1], v.p[2]))
            .collect(),
        ..Default::default()
    };
    if !vertices.is_empty() && vertices.iter().all(|v| v.has & HAS_N != 0) {
        mesh.normals = vertices
            .iter()
            .map(|v| Normal3::new(v.n[0], v.n[1], v.n[2]))
            .collect();
    }
    if !vertices.is_empty() && vertices.iter().all(|v| v.has & HAS_UV != 0) {
        mesh.uvs = vertices
            .iter()
            .map(|v| Point2::new(v.uv[0], v.uv[1]))
            .collect();
    }
    let bad = faces.iter().any(|f| f.bad);
    add_faces(path, &mut mesh, faces.iter().map(|f| &f.indices[..]), bad)?;
    Ok(mesh)
}

/// Checks `faces`' indices against `mesh`'s vertices (`bad`: a face's index list was not of
/// integers) and adds each face as a fan of triangles.
fn add_faces<'a>(
    path: &Path,
    mesh: &mut Mesh,
    faces: impl Iterator<Item = &'a [i64]> + Clone,
    bad: bool,
) -> Result<(), String> {
    let nv = mesh.positions.len() as i64;
    if bad || faces.clone().any(|f| f.iter().any(|&i| i < 0 || i >= nv)) {
        return Err(format!(
            "'{}': a face refers to a vertex that does not exist",
            path.display()
        ));
    }
    mesh.indices.reserve(faces.size_hint().0);
    for f in faces {
        for k in 1..f.len().saturating_sub(1) {
            push_triangle(mesh, [f[0] as u32, f[k] as u32, f[k + 1] as u32]);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str, bytes: &[u8]) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("candela-mesh-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }

    const QUAD_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\nf 1/1/1 2/2/1 3/3/1 4/4/1\n";

    #[test]
    fn obj_quads_become_two_triangles_with_normals_and_flipped_uv() {
        let m = load_mesh(
            &tmp("quad.obj", QUAD_OBJ.as_bytes()),
            &Transform::IDENTITY,
            &Limits::default(),
        )
        .unwrap();
        assert_eq!(m.indices.len(), 2);
        assert_eq!(m.normals.len(), m.positions.len());
        assert_eq!(m.uvs.len(), m.positions.len());
        let i0 = m.indices[0][0] as usize;
        assert_eq!(m.positions[i0], Point3::new(0.0, 0.0, 0.0));
        assert_eq!(m.uvs[i0], Point2::new(0.0, 1.0));
    }

    fn ply_header(format: &str, nv: usize, nf: usize) -> String {
        format!(
            "ply\nformat {format} 1.0\nelement vertex {nv}\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nelement face {nf}\nproperty list uchar int vertex_indices\nend_header\n"
        )
    }

    #[test]
    fn ply_ascii_and_binary_agree() {
        let verts = [
            [0f32, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        let mut ascii = ply_header("ascii", 4, 1);
        for v in verts {
            ascii += &format!("{} {} {} 0 0 1\n", v[0], v[1], v[2]);
        }
        ascii += "4 0 1 2 3\n";
        let a = load_mesh(
            &tmp("a.ply", ascii.as_bytes()),
            &Transform::IDENTITY,
            &Limits::default(),
        )
        .unwrap();
        for (fmt, le) in [("binary_little_endian", true), ("binary_big_endian", false)] {
            let mut b = ply_header(fmt, 4, 1).into_bytes();
            let put_f = |b: &mut Vec<u8>, x: f32| {
                b.extend(if le { x.to_le_bytes() } else { x.to_be_bytes() })
            };
            for v in verts {
                for x in [v[0], v[1], v[2], 0.0, 0.0, 1.0] {
                    put_f(&mut b, x);
                }
            }
            b.push(4);
            for i in [0i32, 1, 2, 3] {
                b.extend(if le { i.to_le_bytes() } else { i.to_be_bytes() });
            }
            let m = load_mesh(
                &tmp(&format!("{fmt}.ply"), &b),
                &Transform::IDENTITY,
                &Limits::default(),
            )
            .unwrap();
            assert_eq!(m, a, "{fmt}");
        }
        assert_eq!(a.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(a.normals.len(), 4);
    }

    /// A binary PLY of mixed property types, with properties and elements candela does not
    /// read (a colour, a vertex list, an edge element), texture coordinates under another name,
    /// faces of three to five corners (one degenerate), the face element first when
    /// `faces_first`; little- or big-endian.
    fn mixed_ply(le: bool, faces_first: bool) -> Vec<u8> {
        let vertex_def = "element vertex 5\nproperty double x\nproperty float y\nproperty short z\nproperty uchar red\nproperty float nx\nproperty float ny\nproperty float nz\nproperty list uchar float junk\nproperty float texture_u\nproperty float texture_v\n";
        let face_def =
            "element face 4\nproperty uchar flags\nproperty list uchar uint vertex_indices\n";
        let edge_def = "element edge 2\nproperty int a\nproperty list ushort int b\n";
        let fmt = if le {
            "binary_little_endian"
        } else {
            "binary_big_endian"
        };
        let (first, second) = if faces_first {
            (face_def, vertex_def)
        } else {
            (vertex_def, face_def)
        };
        let header = format!("ply\nformat {fmt} 1.0\n{first}{edge_def}{second}end_header\n");
        let mut b = header.into_bytes();
        // A value from its little-endian bytes, in the file's order.
        let put = |b: &mut Vec<u8>, mut x: Vec<u8>| {
            if !le {
                x.reverse();
            }
            b.extend(x);
        };
        let vertices = |b: &mut Vec<u8>| {
            for k in 0..5u8 {
                put(b, (0.1f64 * k as f64 + 1e-9).to_le_bytes().to_vec());
                put(b, (k as f32 * 0.25).to_le_bytes().to_vec());
                put(b, (-(k as i16)).to_le_bytes().to_vec());
                b.push(200 + k);
                for n in [0.0f32, 0.6, 0.8] {
                    put(b, n.to_le_bytes().to_vec());
                }
                b.push(k % 3);
                for j in 0..k % 3 {
                    put(b, (j as f32).to_le_bytes().to_vec());
                }
                put(b, (k as f32 / 4.0).to_le_bytes().to_vec());
                put(b, (1.0f32 - k as f32 / 8.0).to_le_bytes().to_vec());
            }
        };
        let faces = |b: &mut Vec<u8>| {
            for f in [
                &[0u32, 1, 2][..],
                &[0, 2, 3, 4],
                &[1, 1, 2],
                &[4, 3, 2, 1, 0],
            ] {
                b.push(7);
                b.push(f.len() as u8);
                for &i in f {
                    put(b, i.to_le_bytes().to_vec());
                }
            }
        };
        if faces_first {
            faces(&mut b);
        } else {
            vertices(&mut b);
        }
        for e in 0..2i32 {
            put(&mut b, e.to_le_bytes().to_vec());
            put(&mut b, (e as u16).to_le_bytes().to_vec());
            for j in 0..e {
                put(&mut b, j.to_le_bytes().to_vec());
            }
        }
        if faces_first {
            vertices(&mut b);
        } else {
            faces(&mut b);
        }
        b
    }

    /// A binary payload read straight into the mesh gives the element parser's mesh, value
    /// for value; a file cut anywhere is an error from both, never a panic; a bad index is
    /// reported the same way.
    #[test]
    fn binary_payloads_read_directly_are_the_element_parsers() {
        let path = Path::new("mixed.ply");
        for le in [true, false] {
            for faces_first in [false, true] {
                let b = mixed_ply(le, faces_first);
                let fast = load_ply_with(path, &b, true).unwrap();
                let general = load_ply_with(path, &b, false).unwrap();
                assert_eq!(fast, general, "{le} {faces_first}");
                assert_eq!(fast.positions.len(), 5);
                assert_eq!((fast.normals.len(), fast.uvs.len()), (5, 5));
                // 1 + 2 + 0 (degenerate) + 3 triangles.
                assert_eq!(fast.indices.len(), 6);
                let header_end = b.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
                for cut in header_end..b.len() {
                    let e = load_ply_with(path, &b[..cut], true).unwrap_err();
                    assert!(e.contains("mixed.ply"), "{e}");
                    assert!(load_ply_with(path, &b[..cut], false).is_err(), "{cut}");
                }
            }
        }
        // An index past the vertices.
        let mut b = mixed_ply(true, false);
        let last = b.len() - 4;
        b[last..].copy_from_slice(&9u32.to_le_bytes());
        for fast in [true, false] {
            let e = load_ply_with(path, &b, fast).unwrap_err();
            assert!(e.contains("does not exist"), "{e}");
        }
        // The bench's meshes, when they have been made (bench/make-meshes.py).
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../bench/meshes");
        for name in ["knot.ply", "blob.ply"] {
            if let Ok(b) = std::fs::read(dir.join(name)) {
                let p = Path::new(name);
                assert_eq!(
                    load_ply_with(p, &b, true),
                    load_ply_with(p, &b, false),
                    "{name}"
                );
            }
        }
    }

    /// Random corruptions of a binary file's payload (counts, values, indices) never make the
    /// direct reader panic, and it gives a mesh exactly when the element parser does: the same
    /// one.
    #[test]
    fn corrupted_binary_payloads_never_panic() {
        let path = Path::new("corrupt.ply");
        let mut rng = candela_render::sampling::Pcg32::new(11, 3);
        for le in [true, false] {
            let clean = mixed_ply(le, false);
            let start = clean
                .windows(11)
                .position(|w| w == b"end_header\n")
                .unwrap()
                + 11;
            for _ in 0..3000 {
                let mut b = clean.clone();
                for _ in 0..1 + rng.next_u32() % 4 {
                    let at = start + (rng.next_u32() as usize) % (b.len() - start);
                    b[at] = rng.next_u32() as u8;
                }
                let (fast, general) = (
                    load_ply_with(path, &b, true),
                    load_ply_with(path, &b, false),
                );
                assert_eq!(fast.is_ok(), general.is_ok(), "{fast:?} {general:?}");
                if fast.is_ok() {
                    assert_eq!(fast, general);
                }
            }
        }
    }

    #[test]
    fn bad_files_are_errors_not_panics() {
        let missing = load_mesh(
            Path::new("/nonexistent/x.obj"),
            &Transform::IDENTITY,
            &Limits::default(),
        )
        .unwrap_err();
        assert!(missing.contains("x.obj"), "{missing}");
        let mut bad_index = ply_header("ascii", 1, 1);
        bad_index += "0 0 0 0 0 1\n3 0 1 2\n";
        assert!(load_mesh(
            &tmp("bad.ply", bad_index.as_bytes()),
            &Transform::IDENTITY,
            &Limits::default()
        )
        .unwrap_err()
        .contains("does not exist"));
        let huge = "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\nend_header\n";
        assert!(load_mesh(
            &tmp("huge.ply", huge.as_bytes()),
            &Transform::IDENTITY,
            &Limits::default()
        )
        .is_err());
        assert!(load_mesh(
            &tmp("garbage.ply", b"not a ply"),
            &Transform::IDENTITY,
            &Limits::default()
        )
        .is_err());
        assert!(load_mesh(
            &tmp("t.stl", b"solid"),
            &Transform::IDENTITY,
            &Limits::default()
        )
        .unwrap_err()
        .contains("unknown mesh format"));
        let truncated = ply_header("binary_little_endian", 4, 1).into_bytes();
        assert!(load_mesh(
            &tmp("trunc.ply", &truncated),
            &Transform::IDENTITY,
            &Limits::default()
        )
        .is_err());
    }
}
