//! Link policies (`link team { ... }`): parsed, checked with positions, compiled, and merged
//! over the blocks and files an engine loads.

use std::time::Duration;

use slate_model::{Context, ReportPolicy};
use slate_plans::{
    Item, LinkEntryKind, LinkExport, LinkFilterDecl, LinkName, LinkPolicy, LinkReport, LoadError,
};

use crate::support::{engine, loaded, messages, only_item};

const CLASSES: &str = "class Robot { position: vec<2> [m]; heading: real; \
                       speed: real report every 1s; \
                       ahead: vec<2> derived = self.position; }\n\
                       class Target { identity: string; }\nclass Waypoint { visited: bool; }\n";

/// The (line, column, message) of each diagnostic.
fn positions(e: &LoadError) -> Vec<(u32, u32, String)> {
    e.diagnostics
        .iter()
        .map(|d| (d.span.line, d.span.col, d.message.clone()))
        .collect()
}

/// The diagnostics of loading `link` (one line, line 1) after [`CLASSES`] were loaded.
fn link_errors(link: &str) -> Vec<(u32, u32, String)> {
    let (_board, engine) = loaded("classes.slate", CLASSES);
    positions(&engine.load("link.slate", link).unwrap_err())
}

/// The first error of loading `link` is at `at` (line, column) and says `says`.
fn assert_first_error(link: &str, at: (u32, u32), says: &str) {
    let e = link_errors(link);
    assert_eq!((e[0].0, e[0].1), at, "{e:?}");
    assert!(e[0].2.contains(says), "{e:?}");
}

fn team(engine: &slate_plans::Engine) -> LinkPolicy {
    engine.link_policies()[&LinkName::Team].clone()
}

fn every(secs: u64) -> ReportPolicy {
    ReportPolicy {
        min_interval: Some(Duration::from_secs(secs)),
        ..ReportPolicy::default()
    }
}

#[test]
fn a_link_block_holds_exports_reports_and_liveliness() {
    let item = only_item(
        "link team {\n export Robot (self), Target;\n report Robot.position every 20s \
         deadband 10.0;\n report Robot.heading never;\n heartbeat 20s timeout 90s;\n}",
    );
    let Item::Link(link) = item else {
        panic!("{item:?}")
    };
    assert_eq!(link.link.name, "team");
    let kinds: Vec<_> = link.entries.iter().map(|e| &e.kind).collect();
    let LinkEntryKind::Export(classes) = kinds[0] else {
        panic!("{kinds:?}")
    };
    assert_eq!(classes[0].class.name, "Robot");
    assert_eq!(classes[0].contexts[0].context, Context::Self_);
    assert!(classes[1].contexts.is_empty());
    let LinkEntryKind::Report { attribute, filter } = kinds[1] else {
        panic!("{kinds:?}")
    };
    assert_eq!(attribute.to_string(), "Robot.position");
    assert!(
        matches!(filter, LinkFilterDecl::Policy(p) if p.every.is_some() && p.deadband.is_some())
    );
    assert!(matches!(
        kinds[2],
        LinkEntryKind::Report {
            filter: LinkFilterDecl::Never(_),
            ..
        }
    ));
    assert!(matches!(
        kinds[3],
        LinkEntryKind::Heartbeat {
            timeout: Some(_),
            ..
        }
    ));
    assert_eq!(link.entries[3].span.line, 5);
}

#[test]
fn a_link_report_without_options_says_never_is_one() {
    let e = messages("link team { report Robot.position; }");
    assert_eq!(e.len(), 1, "{e:?}");
    assert!(e[0].contains("`never`, `every`"), "{e:?}");
}

#[test]
fn a_link_block_takes_only_exports_reports_and_heartbeats() {
    let e = messages("link team { set x = 1; }\nclass A { }");
    assert_eq!(
        e,
        ["expected `export`, `report` or `heartbeat` in a link block, found `set`"]
    );
}

#[test]
fn link_is_a_keyword_that_starts_an_item() {
    let e = messages("class A { x: real }\nlink team { export A; }");
    assert_eq!(e.len(), 1, "{e:?}");
}

#[test]
fn a_link_block_compiles_to_the_links_policy() {
    let src = format!(
        "{CLASSES}link team {{\n export Robot (self), Target;\n report Robot.position every \
         20s deadband 10.0;\n report Robot.heading never;\n heartbeat 20s timeout 90s;\n}}"
    );
    let (_board, engine) = engine();
    let loaded = engine.load("team.slate", &src).unwrap();
    assert_eq!(loaded.links, [LinkName::Team]);
    let policy = team(&engine);
    let robot = LinkExport {
        class: "Robot".into(),
        contexts: vec![Context::Self_],
    };
    let target = LinkExport {
        class: "Target".into(),
        contexts: vec![],
    };
    assert_eq!(policy.export, [robot, target]);
    let position = ReportPolicy {
        deadband: Some(10.0),
        ..every(20)
    };
    let key = |a: &str| ("Robot".to_owned(), a.to_owned());
    assert_eq!(
        policy.reports[&key("position")],
        LinkReport::Policy(position)
    );
    assert_eq!(policy.reports[&key("heading")], LinkReport::Never);
    assert_eq!(policy.heartbeat, Some(Duration::from_secs(20)));
    assert_eq!(policy.timeout, Some(Duration::from_secs(90)));
}

#[test]
fn an_unknown_link_name_is_reported_at_the_name() {
    let e = link_errors("link radio { export Robot; }");
    assert_eq!(
        e,
        [(
            1,
            6,
            "unknown link `radio`: expected `team` or `robot`".into()
        )]
    );
}

#[test]
fn unknown_classes_and_attributes_are_reported_where_they_are_written() {
    let e = link_errors("link team { export Robt; report Robot.posn never; report Trgt.x never; }");
    assert_eq!(
        e,
        [
            (1, 20, "unknown class Robt".into()),
            (1, 39, "Robot has no attribute posn".into()),
            (1, 58, "unknown class Trgt".into()),
        ]
    );
}

#[test]
fn a_filter_on_a_derived_attribute_is_refused() {
    assert_first_error(
        "link team { report Robot.ahead every 1s; }",
        (1, 26),
        "derived",
    );
}

#[test]
fn a_filter_on_a_module_attribute_is_refused() {
    assert_first_error(
        "link team { report Module.alive never; }",
        (1, 27),
        "never reported",
    );
}

#[test]
fn a_link_report_names_a_class_attribute() {
    assert_first_error(
        "link team { report Robot never; }",
        (1, 20),
        "`Class.attribute`",
    );
}

#[test]
fn an_entry_written_twice_in_one_block_is_an_error() {
    let e = link_errors(
        "link team { export Robot, Target (self, self); export Robot; \
         report Robot.heading never; report Robot.heading every 1s; \
         heartbeat 1s; heartbeat 2s; }",
    );
    let found: Vec<_> = e.iter().map(|(_, col, m)| (*col, m.as_str())).collect();
    assert_eq!(
        found,
        [
            (41, "context listed twice for Target"),
            (55, "Robot is exported twice in this link block"),
            (
                97,
                "Robot.heading has two `report` entries in this link block"
            ),
            (135, "duplicate `heartbeat` in this link block"),
        ]
    );
}

#[test]
fn the_robot_link_has_no_export() {
    assert_first_error(
        "link robot { export Robot; }",
        (1, 14),
        "`export` is for `link team`",
    );
}

#[test]
fn the_timeout_must_be_longer_than_the_heartbeat() {
    let e = link_errors("link team { heartbeat 20s timeout 10s; }");
    assert_eq!(
        e,
        [(
            1,
            35,
            "the timeout must be longer than the heartbeat".into()
        )]
    );
    let e = link_errors("link robot { heartbeat 0s; }");
    assert!(e[0].2.contains("positive duration"), "{e:?}");
}

#[test]
fn two_team_blocks_merge_exports_united_and_the_later_report_replacing() {
    let (_board, engine) = loaded("classes.slate", CLASSES);
    let exec = "link team { export Robot (self); report Robot.position every 20s; }\n\
                link team { export Target; }";
    engine.load("exec.slate", exec).unwrap();
    let acoustic = "link team { export Robot (system); report Robot.position every 60s; \
                    heartbeat 20s; }";
    engine.load("acoustic.slate", acoustic).unwrap();
    let policy = team(&engine);
    let classes: Vec<_> = policy.export.iter().map(|e| e.class.as_str()).collect();
    assert_eq!(classes, ["Robot", "Target"]);
    assert_eq!(policy.export[0].contexts, [Context::Self_, Context::System]);
    let position = &policy.reports[&("Robot".to_owned(), "position".to_owned())];
    assert_eq!(*position, LinkReport::Policy(every(60)));
    assert_eq!(policy.heartbeat, Some(Duration::from_secs(20)));
}

#[test]
fn a_file_with_an_error_changes_no_link_policy() {
    let (_board, engine) = loaded("classes.slate", CLASSES);
    let bad = "link team { export Robot; }\nobject r : Nowhere;";
    engine.load("bad.slate", bad).unwrap_err();
    assert!(engine.link_policies().is_empty());
}

#[test]
fn a_link_block_may_name_classes_of_its_own_file() {
    let (_board, engine) = engine();
    let src = "class Mission { phase: string; }\nlink team { export Mission; }";
    engine.load("console.slate", src).unwrap();
    assert_eq!(team(&engine).export[0].class, "Mission");
}

#[test]
fn a_duration_too_long_for_a_duration_is_refused_not_a_panic() {
    // Found by the `slate_check` fuzz target (session 13): `heartbeat 7e23s` panicked in
    // `Duration::from_secs_f64`.
    let e = link_errors("link team {\n    heartbeat 699999999999999999999999s timeout 5s;\n}");
    assert!(e[0].2.contains("positive duration"), "{e:?}");
    let (_board, engine) = engine();
    let huge = "class Robot { position: real report every 1e30s; }";
    assert!(engine.load("huge.slate", huge).is_ok());
}
