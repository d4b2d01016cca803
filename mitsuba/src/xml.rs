//! The XML layer: positions, `$name` substitution, typed property values.
//!
//! Mitsuba 3 reads a scene as a tree of *objects* (`<bsdf type="…">`,
//! `<shape>`, …) whose children are either *properties* (`<float name="…"
//! value="…"/>` and friends), nested objects, or `<ref id="…"/>` references
//! to objects declared elsewhere. [`Props`] gathers the children of one
//! object so that each plugin can ask for its parameters by name and type,
//! and reports every child nobody asked for — Mitsuba 3 rejects such
//! "unreferenced properties" too, which catches misspelt names.

use std::cell::Cell;
use std::collections::HashMap;

use glam::DMat4;
use roxmltree::{Document, Node, NodeId};

use super::error::LoadError;
use super::input;
use super::transform;

/// Tags that denote objects (plugin instances) rather than properties.
pub(crate) const OBJECT_TAGS: &[&str] = &[
    "bsdf",
    "texture",
    "emitter",
    "shape",
    "sensor",
    "film",
    "sampler",
    "rfilter",
    "integrator",
    "medium",
    "phase",
    "volume",
];

/// A parsed document with everything needed to read attributes and report
/// errors at the right place.
pub(crate) struct Xml<'a> {
    /// The parsed document.
    pub doc: &'a Document<'a>,
    /// Scene file name used in messages.
    pub file: &'a str,
    /// `$name` → value, longest key first (Mitsuba substitutes longer names
    /// first so that `$resx` does not eat the start of `$resx2`).
    params: Vec<Param>,
    /// Objects carrying an `id`, for `<ref>`.
    ids: HashMap<String, Node<'a, 'a>>,
}

struct Param {
    key: String,
    value: String,
    from_command_line: bool,
    used: Cell<bool>,
}

impl<'a> Xml<'a> {
    /// Reads the `<default>` elements (overridden by `defaults`, like
    /// `mitsuba -D`) and indexes the objects that have an `id`.
    pub fn new(
        doc: &'a Document<'a>,
        file: &'a str,
        defaults: &[(String, String)],
    ) -> Result<Self, LoadError> {
        let mut xml = Xml {
            doc,
            file,
            params: Vec::new(),
            ids: HashMap::new(),
        };
        for (k, v) in defaults {
            if k.is_empty() || k.contains('$') {
                return Err(LoadError::whole_file(
                    file,
                    format!("invalid parameter name '{k}' given on the command line"),
                ));
            }
            xml.add_param(k, v.clone(), true);
        }
        // Mitsuba processes <default> while walking the document, so a
        // default applies from its own position on; collecting them first
        // only differs for scenes that use a parameter before declaring it,
        // which Mitsuba rejects anyway.
        for node in doc
            .descendants()
            .filter(|n| n.is_element() && n.tag_name().name() == "default")
        {
            let name = xml.req_attr(node, "name")?;
            if name.is_empty() || name.contains('$') {
                return Err(xml.err(node, format!("<default> has an invalid name '{name}'")));
            }
            let value = xml.req_attr(node, "value")?;
            if !xml.params.iter().any(|p| p.key[1..] == *name) {
                xml.add_param(&name, value, false);
            }
        }
        for node in doc
            .descendants()
            .filter(|n| n.is_element() && OBJECT_TAGS.contains(&n.tag_name().name()))
        {
            if let Some(id) = xml.attr(node, "id")? {
                if let Some(prev) = xml.ids.get(&id) {
                    let (l, c) = xml.pos(*prev);
                    return Err(xml.err(
                        node,
                        format!("duplicate id '{id}' (first declared at line {l}, column {c})"),
                    ));
                }
                xml.ids.insert(id, node);
            }
        }
        Ok(xml)
    }

    fn add_param(&mut self, key: &str, value: String, from_command_line: bool) {
        let p = Param {
            key: format!("${key}"),
            value,
            from_command_line,
            used: Cell::new(false),
        };
        let at = self
            .params
            .iter()
            .position(|q| q.key.len() < p.key.len())
            .unwrap_or(self.params.len());
        self.params.insert(at, p);
    }

    /// Command-line parameters the scene never used (Mitsuba reports these
    /// as errors; we only warn).
    pub fn unused_command_line_params(&self) -> Vec<String> {
        self.params
            .iter()
            .filter(|p| p.from_command_line && !p.used.get())
            .map(|p| p.key[1..].to_string())
            .collect()
    }

    /// 1-based line and column of a node's start tag.
    pub fn pos(&self, node: Node) -> (u32, u32) {
        let p = self.doc.text_pos_at(node.range().start);
        (p.row, p.col)
    }

    /// An error located at `node`.
    pub fn err(&self, node: Node, msg: impl Into<String>) -> LoadError {
        let (l, c) = self.pos(node);
        LoadError::at(self.file, l, c, msg)
    }

    /// A warning located at `node`, formatted like an error.
    pub fn warning(&self, node: Node, msg: impl AsRef<str>) -> String {
        let (l, c) = self.pos(node);
        format!("{}:{l}:{c}: warning: {}", self.file, msg.as_ref())
    }

    /// Attribute value after `$name` substitution.
    pub fn attr(&self, node: Node, name: &str) -> Result<Option<String>, LoadError> {
        match node.attribute(name) {
            None => Ok(None),
            Some(raw) => self.substitute(node, raw).map(Some),
        }
    }

    /// A required attribute.
    pub fn req_attr(&self, node: Node, name: &str) -> Result<String, LoadError> {
        self.attr(node, name)?.ok_or_else(|| {
            self.err(
                node,
                format!(
                    "<{}> lacks the required attribute '{name}'",
                    node.tag_name().name()
                ),
            )
        })
    }

    /// Mitsuba's substitution: every `$key` (longest keys first) is replaced
    /// textually, `\$` escapes a dollar, and any `$name` left over is an
    /// undefined parameter.
    fn substitute(&self, node: Node, raw: &str) -> Result<String, LoadError> {
        if !raw.contains('$') {
            return Ok(raw.to_string());
        }
        let mut value = raw.to_string();
        for p in &self.params {
            if !value.contains(&p.key) {
                continue;
            }
            // One pass per key, building a new string: replacing in place
            // moved the tail once per occurrence (quadratic), and a value
            // that names defaults naming defaults grows exponentially with
            // the depth, so the result is bounded as it is built.
            let mut out = String::new();
            let mut rest = value.as_str();
            while let Some(at) = rest.find(&p.key) {
                let escaped = at > 0 && rest.as_bytes()[at - 1] == b'\\';
                let (piece, replacement) = if escaped {
                    (&rest[..at + p.key.len()], "")
                } else {
                    p.used.set(true);
                    (&rest[..at], p.value.as_str())
                };
                if out.len() + piece.len() + replacement.len() > input::MAX_SUBSTITUTED_BYTES {
                    return Err(self.err(
                        node,
                        format!(
                            "substituting '{}' makes the value longer than {} bytes (defaults that expand into each other?)",
                            p.key,
                            input::MAX_SUBSTITUTED_BYTES
                        ),
                    ));
                }
                out.push_str(piece);
                out.push_str(replacement);
                rest = &rest[at + p.key.len()..];
            }
            if out.len() + rest.len() > input::MAX_SUBSTITUTED_BYTES {
                return Err(self.err(
                    node,
                    format!(
                        "the value is longer than {} bytes after substitution",
                        input::MAX_SUBSTITUTED_BYTES
                    ),
                ));
            }
            out.push_str(rest);
            value = out;
        }
        let bytes = value.as_bytes();
        for (i, &b) in bytes.iter().enumerate() {
            if b == b'$' && !(i > 0 && bytes[i - 1] == b'\\') {
                let name: String = value[i + 1..]
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                return Err(self.err(
                    node,
                    format!("undefined parameter '${name}' (declare it with <default name=\"{name}\" .../> or pass it with -D)"),
                ));
            }
        }
        Ok(value.replace("\\$", "$"))
    }

    /// The object an `<ref id>` points to.
    pub fn resolve(&self, node: Node<'a, 'a>) -> Result<Node<'a, 'a>, LoadError> {
        let id = self.req_attr(node, "id")?;
        self.ids
            .get(&id)
            .copied()
            .ok_or_else(|| self.err(node, format!("reference to unknown id '{id}'")))
    }

    /// Top-level description of an object element for messages, e.g.
    /// `<bsdf type="diffuse" id="Floor">`.
    pub fn describe(&self, node: Node) -> String {
        let tag = node.tag_name().name();
        let ty = node
            .attribute("type")
            .map(|t| format!(" type=\"{t}\""))
            .unwrap_or_default();
        let id = node
            .attribute("id")
            .map(|t| format!(" id=\"{t}\""))
            .unwrap_or_default();
        format!("<{tag}{ty}{id}>")
    }
}

/// Strict number parsing: decimal and exponent notation only. Rust's parser
/// also accepts "nan", "inf" and "infinity", which must never reach the
/// renderer from a scene file; overflow to infinity is rejected too.
pub(crate) fn parse_f64(s: &str) -> Result<f64, String> {
    let t = s.trim();
    if t.is_empty() {
        return Err("empty number".into());
    }
    let lower = t.to_ascii_lowercase();
    if lower.contains("nan") || lower.contains("inf") {
        return Err(format!(
            "'{t}' is not a finite number (NaN and infinity are not allowed)"
        ));
    }
    if !t
        .bytes()
        .all(|b| b.is_ascii_digit() || matches!(b, b'+' | b'-' | b'.' | b'e' | b'E'))
    {
        return Err(format!("'{t}' is not a number"));
    }
    let v: f64 = t.parse().map_err(|_| format!("'{t}' is not a number"))?;
    if !v.is_finite() {
        return Err(format!("'{t}' is out of range"));
    }
    Ok(v)
}

/// Splits a list the way Mitsuba's tokenizer does: on commas and
/// whitespace, dropping empty pieces.
pub(crate) fn tokens(s: &str) -> Vec<&str> {
    s.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .collect()
}

/// A property value, in double precision as Mitsuba's parser keeps it.
#[derive(Clone, Debug)]
pub(crate) enum Value {
    Float(f64),
    Integer(i64),
    Boolean(bool),
    String(String),
    Rgb([f64; 3]),
    Vector([f64; 3]),
    Transform(DMat4),
}

impl Value {
    fn type_name(&self) -> &'static str {
        match self {
            Value::Float(_) => "float",
            Value::Integer(_) => "integer",
            Value::Boolean(_) => "boolean",
            Value::String(_) => "string",
            Value::Rgb(_) => "rgb",
            Value::Vector(_) => "point/vector",
            Value::Transform(_) => "transform",
        }
    }
}

/// What one child of an object element holds.
#[derive(Clone, Debug)]
pub(crate) enum Item<'a> {
    /// A typed value.
    Value(Value),
    /// A nested object, inline or reached through `<ref>`.
    Object(Node<'a, 'a>),
}

/// One child of an object element.
pub(crate) struct Entry<'a> {
    /// The `name` attribute (nested objects and refs may have none).
    pub name: Option<String>,
    /// The child element itself (the `<ref>` for references), for messages.
    pub node: Node<'a, 'a>,
    /// Its content.
    pub item: Item<'a>,
    used: Cell<bool>,
}

impl<'a> Entry<'a> {
    /// The object's tag (`bsdf`, `texture`, …) when the entry is an object.
    pub fn object_tag(&self) -> Option<&'a str> {
        match &self.item {
            Item::Object(n) => Some(n.tag_name().name()),
            Item::Value(_) => None,
        }
    }
}

/// The children of one object element, read once and queried by name.
pub(crate) struct Props<'a> {
    /// The object element.
    pub owner: Node<'a, 'a>,
    /// The plugin name (`type` attribute after substitution).
    pub plugin: String,
    entries: Vec<Entry<'a>>,
}

impl<'a> Props<'a> {
    /// Reads every child element of `owner`.
    pub fn read(xml: &Xml<'a>, owner: Node<'a, 'a>) -> Result<Self, LoadError> {
        let plugin = xml.attr(owner, "type")?.unwrap_or_default();
        let mut entries: Vec<Entry<'a>> = Vec::new();
        for child in owner.children().filter(|n| n.is_element()) {
            let tag = child.tag_name().name();
            let name = xml.attr(child, "name")?;
            let item = match tag {
                "default" => continue,
                "ref" => {
                    let target = xml.resolve(child)?;
                    Item::Object(target)
                }
                t if OBJECT_TAGS.contains(&t) => Item::Object(child),
                "float" | "integer" | "boolean" | "string" | "rgb" | "spectrum" | "point"
                | "vector" | "transform" => {
                    let Some(n) = name.as_deref() else {
                        return Err(xml.err(
                            child,
                            format!("<{tag}> lacks the required attribute 'name'"),
                        ));
                    };
                    Item::Value(read_value(xml, child, tag, n)?)
                }
                "include" | "path" | "alias" => {
                    return Err(xml.err(
                        child,
                        format!("<{tag}> is not supported by cmlt's scene loader"),
                    ));
                }
                "translate" | "rotate" | "scale" | "matrix" | "lookat" => {
                    return Err(xml.err(
                        child,
                        format!("<{tag}> may only appear inside a <transform>"),
                    ));
                }
                other => return Err(xml.err(child, format!("unknown XML element <{other}>"))),
            };
            if let Some(n) = &name
                && let Some(prev) = entries
                    .iter()
                    .find(|e| e.name.as_deref() == Some(n.as_str()))
            {
                let (l, c) = xml.pos(prev.node);
                return Err(xml.err(
                    child,
                    format!("property '{n}' is given twice (first at line {l}, column {c})"),
                ));
            }
            entries.push(Entry {
                name,
                node: child,
                item,
                used: Cell::new(false),
            });
        }
        Ok(Props {
            owner,
            plugin,
            entries,
        })
    }

    /// The entry called `name`, marked as used.
    pub fn get(&self, name: &str) -> Option<&Entry<'a>> {
        let e = self
            .entries
            .iter()
            .find(|e| e.name.as_deref() == Some(name))?;
        e.used.set(true);
        Some(e)
    }

    /// True when a property called `name` exists (does not mark it used).
    pub fn has(&self, name: &str) -> bool {
        self.entries.iter().any(|e| e.name.as_deref() == Some(name))
    }

    /// All nested objects with tag `tag` (named or not), marked as used.
    pub fn objects(&self, tag: &str) -> Vec<&Entry<'a>> {
        let v: Vec<&Entry<'a>> = self
            .entries
            .iter()
            .filter(|e| e.object_tag() == Some(tag))
            .collect();
        for e in &v {
            e.used.set(true);
        }
        v
    }

    fn wrong_type(&self, xml: &Xml, e: &Entry, want: &str) -> LoadError {
        let found = match &e.item {
            Item::Value(v) => v.type_name().to_string(),
            Item::Object(n) => format!("a <{}> object", n.tag_name().name()),
        };
        xml.err(
            e.node,
            format!(
                "property '{}' must be {want}, found {found}",
                e.name.as_deref().unwrap_or("?")
            ),
        )
    }

    /// A float property (an integer is accepted, as in Mitsuba).
    pub fn float(&self, xml: &Xml, name: &str) -> Result<Option<(f64, Node<'a, 'a>)>, LoadError> {
        let Some(e) = self.get(name) else {
            return Ok(None);
        };
        match e.item {
            Item::Value(Value::Float(v)) => Ok(Some((v, e.node))),
            Item::Value(Value::Integer(v)) => Ok(Some((v as f64, e.node))),
            _ => Err(self.wrong_type(xml, e, "a float")),
        }
    }

    /// An integer property.
    pub fn integer(&self, xml: &Xml, name: &str) -> Result<Option<(i64, Node<'a, 'a>)>, LoadError> {
        let Some(e) = self.get(name) else {
            return Ok(None);
        };
        match e.item {
            Item::Value(Value::Integer(v)) => Ok(Some((v, e.node))),
            _ => Err(self.wrong_type(xml, e, "an integer")),
        }
    }

    /// A boolean property.
    pub fn boolean(&self, xml: &Xml, name: &str) -> Result<Option<bool>, LoadError> {
        let Some(e) = self.get(name) else {
            return Ok(None);
        };
        match e.item {
            Item::Value(Value::Boolean(v)) => Ok(Some(v)),
            _ => Err(self.wrong_type(xml, e, "a boolean")),
        }
    }

    /// A string property.
    pub fn string(
        &self,
        xml: &Xml,
        name: &str,
    ) -> Result<Option<(String, Node<'a, 'a>)>, LoadError> {
        let Some(e) = self.get(name) else {
            return Ok(None);
        };
        match &e.item {
            Item::Value(Value::String(v)) => Ok(Some((v.clone(), e.node))),
            _ => Err(self.wrong_type(xml, e, "a string")),
        }
    }

    /// A point or vector property.
    pub fn vector(&self, xml: &Xml, name: &str) -> Result<Option<[f64; 3]>, LoadError> {
        let Some(e) = self.get(name) else {
            return Ok(None);
        };
        match e.item {
            Item::Value(Value::Vector(v)) => Ok(Some(v)),
            _ => Err(self.wrong_type(xml, e, "a point or vector")),
        }
    }

    /// A transform property.
    pub fn transform(
        &self,
        xml: &Xml,
        name: &str,
    ) -> Result<Option<(DMat4, Node<'a, 'a>)>, LoadError> {
        let Some(e) = self.get(name) else {
            return Ok(None);
        };
        match e.item {
            Item::Value(Value::Transform(m)) => Ok(Some((m, e.node))),
            _ => Err(self.wrong_type(xml, e, "a transform")),
        }
    }

    /// A colour given as `rgb`, `float`, `integer` or a uniform `spectrum`.
    /// Nested textures are left to the caller (`Ok(None)` is not returned
    /// for them: the entry is reported as the wrong type unless the caller
    /// handles objects first).
    pub fn color(
        &self,
        xml: &Xml,
        name: &str,
    ) -> Result<Option<([f64; 3], Node<'a, 'a>)>, LoadError> {
        let Some(e) = self.get(name) else {
            return Ok(None);
        };
        match e.item {
            Item::Value(Value::Rgb(v)) => Ok(Some((v, e.node))),
            Item::Value(Value::Float(v)) => Ok(Some(([v; 3], e.node))),
            Item::Value(Value::Integer(v)) => Ok(Some(([v as f64; 3], e.node))),
            _ => Err(self.wrong_type(xml, e, "a colour (rgb or float)")),
        }
    }

    /// Errors on the first child nobody asked for, except names in
    /// `ignored` (parameters that exist in Mitsuba but cannot change the
    /// image, such as a film's file format).
    pub fn finish(&self, xml: &Xml, ignored: &[&str]) -> Result<(), LoadError> {
        for e in &self.entries {
            if e.used.get() {
                continue;
            }
            if let Some(n) = &e.name
                && ignored.contains(&n.as_str())
            {
                continue;
            }
            let owner = xml.describe(self.owner);
            return Err(match (&e.item, &e.name) {
                (Item::Value(_), Some(n)) => xml.err(
                    e.node,
                    format!("unsupported property '{n}' in {owner} (misspelt, or a Mitsuba feature cmlt does not implement)"),
                ),
                (Item::Object(o), _) => {
                    xml.err(e.node, format!("unexpected {} inside {owner}", xml.describe(*o)))
                }
                (Item::Value(_), None) => xml.err(e.node, format!("unnamed property inside {owner}")),
            });
        }
        Ok(())
    }

    /// Names of the unused children, for plugins that only warn.
    pub fn unused(&self) -> Vec<(String, Node<'a, 'a>)> {
        self.entries
            .iter()
            .filter(|e| !e.used.get())
            .map(|e| {
                (
                    e.name
                        .clone()
                        .unwrap_or_else(|| format!("<{}>", e.node.tag_name().name())),
                    e.node,
                )
            })
            .collect()
    }
}

/// Reads one property element.
fn read_value(xml: &Xml, node: Node, tag: &str, name: &str) -> Result<Value, LoadError> {
    let bad = |msg: String| xml.err(node, format!("property '{name}': {msg}"));
    match tag {
        "float" => {
            let v = xml.req_attr(node, "value")?;
            Ok(Value::Float(parse_f64(&v).map_err(bad)?))
        }
        "integer" => {
            let v = xml.req_attr(node, "value")?;
            let t = v.trim();
            t.parse::<i64>()
                .map(Value::Integer)
                .map_err(|_| bad(format!("'{t}' is not an integer")))
        }
        "boolean" => {
            let v = xml.req_attr(node, "value")?;
            match v.trim().to_ascii_lowercase().as_str() {
                "true" => Ok(Value::Boolean(true)),
                "false" => Ok(Value::Boolean(false)),
                _ => Err(bad(format!(
                    "'{v}' is not a boolean (must be \"true\" or \"false\")"
                ))),
            }
        }
        "string" => Ok(Value::String(xml.req_attr(node, "value")?)),
        "rgb" | "spectrum" => {
            if node.attribute("filename").is_some() {
                return Err(bad(
                    "spectra from files are not supported; give an <rgb> value".into(),
                ));
            }
            let v = xml.req_attr(node, "value")?;
            let t = tokens(&v);
            if tag == "spectrum" && (t.len() != 1 || v.contains(':')) {
                return Err(bad(format!(
                    "spectral data '{v}' is not supported (cmlt renders in RGB); give an <rgb> value or a single number"
                )));
            }
            let parsed: Vec<f64> = t
                .iter()
                .map(|s| parse_f64(s))
                .collect::<Result<_, _>>()
                .map_err(|e| bad(format!("bad colour '{v}': {e}")))?;
            match parsed.len() {
                1 => Ok(Value::Rgb([parsed[0]; 3])),
                3 => Ok(Value::Rgb([parsed[0], parsed[1], parsed[2]])),
                n => Err(bad(format!(
                    "bad colour '{v}': expected 1 or 3 values, got {n}"
                ))),
            }
        }
        "point" | "vector" => Ok(Value::Vector(xyz(xml, node, 0.0)?)),
        "transform" => Ok(Value::Transform(transform::parse(xml, node)?)),
        _ => Err(xml.err(node, format!("unknown property tag <{tag}>"))),
    }
}

/// Mitsuba's vector syntax: either `value` with one (replicated) or three
/// numbers, or separate `x`, `y`, `z` attributes defaulting to `default`.
pub(crate) fn xyz(xml: &Xml, node: Node, default: f64) -> Result<[f64; 3], LoadError> {
    let tag = node.tag_name().name();
    let value = xml.attr(node, "value")?;
    let has_xyz = ["x", "y", "z"].iter().any(|a| node.attribute(*a).is_some());
    let num = |s: &str| parse_f64(s).map_err(|e| xml.err(node, format!("<{tag}>: {e}")));
    if let Some(v) = value {
        if has_xyz {
            return Err(xml.err(node, format!("<{tag}> cannot mix 'value' with 'x'/'y'/'z'")));
        }
        let t = tokens(&v);
        return match t.len() {
            1 => {
                let a = num(t[0])?;
                Ok([a; 3])
            }
            3 => Ok([num(t[0])?, num(t[1])?, num(t[2])?]),
            n => Err(xml.err(
                node,
                format!("<{tag}> 'value' must have 1 or 3 numbers, got {n}"),
            )),
        };
    }
    let mut out = [default; 3];
    for (i, a) in ["x", "y", "z"].iter().enumerate() {
        if let Some(s) = xml.attr(node, a)? {
            out[i] = num(&s)?;
        }
    }
    Ok(out)
}

/// Parses three numbers from a string such as `lookat`'s `origin`.
pub(crate) fn three(xml: &Xml, node: Node, what: &str, s: &str) -> Result<[f64; 3], LoadError> {
    let t = tokens(s);
    if t.len() != 3 {
        return Err(xml.err(node, format!("{what} must have 3 numbers, got {}", t.len())));
    }
    let mut out = [0.0; 3];
    for (o, s) in out.iter_mut().zip(t) {
        *o = parse_f64(s).map_err(|e| xml.err(node, format!("{what}: {e}")))?;
    }
    Ok(out)
}

/// Node identity usable as a map key (memoising per-element work).
pub(crate) fn key(node: Node) -> NodeId {
    node.id()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strict_numbers() {
        assert_eq!(parse_f64(" 4.37114e-008 ").unwrap(), 4.37114e-8);
        assert_eq!(parse_f64("-1").unwrap(), -1.0);
        assert_eq!(parse_f64(".5").unwrap(), 0.5);
        for bad in [
            "nan", "NaN", "inf", "-inf", "infinity", "1e999", "", "1,5", "0x10", "1.0f",
        ] {
            assert!(parse_f64(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn tokenizer_accepts_commas_and_spaces() {
        assert_eq!(tokens("0.63, 0.065,0.05"), vec!["0.63", "0.065", "0.05"]);
        assert_eq!(tokens("1 2\t3"), vec!["1", "2", "3"]);
    }

    /// Defaults that each name the next ten times expand to 10^d bytes at
    /// depth d (Mitsuba substitutes a default's value where it is
    /// declared): the first one past the bound is refused at its own line,
    /// quickly; the ones below it expand exactly.
    #[test]
    fn nested_defaults_cannot_expand_without_bound() {
        // Defaults p10 = "x", p09 = ten "$p10", …, down to p{lowest}.
        fn chain(lowest: usize) -> String {
            let mut text =
                String::from("<scene version=\"3.0.0\">\n<default name=\"p10\" value=\"x\"/>\n");
            for d in (lowest..10).rev() {
                let value = format!("$p{:02}", d + 1).repeat(10);
                text += &format!("<default name=\"p{d:02}\" value=\"{value}\"/>\n");
            }
            text + "<integer name=\"n\" value=\"$p04\"/>\n</scene>"
        }
        let text = chain(0);
        let doc = Document::parse(&text).unwrap();
        let t = std::time::Instant::now();
        let e = Xml::new(&doc, "deep.xml", &[]).err().expect("refused");
        assert!(t.elapsed().as_secs_f64() < 5.0, "took {:?}", t.elapsed());
        assert!(e.message.contains("longer than"), "{e}");
        // Line 9 declares p03, 10^7 bytes; p04 (10^6) still fits.
        assert_eq!(e.line, Some(9), "{e}");
        let text = chain(4);
        let doc = Document::parse(&text).unwrap();
        let xml = Xml::new(&doc, "deep.xml", &[]).unwrap();
        let node = doc
            .descendants()
            .find(|n| n.has_tag_name("integer"))
            .unwrap();
        assert_eq!(
            xml.attr(node, "value").unwrap().unwrap(),
            "x".repeat(1_000_000)
        );
    }

    #[test]
    fn escaped_and_repeated_keys_substitute_as_before() {
        let text = "<scene version=\"3.0.0\"><default name=\"a\" value=\"1\"/><default name=\"ab\" value=\"2\"/><string name=\"s\" value=\"$a-$ab-\\$a-$a\"/></scene>";
        let doc = Document::parse(text).unwrap();
        let xml = Xml::new(&doc, "s.xml", &[]).unwrap();
        let node = doc
            .descendants()
            .find(|n| n.has_tag_name("string"))
            .unwrap();
        assert_eq!(xml.attr(node, "value").unwrap().unwrap(), "1-2-$a-1");
    }
}
