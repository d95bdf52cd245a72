//! Link policies (`link team { ... }`): checked against the classes in scope and compiled
//! to [`LinkPolicy`], which the engine keeps merged over every file it loaded, for the
//! module's ICI (the node hands them over: slate-plans does not know the ICI).
//!
//! Merge rule: exports are united, and a later `report` (or `heartbeat`) for the same
//! attribute (or link) replaces an earlier one. Within one block, an entry written twice is
//! an error: it is a mistake, not a replacement.

use std::collections::{BTreeMap, HashSet};
use std::time::Duration;

use slate_model::{Context, ReportPolicy};

use super::classes::{constant, report_policy};
use crate::ast::{ExportDecl, Expr, LinkDecl, LinkEntryKind, LinkFilterDecl, Path};
use crate::check::Checker;
use crate::diagnostic::Span;

/// The kinds of link a policy configures (the ICI's `LinkKind`, which this crate does not
/// depend on).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum LinkName {
    /// `robot`: between the modules of one robot.
    Robot,
    /// `team`: between robots.
    Team,
}

impl LinkName {
    /// The link called `name` in a `.slate` file.
    pub fn parse(name: &str) -> Option<LinkName> {
        match name {
            "robot" => Some(LinkName::Robot),
            "team" => Some(LinkName::Team),
            _ => None,
        }
    }
}

/// One class of a link's export policy.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LinkExport {
    /// The class (its subclasses included).
    pub class: String,
    /// The contexts exported; empty means every context.
    pub contexts: Vec<Context>,
}

/// A link's filter for one attribute, on top of the class's own report policy.
#[derive(Debug, Clone, PartialEq)]
pub enum LinkReport {
    /// The attribute never goes on this link.
    Never,
    /// The attribute goes on this link through this filter as well.
    Policy(ReportPolicy),
}

/// What a module's `link` blocks say about one kind of link, merged.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LinkPolicy {
    /// Classes that may leave the robot on this link, one entry per class.
    pub export: Vec<LinkExport>,
    /// Per-attribute filters, by `(class, attribute)`; they apply to subclasses too.
    pub reports: BTreeMap<(String, String), LinkReport>,
    /// How long the link may stay silent before a heartbeat is sent.
    pub heartbeat: Option<Duration>,
    /// Silence after which a peer on this link is dead.
    pub timeout: Option<Duration>,
}

impl LinkPolicy {
    /// Adds a later policy: exports united (contexts too), its reports and liveliness
    /// replacing these.
    pub fn merge(&mut self, later: LinkPolicy) {
        for export in later.export {
            self.export_class(export);
        }
        self.reports.extend(later.reports);
        self.heartbeat = later.heartbeat.or(self.heartbeat);
        self.timeout = later.timeout.or(self.timeout);
    }

    /// Unites one class export with the policy (an empty context list is every context).
    fn export_class(&mut self, export: LinkExport) {
        let Some(known) = self.export.iter_mut().find(|e| e.class == export.class) else {
            self.export.push(export);
            return;
        };
        if known.contexts.is_empty() || export.contexts.is_empty() {
            known.contexts.clear();
            return;
        }
        for c in export.contexts {
            if !known.contexts.contains(&c) {
                known.contexts.push(c);
            }
        }
    }
}

/// Checks the `link` blocks of a file and compiles them, merged per link in source order.
pub(super) fn compile_links<'a>(
    ck: &mut Checker<'_>,
    links: impl Iterator<Item = &'a LinkDecl>,
) -> BTreeMap<LinkName, LinkPolicy> {
    let mut out: BTreeMap<LinkName, LinkPolicy> = BTreeMap::new();
    for decl in links {
        if let Some((name, policy)) = compile_link(ck, decl) {
            out.entry(name).or_default().merge(policy);
        }
    }
    out
}

/// One block; `None` if its link name is unknown (its entries are still checked).
fn compile_link(ck: &mut Checker<'_>, decl: &LinkDecl) -> Option<(LinkName, LinkPolicy)> {
    let name = LinkName::parse(&decl.link.name);
    if name.is_none() {
        let message = format!(
            "unknown link `{}`: expected `team` or `robot`",
            decl.link.name
        );
        ck.error(decl.link.span, message);
    }
    let mut block = Block::default();
    for entry in &decl.entries {
        match &entry.kind {
            LinkEntryKind::Export(classes) => block.export(ck, name, classes, entry.span),
            LinkEntryKind::Report { attribute, filter } => block.report(ck, attribute, filter),
            LinkEntryKind::Heartbeat { heartbeat, timeout } => {
                block.liveliness(ck, heartbeat, timeout.as_ref(), entry.span);
            }
        }
    }
    name.map(|n| (n, block.policy))
}

/// A block being compiled, with what it already said (to refuse saying it twice).
#[derive(Default)]
struct Block {
    policy: LinkPolicy,
    exported: HashSet<String>,
    heartbeat_at: Option<Span>,
}

impl Block {
    /// `export ...`: known classes, each once per block, only on the team link.
    fn export(
        &mut self,
        ck: &mut Checker<'_>,
        link: Option<LinkName>,
        classes: &[ExportDecl],
        span: Span,
    ) {
        if link == Some(LinkName::Robot) {
            let message = "the robot link carries everything its receivers want: \
                           `export` is for `link team`";
            ck.error(span, message);
            return;
        }
        for decl in classes {
            if let Some(export) = self.export_class(ck, decl) {
                self.policy.export_class(export);
            }
        }
    }

    fn export_class(&mut self, ck: &mut Checker<'_>, decl: &ExportDecl) -> Option<LinkExport> {
        let class = &decl.class;
        if !ck.scope.classes.contains_key(&class.name) {
            ck.error(class.span, format!("unknown class {}", class.name));
            return None;
        }
        if !self.exported.insert(class.name.clone()) {
            let message = format!("{} is exported twice in this link block", class.name);
            ck.error(class.span, message);
            return None;
        }
        Some(LinkExport {
            class: class.name.clone(),
            contexts: contexts(ck, decl)?,
        })
    }

    /// `report Class.attribute ...`: a reported attribute of a known class, once per block.
    fn report(&mut self, ck: &mut Checker<'_>, path: &Path, filter: &LinkFilterDecl) {
        let Some(key) = reported_attribute(ck, path) else {
            return;
        };
        let report = match filter {
            LinkFilterDecl::Never(_) => LinkReport::Never,
            LinkFilterDecl::Policy(decl) => LinkReport::Policy(report_policy(ck, decl)),
        };
        if self.policy.reports.insert(key.clone(), report).is_some() {
            let message = format!(
                "{}.{} has two `report` entries in this link block",
                key.0, key.1
            );
            ck.error(path.span, message);
        }
    }

    /// `heartbeat D [timeout D]`: positive durations, timeout longer, once per block.
    fn liveliness(
        &mut self,
        ck: &mut Checker<'_>,
        heartbeat: &Expr,
        timeout: Option<&Expr>,
        span: Span,
    ) {
        if self.heartbeat_at.replace(span).is_some() {
            ck.error(span, "duplicate `heartbeat` in this link block");
            return;
        }
        self.policy.heartbeat = duration(ck, heartbeat);
        self.policy.timeout = timeout.and_then(|t| duration(ck, t));
        if let (Some(h), Some(t), Some(at)) = (self.policy.heartbeat, self.policy.timeout, timeout)
            && t <= h
        {
            ck.error(at.span, "the timeout must be longer than the heartbeat");
        }
    }
}

/// The contexts of an export, each once.
fn contexts(ck: &mut Checker<'_>, decl: &ExportDecl) -> Option<Vec<Context>> {
    let mut out = Vec::new();
    for spec in &decl.contexts {
        if out.contains(&spec.context) {
            ck.error(
                spec.span,
                format!("context listed twice for {}", decl.class.name),
            );
            return None;
        }
        out.push(spec.context);
    }
    Some(out)
}

/// `(class, attribute)` of `Class.attribute`, if the class has it and it is ever reported
/// (a derived attribute is computed on read, never written, so never reported; a
/// `Module` object's attributes are each ICI's own view, never reported either).
fn reported_attribute(ck: &mut Checker<'_>, path: &Path) -> Option<(String, String)> {
    let [attr] = path.fields.as_slice() else {
        let message = "a link report names one class attribute: `Class.attribute`";
        ck.error(path.span, message);
        return None;
    };
    let class = &path.root;
    let Some(info) = ck.scope.classes.get(&class.name) else {
        ck.error(class.span, format!("unknown class {}", class.name));
        return None;
    };
    match info.attrs.get(&attr.name) {
        None => {
            let message = format!("{} has no attribute {}", class.name, attr.name);
            ck.error(attr.span, message);
            None
        }
        Some(a) if a.class == slate_model::MODULE_CLASS => {
            let message = format!(
                "{}.{} is written by each ICI about the modules it hears and never reported: \
                 a link cannot filter it",
                class.name, attr.name
            );
            ck.error(attr.span, message);
            None
        }
        Some(a) if a.derived => {
            let message = format!(
                "{}.{} is derived (computed on every read): it is never reported, so a link \
                 cannot filter it",
                class.name, attr.name
            );
            ck.error(attr.span, message);
            None
        }
        Some(_) => Some((class.name.clone(), attr.name.clone())),
    }
}

/// A positive constant duration, in seconds, that a `Duration` holds (not `1e30s`).
fn duration(ck: &mut Checker<'_>, e: &Expr) -> Option<Duration> {
    let secs = constant(ck, e)?.as_f64();
    match secs
        .filter(|s| *s > 0.0)
        .and_then(|s| Duration::try_from_secs_f64(s).ok())
    {
        Some(d) => Some(d),
        None => {
            ck.error(e.span, "expected a positive duration (`20s`, `500ms`)");
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn exporting(class: &str, contexts: &[Context]) -> LinkPolicy {
        LinkPolicy {
            export: vec![LinkExport {
                class: class.into(),
                contexts: contexts.to_vec(),
            }],
            ..LinkPolicy::default()
        }
    }

    fn reporting(attr: &str, report: LinkReport) -> LinkPolicy {
        let mut policy = LinkPolicy::default();
        policy.reports.insert(("Robot".into(), attr.into()), report);
        policy
    }

    #[test]
    fn merged_exports_unite_their_contexts() {
        let mut policy = exporting("Robot", &[Context::Self_]);
        policy.merge(exporting("Robot", &[Context::System, Context::Self_]));
        assert_eq!(policy.export[0].contexts, [Context::Self_, Context::System]);
        policy.merge(exporting("Robot", &[]));
        assert!(policy.export[0].contexts.is_empty(), "every context");
        policy.merge(exporting("Robot", &[Context::Self_]));
        assert!(policy.export[0].contexts.is_empty(), "every context stays");
    }

    #[test]
    fn a_later_report_replaces_an_earlier_one_and_others_stay() {
        let mut policy = reporting("position", LinkReport::Never);
        policy.merge(reporting("heading", LinkReport::Never));
        policy.merge(reporting(
            "position",
            LinkReport::Policy(ReportPolicy::default()),
        ));
        let position = &policy.reports[&("Robot".to_owned(), "position".to_owned())];
        assert_eq!(*position, LinkReport::Policy(ReportPolicy::default()));
        assert_eq!(policy.reports.len(), 2);
    }

    #[test]
    fn a_later_heartbeat_replaces_and_an_absent_one_keeps() {
        let mut policy = LinkPolicy {
            heartbeat: Some(Duration::from_secs(20)),
            ..LinkPolicy::default()
        };
        policy.merge(LinkPolicy::default());
        assert_eq!(policy.heartbeat, Some(Duration::from_secs(20)));
        policy.merge(LinkPolicy {
            heartbeat: Some(Duration::from_secs(5)),
            ..LinkPolicy::default()
        });
        assert_eq!(policy.heartbeat, Some(Duration::from_secs(5)));
    }

    /// What an export list lets out: (class, context) pairs.
    fn exported(policy: &LinkPolicy) -> std::collections::BTreeSet<(String, String)> {
        let all = [Context::Self_, Context::Surroundings, Context::System];
        let mut out = std::collections::BTreeSet::new();
        for e in &policy.export {
            for c in all {
                if e.contexts.is_empty() || e.contexts.contains(&c) {
                    out.insert((e.class.clone(), format!("{c:?}")));
                }
            }
        }
        out
    }

    fn any_export() -> impl Strategy<Value = LinkPolicy> {
        let class = prop::sample::select(vec!["Robot", "Target", "Waypoint"]);
        let context =
            prop::sample::select(vec![Context::Self_, Context::Surroundings, Context::System]);
        (class, prop::collection::vec(context, 0..3)).prop_map(|(class, mut contexts)| {
            contexts.dedup();
            exporting(class, &contexts)
        })
    }

    proptest! {
        #[test]
        fn exports_merged_in_any_order_let_out_the_same(
            blocks in prop::collection::vec(any_export(), 1..6),
        ) {
            let merged = |order: &mut dyn Iterator<Item = &LinkPolicy>| {
                let mut policy = LinkPolicy::default();
                for block in order {
                    policy.merge(block.clone());
                }
                exported(&policy)
            };
            let forward = merged(&mut blocks.iter());
            let backward = merged(&mut blocks.iter().rev());
            let union: std::collections::BTreeSet<_> =
                blocks.iter().flat_map(exported).collect();
            prop_assert_eq!(&forward, &backward);
            prop_assert_eq!(forward, union);
        }
    }
}
