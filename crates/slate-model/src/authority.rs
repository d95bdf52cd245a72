//! Who may write what on a board: address patterns, and the rules a board's module
//! declares for the classes and attributes others write on it (docs/security.md,
//! "Authority over writes"). `owned` attributes are the other half of the same rule:
//! [`Board::write_refusal`](crate::Board::write_refusal) judges both.

use std::fmt;
use std::sync::Arc;

use rustc_hash::FxHashMap;

use crate::Address;

/// The most patterns a refusal's reason lists (the rest are counted).
const MAX_LISTED: usize = 8;

/// A pattern of module addresses: three segments `team/robot/module`, each a name or a
/// glob in which `*` stands for any run of characters (`team/r1/*`, `team/*/cli-*`,
/// `*/*/*` for every module).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AddressPattern {
    text: String,
}

/// A text that is no [`AddressPattern`].
#[non_exhaustive]
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PatternError {
    /// Not three segments of letters, digits, `_`, `-` and `*`.
    #[error(
        "{0:?} is no address pattern: expected TEAM/ROBOT/MODULE, each segment letters, digits, _ and - with * for any run of them (like \"team/*/planner\")"
    )]
    Invalid(String),
}

impl AddressPattern {
    /// Parses a pattern; `*` within a segment stands for any run of characters.
    pub fn new(text: &str) -> Result<AddressPattern, PatternError> {
        let segment_ok = |s: &str| {
            !s.is_empty()
                && s.chars()
                    .all(|c| c.is_ascii_alphanumeric() || "_-*".contains(c))
        };
        let segments: Vec<&str> = text.split('/').collect();
        if segments.len() != 3 || !segments.iter().all(|s| segment_ok(s)) {
            return Err(PatternError::Invalid(text.to_owned()));
        }
        Ok(AddressPattern {
            text: text.to_owned(),
        })
    }

    /// Every module, `*/*/*`.
    pub fn any() -> AddressPattern {
        AddressPattern {
            text: "*/*/*".to_owned(),
        }
    }

    /// Every module of `address`'s robot, `TEAM/ROBOT/*`.
    pub fn robot_of(address: &Address) -> AddressPattern {
        AddressPattern {
            text: format!("{}/{}/*", address.team(), address.robot()),
        }
    }

    /// Does `address` match?
    pub fn matches(&self, address: &Address) -> bool {
        let text = address.to_string();
        let mut given = text.split('/');
        self.text
            .split('/')
            .all(|pattern| given.next().is_some_and(|s| glob(pattern, s)))
    }

    /// The pattern as written.
    pub fn as_str(&self) -> &str {
        &self.text
    }
}

impl std::fmt::Display for AddressPattern {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.text)
    }
}

/// Does `text` match `pattern`, whose `*` stands for any run of characters? Iterative,
/// in time linear in `text` per `*` (patterns come from the node's config).
fn glob(pattern: &str, text: &str) -> bool {
    let mut parts = pattern.split('*');
    let first = parts.next().unwrap_or_default();
    let Some(mut rest) = text.strip_prefix(first) else {
        return false;
    };
    let parts: Vec<&str> = parts.collect();
    let Some((last, middle)) = parts.split_last() else {
        return rest.is_empty();
    };
    for part in middle {
        match rest.find(part) {
            Some(at) => rest = &rest[at + part.len()..],
            None => return false,
        }
    }
    rest.len() >= last.len() && rest.ends_with(last)
}

/// The patterns as a list for a reason: at most [`MAX_LISTED`], the rest counted.
pub fn listed(patterns: &[AddressPattern]) -> String {
    if patterns.is_empty() {
        return "no module".to_owned();
    }
    let mut list: Vec<String> = patterns
        .iter()
        .take(MAX_LISTED)
        .map(|p| p.as_str().to_owned())
        .collect();
    let more = patterns.len().saturating_sub(MAX_LISTED);
    if more > 0 {
        list.push(format!("{more} more"));
    }
    list.join(", ")
}

/// One declared rule: the modules that may write `class` (and its subclasses), or only
/// its attribute `attr`, on this board.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WriteRule {
    class: Arc<str>,
    attr: Option<Arc<str>>,
    writers: Vec<AddressPattern>,
}

impl WriteRule {
    /// What the rule covers: `Class` or `Class.attr`.
    pub fn target(&self) -> String {
        match &self.attr {
            Some(attr) => format!("{}.{attr}", self.class),
            None => self.class.to_string(),
        }
    }

    /// The class it names.
    pub fn class(&self) -> &str {
        &self.class
    }

    /// The attribute it names, if only one.
    pub fn attr(&self) -> Option<&str> {
        self.attr.as_deref()
    }

    /// The modules it lets write.
    pub fn writers(&self) -> &[AddressPattern] {
        &self.writers
    }

    /// May `writer` write what the rule covers?
    pub fn permits(&self, writer: &Address) -> bool {
        self.writers.iter().any(|p| p.matches(writer))
    }
}

impl fmt::Display for WriteRule {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} may be written by {}",
            self.target(),
            listed(&self.writers)
        )
    }
}

/// Which modules may write which classes and attributes on a board, besides its own
/// module (which always may): `[authority] writes` in a node's config.
///
/// A write of `attr` of an object of class `C` (or of the class `C` itself) is decided
/// by the most specific rule: walking `C`'s lineage from `C` up to `Thing`, the first
/// class with a rule for `Class.attr`, else for the whole `Class`, decides; a class or
/// attribute no rule covers may be written by any module (the merge policies decide, as
/// without rules). Creating an object of `C` is decided by the whole-class rules alone.
/// `owned` attributes stay their owner's whatever a rule says.
///
/// ```
/// use slate_model::{Address, AddressPattern, WriteAuthority};
/// let nav = AddressPattern::new("t/*/nav")?;
/// let rules = WriteAuthority::default().rule("Obstacle", None, vec![nav]);
/// assert!(rules.deciding(["Rock", "Obstacle", "Thing"], "range").is_some());
/// assert!(rules.deciding(["Vehicle", "Thing"], "speed").is_none());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct WriteAuthority {
    rules: Vec<WriteRule>,
    /// Per class: its whole-class rule, and its rules per attribute (indices in `rules`).
    by_class: FxHashMap<Arc<str>, ClassRules>,
}

#[derive(Clone, Debug, Default, PartialEq, Eq)]
struct ClassRules {
    whole: Option<usize>,
    attrs: FxHashMap<Arc<str>, usize>,
}

impl WriteAuthority {
    /// The same, and a rule: only modules matching `writers` may write `class` (with
    /// `attr`, only that attribute of it) here. A second rule for the same target
    /// replaces the first.
    pub fn rule(mut self, class: &str, attr: Option<&str>, writers: Vec<AddressPattern>) -> Self {
        let rule = WriteRule {
            class: class.into(),
            attr: attr.map(Into::into),
            writers,
        };
        let entry = self.by_class.entry(rule.class.clone()).or_default();
        let slot = match &rule.attr {
            Some(a) => entry.attrs.get(a).copied(),
            None => entry.whole,
        };
        let index = match slot {
            Some(i) => {
                self.rules[i] = rule;
                i
            }
            None => {
                self.rules.push(rule);
                self.rules.len() - 1
            }
        };
        let rule = &self.rules[index];
        match &rule.attr {
            Some(a) => {
                entry.attrs.insert(a.clone(), index);
            }
            None => entry.whole = Some(index),
        }
        self
    }

    /// No rule: every module may write everything (as the merge policies allow).
    pub fn is_empty(&self) -> bool {
        self.rules.is_empty()
    }

    /// The rules, in the order given.
    pub fn rules(&self) -> &[WriteRule] {
        &self.rules
    }

    /// The rule deciding a write of `attr` (`None`: the object itself, as when it is
    /// created) of something whose lineage is `lineage` (most specific class first), or
    /// `None` if no rule covers it.
    pub fn deciding<'a, S: AsRef<str>>(
        &self,
        lineage: impl IntoIterator<Item = S>,
        attr: impl Into<Option<&'a str>>,
    ) -> Option<&WriteRule> {
        if self.rules.is_empty() {
            return None;
        }
        let attr = attr.into();
        lineage.into_iter().find_map(|class| {
            let rules = self.by_class.get(class.as_ref())?;
            attr.and_then(|a| rules.attrs.get(a))
                .or(rules.whole.as_ref())
                .map(|&i| &self.rules[i])
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn addr(text: &str) -> Address {
        Address::new(text).unwrap_or_else(|e| panic!("{e}"))
    }

    fn pattern(text: &str) -> AddressPattern {
        AddressPattern::new(text).unwrap_or_else(|e| panic!("{e}"))
    }

    #[test]
    fn a_pattern_matches_whole_segments_with_stars_for_any_run() {
        let cli = pattern("t/*/cli-*");
        assert!(cli.matches(&addr("t/r1/cli-alice-12")));
        assert!(!cli.matches(&addr("t/r1/nav")));
        assert!(!cli.matches(&addr("u/r1/cli-1")));
        assert!(pattern("t/r1/nav").matches(&addr("t/r1/nav")));
        assert!(!pattern("t/r1/nav").matches(&addr("t/r1/navx")));
        assert!(pattern("*/*/*").matches(&addr("a/b/c")));
        assert!(pattern("t/r*1/a*b*c").matches(&addr("t/r21/abxc")));
        assert!(!pattern("t/r*1/a*b*c").matches(&addr("t/r21/abcx")));
        assert!(glob("a*a", "aa") && !glob("a*a", "a"));
    }

    #[test]
    fn a_pattern_is_three_segments_of_names_and_stars() {
        for bad in ["t/r1", "t/r1/nav/x", "t//nav", "t/r 1/nav", "t/r1/n.v", ""] {
            assert!(AddressPattern::new(bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn the_most_specific_class_decides_an_attribute_before_its_class() {
        let rules = WriteAuthority::default()
            .rule("Obstacle", None, vec![pattern("t/*/nav")])
            .rule("Obstacle", Some("range"), vec![pattern("t/*/sonar")])
            .rule("Rock", None, vec![pattern("t/*/geo")]);
        let decide =
            |lineage: &[&str], attr| rules.deciding(lineage.iter(), attr).map(WriteRule::target);
        let rock = ["Rock", "Obstacle", "Thing"];
        assert_eq!(decide(&rock, Some("range")).as_deref(), Some("Rock"));
        let tree = ["Tree", "Obstacle", "Thing"];
        assert_eq!(
            decide(&tree, Some("range")).as_deref(),
            Some("Obstacle.range")
        );
        assert_eq!(decide(&tree, Some("height")).as_deref(), Some("Obstacle"));
        assert_eq!(decide(&tree, None).as_deref(), Some("Obstacle"));
        assert_eq!(decide(&["Vehicle", "Thing"], Some("range")), None);
        let rule = rules.deciding(tree.iter(), Some("range"));
        assert!(
            rule.is_some_and(|r| r.permits(&addr("t/r1/sonar")) && !r.permits(&addr("t/r1/nav")))
        );
    }

    #[test]
    fn a_second_rule_for_the_same_target_replaces_the_first() {
        let rules = WriteAuthority::default()
            .rule("Obstacle", Some("range"), vec![pattern("t/*/nav")])
            .rule("Obstacle", Some("range"), vec![pattern("t/*/sonar")]);
        assert_eq!(rules.rules().len(), 1);
        let rule = rules.deciding(["Obstacle"], Some("range"));
        assert!(rule.is_some_and(|r| r.permits(&addr("t/r1/sonar"))));
        assert_eq!(
            rule.map(ToString::to_string).as_deref(),
            Some("Obstacle.range may be written by t/*/sonar")
        );
    }
}
