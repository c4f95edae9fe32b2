//! Instancing through the importers: Mitsuba's `shapegroup`/`instance` and the candela
//! language's `instance(NAME, T)` of meshes share one copy of the geometry (two-level ray
//! tracing) and hit what the same shapes placed one by one hit; bad references, emitters and
//! nested instancing are errors at their position.

mod support;

use candela_render::math::{Point3, Ray};
use candela_render::sampling::Pcg32;
use candela_render::stats::RayStats;
use candela_render::Scene;
use candela_scene::{load_scene, LoadOptions};
use support::mitsuba::{error_of, load_at, scene, tmpdir};

/// An ASCII PLY torus (radii 1 and 0.35, `n`×`n` quads, two triangles each), without normals.
fn torus_ply(n: usize) -> String {
    let mut s = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        n * n,
        2 * n * n
    );
    for i in 0..n {
        for j in 0..n {
            let (u, v) = (
                i as f64 / n as f64 * std::f64::consts::TAU,
                j as f64 / n as f64 * std::f64::consts::TAU,
            );
            let r = 1.0 + 0.35 * v.cos();
            s += &format!("{} {} {}\n", r * u.cos(), r * u.sin(), 0.35 * v.sin());
        }
    }
    let id = |i: usize, j: usize| (i % n) * n + (j % n);
    for i in 0..n {
        for j in 0..n {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            s += &format!("3 {a} {b} {c}\n3 {a} {c} {d}\n");
        }
    }
    s
}

/// Random rays from above aimed at the region where the shapes are.
fn rays(seed: u64, n: usize) -> Vec<Ray> {
    let mut rng = Pcg32::new(seed, 1);
    (0..n)
        .map(|_| {
            let mut f = || rng.next_f32();
            let o = Point3::new(f() * 16.0 - 8.0, f() * 16.0 - 8.0, 8.0 + f() * 4.0);
            let target = Point3::new(f() * 12.0 - 6.0, f() * 12.0 - 6.0, f() * 3.0 - 1.5);
            Ray::new(o, target - o)
        })
        .collect()
}

/// Every ray hits the same surface in both scenes (same distance, normal, material, up to
/// round-off); a few grazing rays may disagree. Returns the number of hits.
fn same_hits(a: &Scene, b: &Scene, rays: &[Ray]) -> usize {
    let mut st = RayStats::default();
    let (mut hits, mut differ) = (0, 0);
    for r in rays {
        match (a.interact(r, &mut st), b.interact(r, &mut st)) {
            (Some(x), Some(y)) if (x.t - y.t).abs() <= 1e-4 * y.t => {
                hits += 1;
                assert!((x.p - y.p).norm() < 1e-3, "{:?} {:?}", x.p, y.p);
                assert!(
                    x.n.to_vec().approx_eq(y.n.to_vec(), 2e-3),
                    "{:?} {:?} at {:?}",
                    x.n,
                    y.n,
                    x.p
                );
                assert_eq!(x.props.material, y.props.material);
            }
            (None, None) => {}
            _ => differ += 1,
        }
    }
    assert!(
        differ * 1000 < rays.len(),
        "{differ} of {} rays differ",
        rays.len()
    );
    hits
}

const SENSORLESS_BSDFS: &str = r#"<bsdf type="diffuse" id="red"><rgb name="reflectance" value="0.8, 0.2, 0.2"/></bsdf>
<bsdf type="conductor" id="metal"/>"#;

/// The group's shapes, each with its own `to_world` followed by `extra` (the instance's
/// placement, for the flattened scene).
fn group_shapes(extra: &str) -> String {
    format!(
        r#"<shape type="ply"><string name="filename" value="torus.ply"/><ref id="red"/>
  <transform name="to_world"><rotate x="1" angle="20"/>{extra}</transform></shape>
<shape type="cube"><ref id="metal"/><transform name="to_world"><scale value="0.3"/><translate z="1"/>{extra}</transform></shape>
<shape type="rectangle"><transform name="to_world"><scale x="1.5" y="0.5"/><translate z="-0.6"/>{extra}</transform></shape>"#
    )
}

/// Placements of the torus group: identity, rotated and non-uniformly scaled, mirrored and
/// moved; and of the sphere group (uniform scaling: Mitsuba keeps spheres round).
const PLACEMENTS: [&str; 3] = [
    "",
    r#"<scale x="0.5" y="1.5" z="0.8"/><rotate x="1" y="1" z="0" angle="40"/><translate x="3" y="1"/>"#,
    r#"<scale x="-1" y="1" z="1.2"/><rotate z="1" angle="-75"/><translate x="-3" y="-2" z="0.5"/>"#,
];
const BALL: &str = r#"<scale value="1.5"/><rotate y="1" angle="30"/><translate y="4"/>"#;

#[test]
fn mitsuba_instances_hit_what_the_placed_shapes_hit() {
    let dir = tmpdir("instances");
    std::fs::write(dir.join("torus.ply"), torus_ply(24)).unwrap();
    let mut instanced = format!(
        "{SENSORLESS_BSDFS}\n<shape type=\"shapegroup\" id=\"g\">{}</shape>\n<shape type=\"shapegroup\" id=\"ball\"><shape type=\"sphere\"><ref id=\"metal\"/></shape></shape>\n",
        group_shapes("")
    );
    for t in PLACEMENTS {
        instanced += &format!(
            "<shape type=\"instance\"><ref id=\"g\"/><transform name=\"to_world\">{t}</transform></shape>\n"
        );
    }
    instanced += &format!("<shape type=\"instance\"><ref id=\"ball\"/><transform name=\"to_world\">{BALL}</transform></shape>\n");
    let mut flat = format!("{SENSORLESS_BSDFS}\n");
    for t in PLACEMENTS {
        flat += &group_shapes(t);
    }
    flat += &format!("<shape type=\"sphere\"><ref id=\"metal\"/><transform name=\"to_world\">{BALL}</transform></shape>\n");
    let a = load_at(&dir.join("a.xml"), &scene(&instanced));
    let b = load_at(&dir.join("b.xml"), &scene(&flat));
    let g = &a.scene.geometry;
    // One copy of the torus however often it is placed: no mesh of the world's own.
    assert_eq!((g.groups().len(), g.instances().len()), (2, 4));
    assert!(g.meshes().is_empty() && g.objects().is_empty());
    assert_eq!(g.groups()[0].meshes()[0].len(), 2 * 24 * 24);
    assert_eq!(a.mesh_stats.unwrap().0, 2 * 24 * 24);
    // Copies: three tori and the mirrored rectangle (two triangles).
    assert_eq!(b.mesh_stats.unwrap().0, 3 * 2 * 24 * 24 + 2);
    let hits = same_hits(&a.scene, &b.scene, &rays(3, 40_000));
    assert!(hits > 5_000, "{hits}");
    // The shape output variable tells the instances' shapes apart: 4 groups' shapes.
    let mut st = RayStats::default();
    let mut shapes = std::collections::BTreeSet::new();
    for r in rays(4, 5000) {
        if let Some(h) = a.scene.intersect(&r, &mut st) {
            shapes.insert(a.scene.shape_index(&h));
        }
    }
    assert_eq!(
        shapes.into_iter().collect::<Vec<_>>(),
        (0..10).collect::<Vec<u32>>()
    );
}

#[test]
fn a_shapegroup_alone_renders_nothing() {
    let dir = tmpdir("instances-alone");
    std::fs::write(dir.join("torus.ply"), torus_ply(8)).unwrap();
    let l = load_at(
        &dir.join("a.xml"),
        &scene(&format!(
            "{SENSORLESS_BSDFS}\n<shape type=\"shapegroup\" id=\"g\">{}</shape>",
            group_shapes("")
        )),
    );
    let g = &l.scene.geometry;
    assert_eq!((g.groups().len(), g.instances().len()), (1, 0));
    let mut st = RayStats::default();
    assert!(rays(5, 2000)
        .iter()
        .all(|r| l.scene.intersect(r, &mut st).is_none()));
}

#[test]
fn bad_instances_are_errors_at_their_position() {
    let group = r#"<shape type="shapegroup" id="g"><shape type="sphere"/></shape>"#;
    // No reference.
    assert_eq!(
        error_of(&scene(&format!("{group}\n<shape type=\"instance\"/>"))),
        "3:1: an instance needs a <ref id=\"...\"/> to a shapegroup"
    );
    // A reference to nothing.
    let e = error_of(&scene(&format!(
        "{group}\n<shape type=\"instance\"><ref id=\"nope\"/></shape>"
    )));
    assert_eq!(e, "3:33: unknown id 'nope'");
    // A reference to a shape that is not a shapegroup.
    assert_eq!(
        error_of(&scene(
            "<shape type=\"sphere\" id=\"s\"/>\n<shape type=\"instance\"><ref id=\"s\"/></shape>"
        )),
        "3:24: an instance must refer to a shapegroup, not <shape type=\"sphere\">"
    );
    // Emitters inside a group, or on an instance.
    assert_eq!(
        error_of(&scene(
            "<shape type=\"shapegroup\" id=\"g\"><shape type=\"sphere\">\n<emitter type=\"area\"/></shape></shape>"
        )),
        "3:1: a shapegroup cannot contain emitters (instanced emitters are not supported, as in Mitsuba 3)"
    );
    assert_eq!(
        error_of(&scene(&format!(
            "{group}\n<shape type=\"instance\"><ref id=\"g\"/><emitter type=\"area\"/></shape>"
        ))),
        "3:37: an instance cannot have an emitter (instanced emitters are not supported, as in Mitsuba 3)"
    );
    // Nested instancing.
    assert_eq!(
        error_of(&scene(
            "<shape type=\"shapegroup\" id=\"g\">\n<shape type=\"shapegroup\" id=\"h\"><shape type=\"sphere\"/></shape></shape>"
        )),
        "3:1: nested instancing is not supported: a shapegroup cannot contain <shape type=\"shapegroup\">"
    );
    assert_eq!(
        error_of(&scene(&format!(
            "{group}\n<shape type=\"shapegroup\" id=\"h\">  <shape type=\"instance\"><ref id=\"g\"/></shape></shape>"
        ))),
        "3:35: nested instancing is not supported: a shapegroup cannot contain <shape type=\"instance\">"
    );
    // A singular placement.
    let e = error_of(&scene(&format!(
        "{group}\n<shape type=\"instance\"><ref id=\"g\"/><transform name=\"to_world\"><scale x=\"0\"/></transform></shape>"
    )));
    assert!(e.starts_with("3:") && e.contains("singular"), "{e}");
}

/// The course's `instance(NAME, T)` of a named mesh shares it; the image-relevant hits are
/// those of meshes placed one by one.
#[test]
fn course_instances_of_a_mesh_share_it() {
    let dir = tmpdir("course-instances");
    std::fs::write(dir.join("torus.ply"), torus_ply(24)).unwrap();
    let placements = [
        "identity",
        "translation([3, 1, 0]) * rotation([1, 1, 0], 40) * scaling([0.5, 1.5, 0.8])",
        "translation([-3, -2, 0.5]) * rotation_z(-75) * scaling([-1, 1, 1.2])",
    ];
    let head =
        "material red(diffuse(<0.8, 0.2, 0.2>))\nmaterial lamp(diffuse(<0, 0, 0>), <1, 1, 1>)\n";
    let own = "rotation_x(20)";
    let mut instanced = format!("{head}shape t(mesh(red, {own}, \"torus.ply\"))\n");
    let mut flat = head.to_string();
    for p in placements {
        instanced += &format!("instance(t, {p})\n");
        flat += &format!("mesh(red, {p} * {own}, \"torus.ply\")\n");
    }
    let load = |name: &str, text: &str| {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        load_scene(&path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
    };
    let a = load("a.txt", &instanced);
    let b = load("b.txt", &flat);
    let g = &a.scene.geometry;
    assert_eq!((g.groups().len(), g.instances().len()), (1, 3));
    assert!(g.meshes().is_empty());
    assert_eq!(b.scene.geometry.meshes().len(), 3);
    let hits = same_hits(&a.scene, &b.scene, &rays(6, 40_000));
    assert!(hits > 3_000, "{hits}");
    // An emitting mesh is still copied (groups hold no emitters): an area light per copy.
    let c = load(
        "c.txt",
        &format!("{head}shape t(mesh(lamp, identity, \"torus.ply\"))\ninstance(t, translation([0, 0, 1]))\nt\n"),
    );
    assert!(c.scene.geometry.instances().is_empty());
    assert_eq!(c.scene.geometry.meshes().len(), 2);
    assert_eq!(c.scene.lights.len(), 2);
}

/// The distinct CSG nodes of `csg`, following shared trees once each, and the number of trees.
fn distinct_csg_nodes(csg: &candela_render::shape::Csg) -> (usize, usize) {
    use candela_render::shape::{Csg, CsgNode};
    let mut seen: Vec<*const Csg> = vec![];
    let mut todo = vec![csg];
    let mut nodes = 0;
    while let Some(t) = todo.pop() {
        nodes += t.nodes().len();
        for n in t.nodes() {
            if let CsgNode::Shared { tree, .. } = n {
                if !seen.contains(&std::sync::Arc::as_ptr(tree)) {
                    seen.push(std::sync::Arc::as_ptr(tree));
                    todo.push(tree);
                }
            }
        }
    }
    (nodes, seen.len())
}

/// The CSG trees of the scene's objects.
fn csg_trees(s: &Scene) -> Vec<&candela_render::shape::Csg> {
    s.geometry
        .objects()
        .iter()
        .filter_map(|o| match &o.shape {
            candela_render::shape::Shape::Csg(c) => Some(&**c),
            _ => None,
        })
        .collect()
}

/// Named CSG shapes used several times share one tree (placed by a transformation, rays
/// entering by its inverse), and hit what the same trees written out in full hit: every
/// operation, rotations, a non-uniform scaling, a placed copy of the whole.
#[test]
fn course_named_csg_shapes_share_their_tree() {
    let dir = tmpdir("course-csg");
    let head = "material red(diffuse(<0.8, 0.2, 0.2>))\nmaterial blue(diffuse(<0.2, 0.2, 0.8>))\n";
    let a = |t: &str| {
        format!("difference(box(red, identity), sphere(blue, scaling([1.3, 1.3, 1.3])), {t})")
    };
    let ta = "translation([3, 0, 0]) * rotation_z(30)";
    let b = |t: &str| format!("union({}, {}, {t})", a("identity"), a(ta));
    let tb = "translation([0, 3, 0]) * scaling([1, 0.5, 1])";
    let c = |t: &str| format!("fusion({}, {}, {t})", b("identity"), b(tb));
    let tc = "translation([-4, -4, 0]) * rotation_x(15)";
    let d = |t: &str| {
        format!(
            "intersection({}, box(blue, scaling([9, 9, 0.8])), {t})",
            c("identity")
        )
    };
    let shared = format!(
        "{head}shape a({})\nshape b(union(a, instance(a, {ta})))\nshape c(fusion(b, instance(b, {tb})))\nc\ninstance(c, {tc})\nintersection(c, box(blue, scaling([9, 9, 0.8])), translation([0, 0, 0.5]))\n",
        a("identity")
    );
    let flat = format!(
        "{head}{}\n{}\n{}\n",
        c("identity"),
        c(tc),
        d("translation([0, 0, 0.5])")
    );
    let load = |name: &str, text: &str| {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        load_scene(&path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
    };
    let s = load("shared.txt", &shared);
    let f = load("flat.txt", &flat);
    let (ts, tf) = (csg_trees(&s.scene), csg_trees(&f.scene));
    assert_eq!((ts.len(), tf.len()), (3, 3));
    for (x, y) in ts.iter().zip(&tf) {
        assert_eq!(x.leaves(), y.leaves());
    }
    assert_eq!(ts[0].leaves(), 8);
    // The three placements of c hold one copy of a's, b's and c's nodes between them.
    let flat_nodes: usize = tf.iter().map(|t| t.nodes().len()).sum();
    assert_eq!(flat_nodes, 3 * 15 + 2);
    let (shared_nodes, trees) = ts
        .iter()
        .map(|t| distinct_csg_nodes(t))
        .fold((0, 0), |a, b| (a.0 + b.0, a.1.max(b.1)));
    assert_eq!(trees, 3);
    assert!(shared_nodes < 3 * 15, "{shared_nodes}");
    // The same surface up to round-off, but for rays grazing an edge where round-off may pick
    // the other surface (a box's corners meet the subtracted sphere's surface at shallow angles).
    let mut st = RayStats::default();
    let (mut hits, mut differ) = (0, 0);
    let rays = rays(9, 40_000);
    for r in &rays {
        match (s.scene.interact(r, &mut st), f.scene.interact(r, &mut st)) {
            (Some(x), Some(y))
                if (x.p - y.p).norm() < 1e-4
                    && x.n.to_vec().approx_eq(y.n.to_vec(), 1e-3)
                    && x.props.material == y.props.material =>
            {
                hits += 1
            }
            (None, None) => {}
            (x, y) => {
                eprintln!("{:?} {:?}", x.map(|x| (x.p, x.n)), y.map(|y| (y.p, y.n)));
                differ += 1
            }
        }
    }
    assert!(hits > 5_000, "{hits}");
    assert!(
        differ * 2000 < rays.len(),
        "{differ} of {} rays differ",
        rays.len()
    );
}

/// A chain of 40 named doublings (2⁴⁰ solids expanded) is refused by its expanded size at the
/// level that crosses the limit, without building the expansion; 16 levels (65 536 solids)
/// load as 16 shared nodes.
#[test]
fn csg_doubling_chains_are_refused_by_their_expanded_size_only() {
    let dir = tmpdir("csg-chain");
    let chain = |n: usize| {
        let mut s =
            String::from("material m(diffuse(<0.5, 0.5, 0.5>))\nshape s0(sphere(m, identity))\n");
        for i in 1..=n {
            s += &format!(
                "shape s{i}(union(s{p}, instance(s{p}, translation([0, 0, 0.25]))))\n",
                p = i - 1
            );
        }
        s + &format!("s{n}\n")
    };
    let path = dir.join("chain16.txt");
    std::fs::write(&path, chain(16)).unwrap();
    let s = load_scene(&path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let t = csg_trees(&s.scene);
    assert_eq!(t[0].leaves(), 1 << 16);
    let (nodes, trees) = distinct_csg_nodes(t[0]);
    assert_eq!(trees, 16);
    assert!(nodes <= 3 * 16 + 1, "{nodes}");
    let path = dir.join("chain40.txt");
    std::fs::write(&path, chain(40)).unwrap();
    let e = load_scene(&path, &LoadOptions::default())
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("chain40.txt:19:11: the CSG tree expands to 131072 solids, more than 65536"),
        "{e}"
    );
}
