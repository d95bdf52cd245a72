//! A readable text dump of a board: the class tree with its declarations, and every
//! object with the packets it holds.

use std::fmt::Write as _;

use super::Board;
use super::state::{ClassData, State};
use crate::{ObjectId, Packet};

impl Board {
    /// The class tree, declarations, objects and their own packets, as indented text.
    /// Deterministic: children and objects are listed in creation order.
    pub fn dump(&self) -> String {
        let inner = self.inner.read();
        let mut out = String::new();
        dump_class(&inner.state, inner.state.thing, 0, &mut out);
        out
    }
}

fn dump_class(st: &State, id: ObjectId, depth: usize, out: &mut String) {
    let Some(class) = st.class(id) else { return };
    let pad = "  ".repeat(depth);
    let _ = writeln!(out, "{pad}class {}", class.def.name);
    dump_decls(class, &pad, out);
    dump_values(st, id, &format!("{pad}  value "), out);
    for &obj in &class.instances {
        let Some(e) = st.get(obj) else { continue };
        let Some(i) = e.instance() else { continue };
        let _ = writeln!(
            out,
            "{pad}  object {} ({}, owner {})",
            e.name, i.context, i.owner
        );
        dump_values(st, obj, &format!("{pad}    "), out);
    }
    for &child in &class.children {
        dump_class(st, child, depth + 1, out);
    }
}

fn dump_decls(class: &ClassData, pad: &str, out: &mut String) {
    for a in &class.def.attrs {
        let unit = a
            .unit
            .as_deref()
            .map(|u| format!(" [{u}]"))
            .unwrap_or_default();
        let default = a
            .default
            .as_ref()
            .map(|d| format!(" = {} ±{} @{}", d.value, d.accuracy, d.confidence))
            .unwrap_or_default();
        let _ = writeln!(out, "{pad}  attr {}: {}{unit}{default}", a.name, a.ty);
    }
}

fn dump_values(st: &State, id: ObjectId, pad: &str, out: &mut String) {
    let Some(e) = st.get(id) else { return };
    let mut values: Vec<_> = e
        .values
        .iter()
        .map(|s| (st.attr_name(s.attr), &s.packet))
        .collect();
    values.sort_by(|a, b| a.0.cmp(&b.0));
    for (attr, p) in values {
        let _ = writeln!(out, "{pad}{attr} = {}", packet_text(p));
    }
}

/// `value ±accuracy @confidence (t=…, from source)`.
pub(crate) fn packet_text(p: &Packet) -> String {
    format!(
        "{} ±{} @{} (t={}, from {})",
        p.value, p.accuracy, p.confidence, p.timestamp, p.source
    )
}
