//! The demo's `.slate` files (`examples/demo/`), embedded, and the one substitution they
//! need: `ROBOT` stands for a robot's name in the per-robot files (slate-plans'
//! [`Substitution`], as `slate node` and `slate launch` apply it).

use slate_plans::Substitution;

/// The placeholder for a robot's name in per-robot files.
pub const ROBOT: &str = slate_plans::ROBOT_PLACEHOLDER;

/// One of the demo's `.slate` files.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SlateFile {
    /// File name under `examples/demo/`.
    pub name: &'static str,
    /// Its text.
    pub source: &'static str,
}

macro_rules! file {
    ($name:literal) => {
        SlateFile {
            name: $name,
            source: include_str!(concat!("../../../examples/demo/", $name)),
        }
    };
}

/// Classes and the mission object: every board loads it first.
pub const CLASSES: SlateFile = file!("classes.slate");
/// The objects of one robot (per robot).
pub const ROBOT_OBJECTS: SlateFile = file!("robot.slate");
/// The execution controller's standing plans (per robot).
pub const EXEC: SlateFile = file!("exec.slate");
/// The vision module's team export (per robot).
pub const VISION: SlateFile = file!("vision.slate");
/// The team heartbeat of the modules that export nothing (per robot).
pub const QUIET: SlateFile = file!("quiet.slate");
/// The console's mission for one robot (per robot, loaded on the console).
pub const MISSION: SlateFile = file!("mission.slate");
/// The console's own plans.
pub const CONSOLE: SlateFile = file!("console.slate");

/// The team link's filters on the acoustic channel (every module, after its own files).
pub const LINK_ACOUSTIC: SlateFile = file!("link-acoustic.slate");

/// Every file, in the order `slate check` can load them.
pub const ALL: [SlateFile; 8] = [
    CLASSES,
    ROBOT_OBJECTS,
    EXEC,
    VISION,
    QUIET,
    MISSION,
    CONSOLE,
    LINK_ACOUSTIC,
];

impl SlateFile {
    /// The text for robot `robot`: every `ROBOT` replaced by its name; an error if the
    /// name cannot stand in a file (a quote, a backslash, a line break).
    pub fn for_robot(&self, robot: &str) -> Result<String, slate_plans::SubstitutionError> {
        Ok(Substitution::robot(robot)?.apply(self.source))
    }

    /// The name to show in diagnostics for robot `robot`'s copy.
    pub fn label(&self, robot: &str) -> String {
        format!("examples/demo/{} ({robot})", self.name)
    }
}

/// A plan that a plan in a file sends (at any depth), as its destination will load it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SentPlan {
    /// The plan's name.
    pub name: String,
    /// Its destination address.
    pub to: String,
    /// Its text.
    pub text: String,
}

/// Every inline plan that the plans of `source` send, depth first. Empty if the source
/// does not parse (loading it reports why).
pub fn sent_plans(source: &str) -> Vec<SentPlan> {
    let mut out = Vec::new();
    if let Ok(file) = slate_plans::parse(source) {
        for plan in file.plans() {
            collect_sent(plan, source, &mut out);
        }
    }
    out
}

fn collect_sent(plan: &slate_plans::PlanDecl, source: &str, out: &mut Vec<SentPlan>) {
    for action in &plan.action {
        if let slate_plans::ActionKind::Send {
            plan: slate_plans::PlanRef::Inline(inner),
            to,
        } = &action.kind
        {
            out.push(SentPlan {
                name: inner.name.name.clone(),
                to: to.value.clone(),
                text: source[inner.span.start..inner.span.end].to_owned(),
            });
            collect_sent(inner, source, out);
        }
    }
}

/// `source` in its tersest form: comments dropped, every run of whitespace outside string
/// literals one space. Plans travel as their text, so the console loads its missions
/// terse (the paper: "communications can be limited to very terse representations").
pub fn terse(source: &str) -> String {
    let mut out = String::with_capacity(source.len());
    let mut chars = source.chars().peekable();
    let mut space = false;
    while let Some(c) = chars.next() {
        match c {
            '"' => {
                flush_space(&mut out, &mut space);
                out.push('"');
                copy_string(&mut chars, &mut out);
            }
            '/' if chars.peek() == Some(&'/') => {
                while chars.next_if(|c| *c != '\n').is_some() {}
                space = true;
            }
            c if c.is_whitespace() => space = true,
            c => {
                flush_space(&mut out, &mut space);
                out.push(c);
            }
        }
    }
    out
}

fn flush_space(out: &mut String, space: &mut bool) {
    if *space && !out.is_empty() {
        out.push(' ');
    }
    *space = false;
}

/// Copies a string literal's rest (after its opening quote) through its closing quote.
fn copy_string(chars: &mut std::iter::Peekable<std::str::Chars<'_>>, out: &mut String) {
    while let Some(c) = chars.next() {
        out.push(c);
        match c {
            '\\' => {
                if let Some(e) = chars.next() {
                    out.push(e);
                }
            }
            '"' | '\n' => return,
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn terse_drops_comments_and_spaces_but_not_strings() {
        let text = "plan p { // why\n    action {\n        set a.b = \"x  // y\";\n    }\n}\n";
        assert_eq!(terse(text), "plan p { action { set a.b = \"x  // y\"; } }");
    }

    #[test]
    fn every_file_means_the_same_terse() {
        for file in ALL {
            let text = file.for_robot("r1").unwrap();
            let a = slate_plans::parse(&text).map(|f| format!("{f:?}").len());
            let b = slate_plans::parse(&terse(&text)).map(|f| format!("{f:?}").len());
            assert!(a.is_ok() && b.is_ok(), "{}", file.name);
        }
    }

    #[test]
    fn the_robot_placeholder_is_replaced_everywhere() {
        let exec = EXEC.for_robot("r7").unwrap();
        assert!(!exec.contains(ROBOT) && exec.contains("r7_claim"));
    }
}
