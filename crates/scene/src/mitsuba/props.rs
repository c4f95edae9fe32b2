//! Plugin parameters: property values parsed from the XML elements (numbers, colours,
//! spectra, vectors, transforms, references), and [`Props`], the one reader of typed plugin
//! parameters, which remembers what was read so that the rest can be reported.

use super::math::M4;
use super::spectra::SpectrumValue;
use super::xml::{Attr, Element};
use crate::error::{Pos, SceneError, SourceFile};
use std::cell::Cell;
use std::collections::HashMap;

/// A parsed property value.
#[derive(Clone, Debug)]
pub(super) enum Value<'t> {
    /// `<float>`.
    Float(f64),
    /// `<integer>`.
    Int(i64),
    /// `<boolean>`.
    Bool(bool),
    /// `<string>`.
    Str(&'t str),
    /// `<rgb>`.
    Rgb([f64; 3]),
    /// A `<spectrum>` (see `spectra.rs`).
    Spectrum(candela_render::spectrum::Spectrum),
    /// A `<spectrum filename="…">`, read when the property is used.
    SpectrumFile(&'t str, Pos),
    /// `<point>` or `<vector>`.
    Vector([f64; 3]),
    /// `<transform>`.
    Transform(M4),
    /// A nested plugin, or the target of a `<ref>`.
    Object(&'t Element),
}

impl Value<'_> {
    /// What the value is, for messages ("a float", "<bsdf type=\"diffuse\">").
    pub fn describe(&self) -> String {
        match self {
            Value::Float(_) => "a float".into(),
            Value::Int(_) => "an integer".into(),
            Value::Bool(_) => "a boolean".into(),
            Value::Str(_) => "a string".into(),
            Value::Rgb(_) | Value::Spectrum(_) | Value::SpectrumFile(..) => "a colour".into(),
            Value::Vector(_) => "a point or vector".into(),
            Value::Transform(_) => "a transform".into(),
            Value::Object(e) => e.describe(),
        }
    }
}

/// Types that a property can be read as.
pub(super) trait FromValue: Sized {
    /// What the property must be, for messages ("a float").
    const WHAT: &'static str;
    /// The value as `Self`, or `None` when the types do not match.
    fn from_value(v: &Value) -> Option<Self>;
}

impl FromValue for f64 {
    const WHAT: &'static str = "a number";
    fn from_value(v: &Value) -> Option<Self> {
        match *v {
            Value::Float(x) => Some(x),
            Value::Int(i) => Some(i as f64),
            _ => None,
        }
    }
}

impl FromValue for f32 {
    const WHAT: &'static str = "a number";
    fn from_value(v: &Value) -> Option<Self> {
        f64::from_value(v)
            .map(|x| x as f32)
            .filter(|x| x.is_finite())
    }
}

/// `FromValue` for types held by exactly one variant of [`Value`].
macro_rules! from_variant {
    ($($t:ty: $what:literal, $variant:ident;)*) => {$(
        impl FromValue for $t {
            const WHAT: &'static str = $what;
            fn from_value(v: &Value) -> Option<Self> {
                match *v {
                    Value::$variant(x) => Some(x),
                    _ => None,
                }
            }
        }
    )*};
}

from_variant! {
    i64: "an integer", Int;
    bool: "a boolean", Bool;
    [f64; 3]: "a point or vector", Vector;
    M4: "a transform", Transform;
}

impl FromValue for String {
    const WHAT: &'static str = "a string";
    fn from_value(v: &Value) -> Option<Self> {
        match v {
            Value::Str(s) => Some(s.to_string()),
            _ => None,
        }
    }
}

/// One property of a plugin.
pub(super) struct Item<'t> {
    /// The `name` attribute (`None` for unnamed nested plugins).
    pub name: Option<String>,
    /// The value.
    pub value: Value<'t>,
    /// Where the property is written.
    pub pos: Pos,
    used: Cell<bool>,
}

/// The parameters of one plugin element, read by type with defaults; remembers which were read
/// so that the rest can be reported.
pub(super) struct Props<'t> {
    /// The plugin element.
    pub owner: &'t Element,
    items: Vec<Item<'t>>,
    /// Remarks found while parsing (reported with the unused parameters).
    notes: Vec<(Pos, String)>,
    src: SourceFile,
}

impl<'t> Props<'t> {
    /// Parses the properties of `owner`. `ids` resolves `<ref>`s; `upgrade` converts the
    /// camelCase names of Mitsuba 0.6 files.
    pub fn new(
        owner: &'t Element,
        ids: &HashMap<String, &'t Element>,
        src: &SourceFile,
        upgrade: bool,
    ) -> Result<Self, SceneError> {
        let mut items: Vec<Item<'t>> = Vec::new();
        let mut notes = Vec::new();
        for c in &owner.children {
            let err = |msg: String| src.error(c.pos, msg);
            let name = c.get("name").map(|n| {
                if upgrade {
                    camel_to_underscore(n)
                } else {
                    n.to_string()
                }
            });
            let need = |attr: &str| {
                c.attr(attr)
                    .ok_or_else(|| err(format!("<{}> needs the attribute '{attr}'", c.tag)))
            };
            let value = match c.tag.as_str() {
                "float" => Value::Float(number(src, need("value")?)?),
                "integer" => {
                    let a = need("value")?;
                    Value::Int(a.value.trim().parse::<i64>().map_err(|e| {
                        let why = match e.kind() {
                            std::num::IntErrorKind::PosOverflow
                            | std::num::IntErrorKind::NegOverflow => "is out of range",
                            _ => "is not an integer",
                        };
                        src.error(a.pos, format!("'{}' {why}", a.value))
                    })?)
                }
                "boolean" => {
                    let a = need("value")?;
                    match a.value.trim().to_ascii_lowercase().as_str() {
                        "true" => Value::Bool(true),
                        "false" => Value::Bool(false),
                        _ => {
                            return Err(src.error(
                                a.pos,
                                format!("'{}' is not a boolean (true or false)", a.value),
                            ))
                        }
                    }
                }
                "string" => Value::Str(&need("value")?.value),
                "rgb" => {
                    let a = need("value")?;
                    match numbers(src, a)?.as_slice() {
                        [v] => Value::Rgb([*v; 3]),
                        [r, g, b] => Value::Rgb([*r, *g, *b]),
                        v => {
                            return Err(src.error(
                                a.pos,
                                format!("<rgb> needs one or three values, not {}", v.len()),
                            ))
                        }
                    }
                }
                "spectrum" => match super::spectra::spectrum_value(src, c)? {
                    SpectrumValue::Spectrum(s) => Value::Spectrum(s),
                    SpectrumValue::File(f, pos) => Value::SpectrumFile(f, pos),
                    SpectrumValue::Rgb(c) => Value::Rgb(c),
                },
                "point" | "vector" => Value::Vector(vector(src, c, 0.0, true)?),
                "transform" => Value::Transform(transform(src, c, &mut notes)?),
                "ref" => {
                    let a = need("id")?;
                    let target = ids
                        .get(a.value.as_str())
                        .ok_or_else(|| src.error(a.pos, format!("unknown id '{}'", a.value)))?;
                    Value::Object(target)
                }
                "bsdf" | "texture" | "emitter" | "shape" | "sensor" | "film" | "sampler"
                | "rfilter" | "integrator" | "medium" | "phase" | "volume" => Value::Object(c),
                "default" | "alias" | "path" => continue,
                "translate" | "rotate" | "scale" | "matrix" | "lookat" => {
                    return Err(err(format!(
                        "<{}> can only appear inside a <transform>",
                        c.tag
                    )))
                }
                "include" => {
                    return Err(err(
                        "<include> is not supported: paste the included file instead".into(),
                    ))
                }
                t => return Err(err(format!("unknown element <{t}>"))),
            };
            if !matches!(value, Value::Object(_)) {
                match c.children.first() {
                    // Transforms and spectrum plugins (`<spectrum type="…">`) have children.
                    Some(g)
                        if !(matches!(value, Value::Transform(_))
                            || (c.tag == "spectrum" && c.attr("type").is_some())) =>
                    {
                        return Err(src.error(
                            g.pos,
                            format!("<{}> cannot appear inside the property <{}>", g.tag, c.tag),
                        ))
                    }
                    _ => {}
                }
                if name.is_none() {
                    return Err(err(format!("<{}> needs the attribute 'name'", c.tag)));
                }
            }
            if let Some(n) = &name {
                if items.iter().any(|i| i.name.as_ref() == Some(n)) {
                    return Err(err(format!("the parameter '{n}' is given twice")));
                }
            }
            items.push(Item {
                name,
                value,
                pos: c.pos,
                used: Cell::new(false),
            });
        }
        if upgrade && owner.kind() == "diffuse" {
            for i in &mut items {
                if i.name.as_deref() == Some("diffuse_reflectance") {
                    i.name = Some("reflectance".into());
                }
            }
        }
        Ok(Self {
            owner,
            items,
            notes,
            src: src.clone(),
        })
    }

    /// An error at `pos`.
    pub fn error(&self, pos: Pos, msg: impl Into<String>) -> SceneError {
        self.src.error(pos, msg)
    }

    /// The property `name` (marked as read).
    pub fn item(&self, name: &str) -> Option<&Item<'t>> {
        let i = self
            .items
            .iter()
            .find(|i| i.name.as_deref() == Some(name))?;
        i.used.set(true);
        Some(i)
    }

    /// Where the property `name` is written, or the plugin's position.
    pub fn pos(&self, name: &str) -> Pos {
        self.items
            .iter()
            .find(|i| i.name.as_deref() == Some(name))
            .map_or(self.owner.pos, |i| i.pos)
    }

    /// True when the property `name` is given.
    pub fn has(&self, name: &str) -> bool {
        self.items.iter().any(|i| i.name.as_deref() == Some(name))
    }

    /// The property `name` as a `T` with its position, `None` when absent, an error when it has
    /// another type.
    pub fn get<T: FromValue>(&self, name: &str) -> Result<Option<(T, Pos)>, SceneError> {
        let Some(i) = self.item(name) else {
            return Ok(None);
        };
        match T::from_value(&i.value) {
            Some(v) => Ok(Some((v, i.pos))),
            None => Err(self.error(
                i.pos,
                format!("'{name}' must be {}, not {}", T::WHAT, i.value.describe()),
            )),
        }
    }

    /// The property `name` as a `T`, or `default`.
    pub fn or<T: FromValue>(&self, name: &str, default: T) -> Result<T, SceneError> {
        Ok(self.get(name)?.map_or(default, |(v, _)| v))
    }

    /// A number that must lie in `range` (inclusive), or `default`.
    pub fn number_in(
        &self,
        name: &str,
        default: f64,
        range: (f64, f64),
    ) -> Result<f64, SceneError> {
        self.in_range(name, default, range)
    }

    /// An integer that must lie in `range` (inclusive), or `default`.
    pub fn int_in(&self, name: &str, default: i64, range: (i64, i64)) -> Result<i64, SceneError> {
        self.in_range(name, default, range)
    }

    /// A value that must lie in `range` (inclusive; NaN does not), or `default`.
    fn in_range<T: FromValue + PartialOrd + std::fmt::Display>(
        &self,
        name: &str,
        default: T,
        range: (T, T),
    ) -> Result<T, SceneError> {
        let v = self.or(name, default)?;
        if !(v >= range.0 && v <= range.1) {
            return Err(self.error(
                self.pos(name),
                format!(
                    "'{name}' must be between {} and {}, not {v}",
                    range.0, range.1
                ),
            ));
        }
        Ok(v)
    }

    /// A lower-case string among `choices` (the first is the default).
    pub fn choice(&self, name: &str, choices: &[&str]) -> Result<String, SceneError> {
        let v = self.or(name, choices[0].to_string())?.to_ascii_lowercase();
        if !choices.contains(&v.as_str()) {
            return Err(self.error(
                self.pos(name),
                format!("'{name}' must be one of {}, not '{v}'", choices.join(", ")),
            ));
        }
        Ok(v)
    }

    /// The nested plugins (or `<ref>` targets) with tag `tag`, named or not (marked as read).
    pub fn objects(&self, tag: &str) -> Vec<(&'t Element, Pos)> {
        self.items
            .iter()
            .filter_map(|i| match i.value {
                Value::Object(e) if e.tag == tag => {
                    i.used.set(true);
                    Some((e, i.pos))
                }
                _ => None,
            })
            .collect()
    }

    /// At most one nested plugin with tag `tag`.
    pub fn object(&self, tag: &str) -> Result<Option<(&'t Element, Pos)>, SceneError> {
        let all = self.objects(tag);
        if let Some(second) = all.get(1) {
            return Err(self.error(
                second.1,
                format!("{} takes a single <{tag}>", self.owner.describe()),
            ));
        }
        Ok(all.first().copied())
    }

    /// Marks parameters that have no effect on candela's image as read.
    pub fn ignore(&self, names: &[&str]) {
        for n in names {
            self.item(n);
        }
    }

    /// Warnings with positions: remarks, and the parameters nobody read (unknown or
    /// unsupported).
    pub fn unused(&self) -> Vec<(Pos, String)> {
        let what = self.owner.describe();
        let unused = self.items.iter().filter(|i| !i.used.get()).map(|i| {
            let msg = match (&i.name, &i.value) {
                (Some(n), _) => {
                    format!("{what}: unknown or unsupported parameter '{n}' is ignored")
                }
                (None, Value::Object(e)) => {
                    format!("{what}: unexpected nested {} is ignored", e.describe())
                }
                (None, _) => format!("{what}: unnamed property is ignored"),
            };
            (i.pos, msg)
        });
        self.notes.iter().cloned().chain(unused).collect()
    }
}

/// Mitsuba 0.6's camelCase parameter names → Mitsuba 3's snake_case.
fn camel_to_underscore(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 4);
    let mut prev_lower = false;
    for c in s.chars() {
        if c.is_ascii_uppercase() && prev_lower {
            out.push('_');
        }
        prev_lower = c.is_ascii_lowercase();
        out.push(c.to_ascii_lowercase());
    }
    out
}

/// A finite number.
fn number(src: &SourceFile, a: &Attr) -> Result<f64, SceneError> {
    parse_number(&a.value)
        .ok_or_else(|| src.error(a.pos, format!("'{}' is not a finite number", a.value)))
}

fn parse_number(s: &str) -> Option<f64> {
    s.trim()
        .parse::<f64>()
        .ok()
        .filter(|x| x.is_finite() && x.abs() <= f32::MAX as f64)
}

/// The numbers of a list separated by commas and/or spaces.
fn numbers(src: &SourceFile, a: &Attr) -> Result<Vec<f64>, SceneError> {
    a.value
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .map(|t| {
            parse_number(t).ok_or_else(|| src.error(a.pos, format!("'{t}' is not a finite number")))
        })
        .collect()
}

/// x, y, z from the attributes `x`, `y`, `z` (missing ones are `default`) or from `value`
/// (one number for all three, or three numbers).
fn vector(
    src: &SourceFile,
    e: &Element,
    default: f64,
    required: bool,
) -> Result<[f64; 3], SceneError> {
    if let Some(a) = e.attr("value") {
        if ["x", "y", "z"].iter().any(|n| e.attr(n).is_some()) {
            return Err(src.error(a.pos, "use either 'value' or 'x', 'y', 'z', not both"));
        }
        return match numbers(src, a)?.as_slice() {
            [v] => Ok([*v; 3]),
            [x, y, z] => Ok([*x, *y, *z]),
            v => Err(src.error(
                a.pos,
                format!("'value' needs one or three numbers, not {}", v.len()),
            )),
        };
    }
    let mut out = [default; 3];
    for (k, n) in ["x", "y", "z"].iter().enumerate() {
        match e.attr(n) {
            Some(a) => out[k] = number(src, a)?,
            None if required => {
                return Err(src.error(
                    e.pos,
                    format!(
                        "<{}> needs the attributes 'x', 'y' and 'z' (or 'value')",
                        e.tag
                    ),
                ))
            }
            None => {}
        }
    }
    Ok(out)
}

/// Three numbers of an attribute such as `origin="0, 0, 1"`.
fn triple(src: &SourceFile, a: &Attr) -> Result<[f64; 3], SceneError> {
    match numbers(src, a)?.as_slice() {
        [x, y, z] => Ok([*x, *y, *z]),
        v => Err(src.error(
            a.pos,
            format!("'{}' needs three numbers, not {}", a.name, v.len()),
        )),
    }
}

/// A `<transform>`: its children in order, each applied after the previous ones. Remarks for the
/// user go to `notes`.
fn transform(
    src: &SourceFile,
    e: &Element,
    notes: &mut Vec<(Pos, String)>,
) -> Result<M4, SceneError> {
    let mut m = M4::IDENTITY;
    for c in &e.children {
        let err = |msg: &str| src.error(c.pos, msg.to_string());
        let step = match c.tag.as_str() {
            "translate" => M4::translate(vector(src, c, 0.0, false)?),
            "scale" => M4::scale(vector(src, c, 1.0, false)?),
            "rotate" => {
                let angle = c
                    .attr("angle")
                    .ok_or_else(|| err("<rotate> needs the attribute 'angle' (degrees)"))?;
                let angle = number(src, angle)?;
                let axis = vector(src, c, 0.0, false)?;
                let len = axis.iter().map(|x| x * x).sum::<f64>().sqrt();
                if (len - 1.0).abs() > 1e-4 && len > 0.0 {
                    notes.push((
                        c.pos,
                        format!("the rotation axis has length {len:.4}: like Mitsuba 3, candela does not normalise it, so this rotation also scales"),
                    ));
                }
                M4::rotate(axis, angle).ok_or_else(|| err("the rotation axis is zero"))?
            }
            "lookat" => {
                let get = |n: &str| {
                    c.attr(n)
                        .ok_or_else(|| err(&format!("<lookat> needs the attribute '{n}'")))
                };
                let origin = triple(src, get("origin")?)?;
                let target = triple(src, get("target")?)?;
                let up = match c.attr("up") {
                    Some(a) => triple(src, a)?,
                    None => [0.0; 3],
                };
                M4::look_at(origin, target, up).ok_or_else(|| {
                    err("invalid <lookat>: the origin equals the target, or 'up' is parallel to the viewing direction")
                })?
            }
            "matrix" => {
                let a = c
                    .attr("value")
                    .ok_or_else(|| err("<matrix> needs the attribute 'value'"))?;
                let v = numbers(src, a)?;
                M4::from_values(&v).ok_or_else(|| {
                    src.error(
                        a.pos,
                        format!("a matrix needs 9 or 16 numbers, not {}", v.len()),
                    )
                })?
            }
            t => return Err(err(&format!("<{t}> cannot appear inside a <transform>"))),
        };
        m = step.mul(&m);
    }
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camel_case_upgrade() {
        assert_eq!(camel_to_underscore("intIOR"), "int_ior");
        assert_eq!(
            camel_to_underscore("diffuseReflectance"),
            "diffuse_reflectance"
        );
        assert_eq!(camel_to_underscore("toWorld"), "to_world");
        assert_eq!(camel_to_underscore("alpha"), "alpha");
    }
}
