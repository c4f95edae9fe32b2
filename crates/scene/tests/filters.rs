//! Reconstruction filters through both scene formats: the candela language's `filter(…)`
//! statement, Mitsuba's `<rfilter>` (Gaussian when the film names none), and a rendered sharp
//! edge against its analytic filtered value.

mod support;

use candela_render::filter::{Filter, FILTER_NAMES};
use candela_render::integrator::OnOff;
use candela_render::render::{render, RenderSettings};
use candela_scene::{load_scene, LoadOptions};
use support::lang::{error_of, parse};
use support::mitsuba::{error_of as xml_error_of, load, scene, tmpdir};

#[test]
fn the_candela_language_names_filters_and_defaults_to_none() {
    assert_eq!(parse("float x(1)").filter, None);
    let f = |text: &str| parse(text).filter.unwrap().0;
    assert_eq!(f("filter(box)"), Filter::Box);
    assert_eq!(f("filter(gaussian)"), Filter::Gaussian { stddev: 0.5 });
    assert_eq!(f("filter(gaussian, 0.3)"), Filter::Gaussian { stddev: 0.3 });
    assert_eq!(f("filter(tent, 1.5)"), Filter::Tent { radius: 1.5 });
    assert_eq!(
        f("filter(mitchell, 0, 0.5)"),
        Filter::Mitchell { b: 0.0, c: 0.5 }
    );
    assert_eq!(f("filter(catmullrom)"), Filter::Mitchell { b: 0.0, c: 0.5 });
    assert_eq!(f("filter(lanczos, 2)"), Filter::Lanczos { lobes: 2 });
    assert!(error_of("filter(sinc)").starts_with("1:8: unknown filter 'sinc'"));
    assert!(error_of("filter(box)\nfilter(tent)").starts_with("2:1: a second filter"));
    assert!(error_of("filter(lanczos, 2.5)").starts_with("1:17: the number of lobes"));
    assert!(error_of("filter(box, 1)").starts_with("1:11: expected ')'"));
}

#[test]
fn mitsuba_films_read_their_rfilter_and_default_to_a_gaussian() {
    let with = |film_body: &str| {
        let xml = scene(&format!(
            r#"<sensor type="perspective"><film type="hdrfilm">{film_body}</film></sensor>"#
        ));
        load(&xml).hints.filter
    };
    let gaussian = Some(Filter::Gaussian { stddev: 0.5 });
    assert_eq!(with(""), gaussian);
    assert_eq!(load(&scene("")).hints.filter, gaussian);
    assert_eq!(with(r#"<rfilter type="box"/>"#), Some(Filter::Box));
    assert_eq!(
        with(r#"<rfilter type="tent"><float name="radius" value="2"/></rfilter>"#),
        Some(Filter::Tent { radius: 2.0 })
    );
    assert_eq!(
        with(r#"<rfilter type="gaussian"><float name="stddev" value="0.25"/></rfilter>"#),
        Some(Filter::Gaussian { stddev: 0.25 })
    );
    assert_eq!(
        with(r#"<rfilter type="mitchell"/>"#),
        Some(Filter::Mitchell {
            b: 1.0 / 3.0,
            c: 1.0 / 3.0
        })
    );
    assert_eq!(
        with(r#"<rfilter type="catmullrom"/>"#),
        Some(Filter::Mitchell { b: 0.0, c: 0.5 })
    );
    assert_eq!(
        with(r#"<rfilter type="lanczos"><integer name="lobes" value="2"/></rfilter>"#),
        Some(Filter::Lanczos { lobes: 2 })
    );
    let e = xml_error_of(&scene(
        r#"<sensor type="perspective"><film type="hdrfilm"><rfilter type="sinc"/></film></sensor>"#,
    ));
    assert!(e.contains("unknown reconstruction filter 'sinc'"), "{e}");
}

/// ∫_a^b g by composite Simpson.
fn integral(f: &Filter, a: f64, b: f64) -> f64 {
    let n = 4000;
    let h = (b - a) / n as f64;
    let mut s = f.eval_1d(a) + f.eval_1d(b);
    for i in 1..n {
        s += f.eval_1d(a + i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * h / 3.0
}

/// A vertical edge at image column 8.3 of a 16×8 orthogonal view: everything to its right is
/// hit (`onoff` gives 1), nothing to its left. Each pixel's value is the normalised filter's
/// integral beyond the edge, ∫_{8.3 − c}^{r} g / ∫ g for a pixel centred at column c.
#[test]
fn a_sharp_edge_is_filtered_as_the_filter_says() {
    const W: usize = 16;
    const H: usize = 8;
    const EDGE: f64 = 8.3;
    let dir = tmpdir("filter-edge");
    for name in FILTER_NAMES {
        // Screen y ∈ [-2, 2] (aspect 2), left edge at y = 2, 0.25 per pixel.
        let y_edge = 2.0 - 0.25 * EDGE;
        let text = format!(
            "material m(diffuse(<1, 1, 1>))\n\
             parallelogram(m, [1, -20, -20], [0, {}, 0], [0, 0, 40])\n\
             camera(orthogonal, identity, 2, 1)\n\
             filter({name})\n",
            y_edge + 20.0
        );
        let path = dir.join(format!("{name}.txt"));
        std::fs::write(&path, text).unwrap();
        let loaded = load_scene(&path, &LoadOptions::default()).unwrap();
        let filter = loaded.hints.filter.unwrap();
        let settings = RenderSettings {
            width: W,
            height: H,
            spp: 1024,
            filter,
            ..Default::default()
        };
        let image = render(&loaded.scene, &OnOff, &settings, &|_| {}).image;
        let r = filter.radius() as f64;
        let total = integral(&filter, -r, r);
        for x in 0..W {
            let c = x as f64 + 0.5;
            let lo = (EDGE - c).clamp(-r, r);
            let expected = integral(&filter, lo, r) / total;
            let got: f64 = (0..H).map(|y| image.get(x, y).r as f64).sum::<f64>() / H as f64;
            assert!(
                (got - expected).abs() < 0.01,
                "{name}: column {x}: {got:.4} vs {expected:.4}"
            );
        }
    }
}
