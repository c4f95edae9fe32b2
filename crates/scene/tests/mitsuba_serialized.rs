//! Mitsuba `serialized` shapes through the importer: `shape_index`, `to_world`, errors at the
//! shape. (The format itself is tested in `serialized.rs`; `scripts/serialized-vs-mitsuba.py`
//! compares a render with Mitsuba's.)

mod support;

use flate2::write::ZlibEncoder;
use flate2::Compression;
use std::io::Write;
use support::mitsuba::{error_of, load_at, scene, tmpdir};

/// A format-4 mesh of `tris` triangles (a fan), single precision, no normals or uv.
fn mesh(tris: u32) -> Vec<u8> {
    let mut body = Vec::new();
    body.extend(0x1000u32.to_le_bytes());
    body.extend(b"fan\0");
    body.extend(u64::from(tris + 2).to_le_bytes());
    body.extend(u64::from(tris).to_le_bytes());
    for i in 0..tris + 2 {
        let a = i as f32 * 0.3;
        for v in [
            a.cos() * (i > 0) as u8 as f32,
            a.sin() * (i > 0) as u8 as f32,
            0.0,
        ] {
            body.extend(v.to_le_bytes());
        }
    }
    for i in 0..tris {
        for v in [0, i + 1, i + 2] {
            body.extend(v.to_le_bytes());
        }
    }
    let mut e = ZlibEncoder::new(Vec::new(), Compression::default());
    e.write_all(&body).unwrap();
    let mut out = vec![0x1C, 0x04, 4, 0];
    out.extend(e.finish().unwrap());
    out
}

#[test]
fn serialized_shapes_load_by_index() {
    let dir = tmpdir("serialized");
    let (a, b) = (mesh(2), mesh(5));
    let mut file = a.clone();
    file.extend(&b);
    file.extend(0u64.to_le_bytes());
    file.extend((a.len() as u64).to_le_bytes());
    file.extend(2u32.to_le_bytes());
    std::fs::write(dir.join("m.serialized"), file).unwrap();
    let xml = scene(
        r#"<shape type="serialized"><string name="filename" value="m.serialized"/></shape>
<shape type="serialized"><string name="filename" value="m.serialized"/><integer name="shape_index" value="1"/>
  <transform name="to_world"><translate z="3"/></transform></shape>"#,
    );
    let l = load_at(&dir.join("s.xml"), &xml);
    let meshes = l.scene.geometry.meshes();
    assert_eq!(meshes.len(), 2);
    assert_eq!(meshes[0].indices.len(), 2);
    assert_eq!(meshes[1].indices.len(), 5);
    assert!(meshes[1].positions.iter().all(|p| p.z == 3.0));

    let e = error_of(&scene(
        r#"<shape type="serialized">
  <string name="filename" value="nowhere.serialized"/></shape>"#,
    ));
    assert!(e.starts_with("3:3: cannot read serialized mesh"), "{e}");
}
