//! `slate launch --check`: what can be known about a team without starting it. The
//! configs were checked when the team file was read (by `slate node`'s own parser);
//! here the `.slate` files of every module are loaded into a scratch board with the
//! module's substitutions, and the ports of the modules sharing a host must differ.

use std::collections::BTreeMap;
use std::sync::Arc;

use slate_model::{Board, Clock};
use slate_plans::Engine;

use super::team::{ModulePlan, Team};

/// One reason a team cannot start.
#[derive(Clone, Debug)]
pub enum Problem {
    /// A one-line message (a missing file, a port clash).
    Line(String),
    /// A `.slate` file's diagnostics, which say `FILE:LINE:COL: error:` themselves and
    /// keep their source line and caret.
    Diagnostics(String),
}

impl std::fmt::Display for Problem {
    /// As `slate` prints errors: `slate: error: ...`, or `slate: ` before diagnostics
    /// (one "error" per line, docs/cli.md).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Problem::Line(text) => write!(f, "slate: error: {text}"),
            Problem::Diagnostics(text) => write!(f, "slate: {text}"),
        }
    }
}

/// Every problem of the team; empty when the team can start.
pub fn problems(team: &Team) -> Vec<Problem> {
    let mut out = port_clashes(&team.modules);
    for module in &team.modules {
        out.extend(load_files(module));
    }
    out
}

/// Loads a module's files, substituted, into a scratch board, as `slate node` would.
fn load_files(module: &ModulePlan) -> Option<Problem> {
    let board = Arc::new(Board::builder().clock(Clock::manual()).build());
    let engine = Engine::new(&board);
    for file in &module.config.files {
        let name = file.path.display().to_string();
        let text = match std::fs::read_to_string(&file.path) {
            Ok(t) => file.substitute.apply(&t),
            Err(e) => {
                return Some(Problem::Line(format!(
                    "{}: module {}: cannot read {name}: {e}; fix the path (relative to the team file)",
                    module.at, module.name
                )));
            }
        };
        if let Err(e) = engine.load(&name, &text) {
            return Some(Problem::Diagnostics(format!(
                "module {}: {}",
                module.name, e.rendered
            )));
        }
    }
    None
}

/// Two modules of one host on one port (Zenoh or dashboard), named with both.
fn port_clashes(modules: &[ModulePlan]) -> Vec<Problem> {
    let mut taken: BTreeMap<u16, Vec<(String, String)>> = BTreeMap::new();
    let mut out = Vec::new();
    for m in modules {
        let mut ports = vec![(m.host.clone(), m.port, "zenoh")];
        if let Some(d) = m.config.dashboard.filter(|d| d.port() != 0) {
            ports.push((d.ip().to_string(), d.port(), "dashboard"));
        }
        for (host, port, what) in ports {
            let users = taken.entry(port).or_default();
            if let Some((other, _)) = users.iter().find(|(_, h)| same_host(h, &host)) {
                out.push(Problem::Line(format!(
                    "{}: module {} wants port {port} on {host} for its {what}, which {other} has: give each module its own port (a fixed dashboard port in a kind clashes once two robots on one host run it; use port 0)",
                    m.at, m.name
                )));
            }
            users.push((m.name.clone(), host));
        }
    }
    out
}

/// Hosts that would share a port: the same, or either listening on every address.
fn same_host(a: &str, b: &str) -> bool {
    let any = |h: &str| h == "0.0.0.0" || h == "::";
    a == b || any(a) || any(b)
}
