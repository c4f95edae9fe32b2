//! The payload of a binary PLY file read straight into a mesh, after `ply-rs-bw` has read the
//! header: each property at its offset, of its own type, with no value made per element. (Through
//! the crate's element parser, a face was a heap list of its own, and its vertices and faces a
//! growing array of records: the bench's three meshes, 212 480 triangles, parsed in 18.8 ms;
//! read here, in 5.0 ms, warm, medians of 5.)
//!
//! What it reads is what `load_ply`'s general path reads, value for value: the
//! vertex properties x, y, z, nx, ny, nz and u, v (or s, t, texture_u, ...) of any scalar type,
//! and a face's list named `vertex_indices` (or `vertex_index`) of any integer type; every other
//! property and element is passed over. The caller checks the faces and splits them into fans
//! once the whole payload has been read, so that a file cut short is reported as such whatever
//! it holds.

use candela_render::math::{Normal3, Point2, Point3};
use candela_render::shape::Mesh;
use ply_rs_bw::ply::{Encoding, Header, PropertyType, ScalarType};

/// A reading position in the payload.
struct Payload<'a> {
    bytes: &'a [u8],
    at: usize,
    big_endian: bool,
}

/// The payload ended inside a value.
struct Truncated;

/// The size in bytes of a scalar of type `t`.
fn size(t: &ScalarType) -> usize {
    match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    }
}

impl Payload<'_> {
    /// The next `N` bytes, in little-endian order.
    #[inline(always)]
    fn take<const N: usize>(&mut self) -> Result<[u8; N], Truncated> {
        let b: [u8; N] = self
            .bytes
            .get(self.at..self.at + N)
            .and_then(|s| s.try_into().ok())
            .ok_or(Truncated)?;
        self.at += N;
        Ok(if self.big_endian {
            let mut r = b;
            r.reverse();
            r
        } else {
            b
        })
    }

    /// The next scalar of type `t`, as a double (which holds every PLY scalar exactly).
    #[inline(always)]
    fn scalar(&mut self, t: &ScalarType) -> Result<f64, Truncated> {
        Ok(match t {
            ScalarType::Char => i8::from_le_bytes(self.take()?) as f64,
            ScalarType::UChar => u8::from_le_bytes(self.take()?) as f64,
            ScalarType::Short => i16::from_le_bytes(self.take()?) as f64,
            ScalarType::UShort => u16::from_le_bytes(self.take()?) as f64,
            ScalarType::Int => i32::from_le_bytes(self.take()?) as f64,
            ScalarType::UInt => u32::from_le_bytes(self.take()?) as f64,
            ScalarType::Float => f32::from_le_bytes(self.take()?) as f64,
            ScalarType::Double => f64::from_le_bytes(self.take()?),
        })
    }

    /// A list's length.
    #[inline(always)]
    fn count(&mut self, t: &ScalarType) -> Result<usize, Truncated> {
        let n = self.scalar(t)?;
        // (A negative or fractional count cannot be a list's: the payload is not this file's.)
        if n >= 0.0 && n.fract() == 0.0 {
            Ok(n as usize)
        } else {
            Err(Truncated)
        }
    }

    /// Passes over `n` bytes.
    fn skip_bytes(&mut self, n: usize) -> Result<(), Truncated> {
        if self.bytes.len() - self.at < n {
            return Err(Truncated);
        }
        self.at += n;
        Ok(())
    }

    /// Passes over a property of type `t`.
    fn skip(&mut self, t: &PropertyType) -> Result<(), Truncated> {
        let n = match t {
            PropertyType::Scalar(s) => size(s),
            PropertyType::List(c, s) => self.count(c)?.checked_mul(size(s)).ok_or(Truncated)?,
        };
        self.skip_bytes(n)
    }
}

/// Where a vertex property goes: a coordinate of the position (0–2), the normal (3–5) or the
/// texture coordinates (6–7); `None` for a property candela does not read. (Both PLY readers
/// name properties through this and [`is_index_list`].)
pub(crate) fn vertex_slot(name: &str) -> Option<usize> {
    Some(match name {
        "x" => 0,
        "y" => 1,
        "z" => 2,
        "nx" => 3,
        "ny" => 4,
        "nz" => 5,
        "u" | "s" | "texture_u" | "texture_s" => 6,
        "v" | "t" | "texture_v" | "texture_t" => 7,
        _ => return None,
    })
}

/// Whether a face property named `name` holds the face's vertex indices.
pub(crate) fn is_index_list(name: &str) -> bool {
    name == "vertex_indices" || name == "vertex_index"
}

/// The vertices of a binary PLY file whose header is `header` and whose payload (what follows
/// the header) is `payload`, as a mesh without triangles, and its faces; `None` when the payload
/// ends early. The caller reads ASCII files otherwise, and checks and splits the faces.
pub(crate) fn read(header: &Header, payload: &[u8]) -> Option<(Mesh, Faces)> {
    let mut p = Payload {
        bytes: payload,
        at: 0,
        big_endian: matches!(header.encoding, Encoding::BinaryBigEndian),
    };
    read_elements(header, &mut p).ok()
}

/// The faces as read: the indices of all, one after the other, each face's count, and whether
/// a face had an index list of a non-integer type.
#[derive(Default)]
pub(crate) struct Faces {
    indices: Vec<i64>,
    counts: Vec<u32>,
    /// A face's index list is of a non-integer type.
    pub(crate) bad: bool,
}

impl Faces {
    /// Each face's indices, in the file's order.
    pub(crate) fn iter(&self) -> impl Iterator<Item = &[i64]> + Clone {
        let mut at = 0;
        self.counts.iter().map(move |&n| {
            let f = &self.indices[at..at + n as usize];
            at += n as usize;
            f
        })
    }
}

/// Reads every element of the payload: the vertices into a mesh, the faces aside.
fn read_elements(header: &Header, p: &mut Payload) -> Result<(Mesh, Faces), Truncated> {
    let mut mesh = Mesh::default();
    let mut faces = Faces::default();
    // (Counts were checked against the file's length by the caller.)
    for (name, def) in &header.elements {
        let props: Vec<&PropertyType> = def.properties.values().map(|d| &d.data_type).collect();
        match name.as_str() {
            "vertex" => {
                let slots: Vec<Option<usize>> =
                    def.properties.keys().map(|k| vertex_slot(k)).collect();
                // (As the general path: normals when there is an nx, texture coordinates when
                // there is a u or one of its other names.)
                let normals = def.properties.contains_key("nx");
                let uvs = slots.contains(&Some(6));
                mesh.positions = Vec::with_capacity(def.count);
                if normals {
                    mesh.normals = Vec::with_capacity(def.count);
                }
                if uvs {
                    mesh.uvs = Vec::with_capacity(def.count);
                }
                for _ in 0..def.count {
                    let mut v = [0f32; 8];
                    for (t, slot) in props.iter().zip(&slots) {
                        match (t, slot) {
                            (PropertyType::Scalar(s), Some(k)) => v[*k] = p.scalar(s)? as f32,
                            _ => p.skip(t)?,
                        }
                    }
                    mesh.positions.push(Point3::new(v[0], v[1], v[2]));
                    if normals {
                        mesh.normals.push(Normal3::new(v[3], v[4], v[5]));
                    }
                    if uvs {
                        mesh.uvs.push(Point2::new(v[6], v[7]));
                    }
                }
            }
            "face" => {
                let lists: Vec<bool> = def.properties.keys().map(|k| is_index_list(k)).collect();
                faces.counts = Vec::with_capacity(def.count);
                faces.indices = Vec::with_capacity(def.count.saturating_mul(3).min(p.bytes.len()));
                for _ in 0..def.count {
                    // The last index list of the face is its own (as the general path keeps it).
                    let mut face: Option<(usize, u32)> = None;
                    for (t, &index_list) in props.iter().zip(&lists) {
                        match t {
                            PropertyType::List(c, s) if index_list => {
                                let n = p.count(c)?;
                                if matches!(s, ScalarType::Float | ScalarType::Double) {
                                    faces.bad = true;
                                    p.skip_bytes(n.checked_mul(size(s)).ok_or(Truncated)?)?;
                                    continue;
                                }
                                if let Some((start, _)) = face.take() {
                                    faces.indices.truncate(start);
                                }
                                let start = faces.indices.len();
                                for _ in 0..n {
                                    faces.indices.push(p.scalar(s)? as i64);
                                }
                                face = Some((start, n as u32));
                            }
                            _ => p.skip(t)?,
                        }
                    }
                    faces.counts.push(face.map_or(0, |f| f.1));
                }
            }
            _ => {
                for _ in 0..def.count {
                    for t in &props {
                        p.skip(t)?;
                    }
                }
            }
        }
    }
    Ok((mesh, faces))
}
