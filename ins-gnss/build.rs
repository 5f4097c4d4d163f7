//! Generates the configuration reference's skeleton from the configuration types: every
//! section and key the TOML accepts, read from the `serde` structs of `src/config/` and
//! `src/columns.rs` with their doc comments, whether `serde` gives them a default, and
//! the names an enum accepts. `config::reference` adds the units, the examples and the
//! default values (from the types' own defaults) and prints the reference and the
//! commented example file; its tests fail when a key has no unit or example, so the
//! reference cannot miss a key.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use syn::{Attribute, Expr, Fields, GenericArgument, Item, Lit, Meta, PathArguments, Type};

const FILES: [&str; 9] = [
    "src/config/mod.rs",
    "src/config/data.rs",
    "src/config/init.rs",
    "src/config/noise.rs",
    "src/config/gnss.rs",
    "src/config/filter.rs",
    "src/config/vehicle.rs",
    "src/config/calibrate.rs",
    "src/columns.rs",
];

struct Field {
    name: String,
    ty: Type,
    doc: String,
    has_default: bool,
}

struct Struct {
    doc: String,
    fields: Vec<Field>,
}

struct Enum {
    /// Accepted names (kebab-case), with their docs; empty for an untagged enum.
    variants: Vec<(String, String)>,
    default: Option<String>,
    untagged: bool,
}

fn doc_of(attrs: &[Attribute]) -> String {
    let mut lines = Vec::new();
    for a in attrs {
        if !a.path().is_ident("doc") {
            continue;
        }
        if let Meta::NameValue(nv) = &a.meta
            && let Expr::Lit(l) = &nv.value
            && let Lit::Str(s) = &l.lit
        {
            lines.push(s.value().trim().to_string());
        }
    }
    plain(&lines.join(" "))
}

/// Rustdoc links as plain text: ``[`a`](b)`` and ``[`a`]`` become `` `a` ``.
fn plain(s: &str) -> String {
    let mut out = String::new();
    let mut rest = s;
    while let Some(i) = rest.find("[`") {
        out.push_str(&rest[..i]);
        let after = &rest[i + 1..];
        match after.find("`]") {
            Some(j) => {
                out.push_str(&after[..j + 1]);
                let tail = &after[j + 2..];
                rest = if tail.starts_with('(') {
                    match tail.find(')') {
                        Some(k) => &tail[k + 1..],
                        None => tail,
                    }
                } else {
                    tail
                };
            }
            None => {
                out.push('[');
                rest = after;
            }
        }
    }
    out.push_str(rest);
    out.split_whitespace().collect::<Vec<_>>().join(" ")
}

fn serde_tokens(attrs: &[Attribute]) -> String {
    attrs
        .iter()
        .filter(|a| a.path().is_ident("serde"))
        .filter_map(|a| match &a.meta {
            Meta::List(l) => Some(l.tokens.to_string()),
            _ => None,
        })
        .collect::<Vec<_>>()
        .join(",")
}

fn kebab(s: &str) -> String {
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if c.is_ascii_uppercase() {
            if i > 0 {
                out.push('-');
            }
            out.push(c.to_ascii_lowercase());
        } else {
            out.push(c);
        }
    }
    out
}

/// The last path segment's name and its first generic argument.
fn path_parts(ty: &Type) -> Option<(String, Option<&Type>)> {
    if let Type::Path(p) = ty {
        let seg = p.path.segments.last()?;
        let arg = match &seg.arguments {
            PathArguments::AngleBracketed(a) => a.args.iter().find_map(|g| match g {
                GenericArgument::Type(t) => Some(t),
                _ => None,
            }),
            _ => None,
        };
        return Some((seg.ident.to_string(), arg));
    }
    None
}

/// The TOML type of a Rust type, for the reader.
fn toml_type(ty: &Type, enums: &BTreeMap<String, Enum>) -> String {
    match ty {
        Type::Array(a) => {
            let n = match &a.len {
                Expr::Lit(l) => match &l.lit {
                    Lit::Int(i) => i.base10_digits().to_string(),
                    _ => "n".into(),
                },
                _ => "n".into(),
            };
            format!("array of {n} {}", plural(&toml_type(&a.elem, enums)))
        }
        _ => match path_parts(ty) {
            Some((name, arg)) => match (name.as_str(), arg) {
                ("Option", Some(t)) => toml_type(t, enums),
                ("Vec", Some(t)) => format!("array of {}", plural(&toml_type(t, enums))),
                ("BTreeMap", _) => "table of strings".into(),
                ("f64", _) => "number".into(),
                ("u32" | "usize" | "u64", _) => "integer".into(),
                ("bool", _) => "boolean".into(),
                ("String", _) => "string".into(),
                ("PathBuf", _) => "path".into(),
                ("Col", _) => "column".into(),
                (other, _) => match enums.get(other) {
                    Some(e) if e.untagged => "array".into(),
                    Some(e) => e
                        .variants
                        .iter()
                        .map(|(v, _)| format!("\"{v}\""))
                        .collect::<Vec<_>>()
                        .join(" | "),
                    None => other.to_string(),
                },
            },
            None => "value".into(),
        },
    }
}

fn plural(s: &str) -> String {
    match s {
        "number" => "numbers".into(),
        "string" => "strings".into(),
        "path" => "paths".into(),
        "column" => "columns".into(),
        "integer" => "integers".into(),
        other => other.into(),
    }
}

fn lit(s: &str) -> String {
    format!("{s:?}")
}

fn main() {
    let mut structs: BTreeMap<String, Struct> = BTreeMap::new();
    let mut enums: BTreeMap<String, Enum> = BTreeMap::new();
    for f in FILES {
        println!("cargo:rerun-if-changed={f}");
        let text = std::fs::read_to_string(Path::new(f)).expect("config source");
        let file = syn::parse_file(&text).expect("config source parses");
        for item in file.items {
            match item {
                Item::Struct(s) => {
                    let serde = serde_tokens(&s.attrs);
                    if !serde.contains("deny_unknown_fields") {
                        continue;
                    }
                    let Fields::Named(named) = &s.fields else { continue };
                    let fields = named
                        .named
                        .iter()
                        .map(|fl| Field {
                            name: fl.ident.as_ref().expect("named").to_string(),
                            ty: fl.ty.clone(),
                            doc: doc_of(&fl.attrs),
                            has_default: serde_tokens(&fl.attrs).contains("default"),
                        })
                        .collect();
                    structs.insert(s.ident.to_string(), Struct { doc: doc_of(&s.attrs), fields });
                }
                Item::Enum(e) => {
                    let serde = serde_tokens(&e.attrs);
                    let untagged = serde.contains("untagged");
                    if !untagged && !serde.contains("kebab-case") {
                        continue;
                    }
                    let variants: Vec<(String, String)> = e
                        .variants
                        .iter()
                        .map(|v| (kebab(&v.ident.to_string()), doc_of(&v.attrs)))
                        .collect();
                    let default = e
                        .variants
                        .iter()
                        .find(|v| v.attrs.iter().any(|a| a.path().is_ident("default")))
                        .map(|v| kebab(&v.ident.to_string()));
                    enums.insert(e.ident.to_string(), Enum { variants, default, untagged });
                }
                _ => {}
            }
        }
    }

    // walk from `Config`: a field whose type is one of the structs is a section
    let mut out = String::from(
        "// Generated by build.rs from the configuration types; do not edit.\n\
         pub(crate) static SECTIONS: &[SectionDoc] = &[\n",
    );
    let mut keys = String::from("pub(crate) static KEYS: &[KeyDoc] = &[\n");
    // (path, struct, the field's doc, an `Option`, no `serde` default)
    let mut stack: Vec<(String, String, String, bool, bool)> =
        vec![(String::new(), "Config".into(), String::new(), false, true)];
    while let Some((path, ty, field_doc, optional, required)) = stack.pop() {
        let s = &structs[&ty];
        if !path.is_empty() {
            let _ = writeln!(
                out,
                "    SectionDoc {{ path: {}, doc: {}, optional: {optional}, required: {required} }},",
                lit(&path),
                lit(if field_doc.is_empty() { &s.doc } else { &field_doc }),
            );
        }
        let mut sub = Vec::new();
        for f in &s.fields {
            let (inner, is_option) = match path_parts(&f.ty) {
                Some((n, Some(t))) if n == "Option" => (t.clone(), true),
                _ => (f.ty.clone(), false),
            };
            let inner_name = path_parts(&inner).map(|(n, _)| n).unwrap_or_default();
            let full = if path.is_empty() { f.name.clone() } else { format!("{path}.{}", f.name) };
            if structs.contains_key(&inner_name) {
                sub.push((
                    full,
                    inner_name,
                    f.doc.clone(),
                    is_option,
                    !f.has_default && !is_option,
                ));
                continue;
            }
            let e = enums.get(&inner_name);
            let values: Vec<String> = match e {
                Some(e) if !e.untagged => {
                    e.variants.iter().map(|(v, d)| format!("({}, {})", lit(v), lit(d))).collect()
                }
                _ => Vec::new(),
            };
            // an untagged enum's forms are the field's doc to describe
            let doc = f.doc.clone();
            let _ = writeln!(
                keys,
                "    KeyDoc {{ section: {}, name: {}, ty: {}, doc: {}, has_default: {}, \
                 optional: {is_option}, values: &[{}], enum_default: {:?} }},",
                lit(&path),
                lit(&f.name),
                lit(&toml_type(&f.ty, &enums)),
                lit(&doc),
                f.has_default,
                values.join(", "),
                e.and_then(|e| e.default.clone()),
            );
        }
        // depth first, in the order of the fields
        stack.extend(sub.into_iter().rev());
    }
    out.push_str("];\n");
    keys.push_str("];\n");
    out.push_str(&keys);
    let dest = Path::new(&std::env::var("OUT_DIR").expect("OUT_DIR")).join("config_keys.rs");
    std::fs::write(dest, out).expect("write config_keys.rs");
}
