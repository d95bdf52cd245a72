//! Module addresses (`team/robot/module`) and knowledge contexts.

use std::fmt;
use std::str::FromStr;
use std::sync::{Arc, LazyLock};

/// The address of a module: `team/robot/module`.
///
/// Every packet names the module that wrote it, and every object the module that owns it.
/// Segments are non-empty and made of letters, digits, `_` and `-`. Cloning is cheap.
#[derive(Clone, Eq)]
pub struct Address(Arc<str>);

/// Addresses are compared often (every packet names its source) and are mostly clones of
/// a few: the same allocation is the same address without reading the text.
impl PartialEq for Address {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0) || self.0 == other.0
    }
}

impl std::hash::Hash for Address {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.0.hash(state);
    }
}

/// An address orders, hashes and compares as its text, so a map keyed by addresses can be
/// searched by text (a robot's modules are one range of it).
impl std::borrow::Borrow<str> for Address {
    fn borrow(&self) -> &str {
        &self.0
    }
}

impl Ord for Address {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        if Arc::ptr_eq(&self.0, &other.0) {
            return std::cmp::Ordering::Equal;
        }
        self.0.cmp(&other.0)
    }
}

impl PartialOrd for Address {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

static UNKNOWN: LazyLock<Address> = LazyLock::new(|| Address(Arc::from("")));

impl Address {
    /// Parses `team/robot/module`.
    pub fn new(text: &str) -> Result<Self, AddressError> {
        let segments: Vec<&str> = text.split('/').collect();
        if segments.len() != 3 {
            return Err(AddressError::Shape(text.to_owned()));
        }
        for segment in segments {
            let ok = !segment.is_empty()
                && segment
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
            if !ok {
                return Err(AddressError::Segment(text.to_owned(), segment.to_owned()));
            }
        }
        Ok(Address(text.into()))
    }

    /// The address of packets with no known source (declared defaults).
    pub fn unknown() -> Self {
        UNKNOWN.clone()
    }

    /// Is this the unknown address?
    pub fn is_unknown(&self) -> bool {
        self.0.is_empty()
    }

    /// The address as text.
    pub fn as_str(&self) -> &str {
        &self.0
    }

    /// `team/robot`: the robot this module is part of.
    pub fn robot_path(&self) -> &str {
        let s = &*self.0;
        let mut slashes = s.bytes().enumerate().filter(|(_, b)| *b == b'/');
        match slashes.nth(1) {
            Some((i, _)) => &s[..i],
            None => s,
        }
    }

    /// Are both modules part of the same robot (of the same team)?
    pub fn same_robot(&self, other: &Address) -> bool {
        Arc::ptr_eq(&self.0, &other.0) || self.robot_path() == other.robot_path()
    }

    /// The `team` segment.
    pub fn team(&self) -> &str {
        self.0.split('/').next().unwrap_or("")
    }

    /// The `robot` segment.
    pub fn robot(&self) -> &str {
        self.0.split('/').nth(1).unwrap_or("")
    }

    /// The `module` segment.
    pub fn module(&self) -> &str {
        self.0.split('/').nth(2).unwrap_or("")
    }
}

impl fmt::Display for Address {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(if self.is_unknown() { "-" } else { &self.0 })
    }
}

impl fmt::Debug for Address {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Address({self})")
    }
}

impl FromStr for Address {
    type Err = AddressError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Address::new(s)
    }
}

/// A malformed module address.
#[non_exhaustive]
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum AddressError {
    /// Not three segments.
    #[error("address {0:?} must have the form team/robot/module")]
    Shape(String),
    /// A segment is empty or has characters other than letters, digits, `_` and `-`.
    #[error("address {0:?}: segment {1:?} must be non-empty letters, digits, '_' or '-'")]
    Segment(String, String),
}

/// What part of the world an object belongs to, as the paper divides knowledge.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Context {
    /// SELF: the robot's own internal state (`Self` is a Rust keyword, hence the underscore).
    Self_,
    /// SURROUNDINGS: things in the environment that matter to the task.
    #[default]
    Surroundings,
    /// SYSTEM: the other robots of the team, their perceptions and intentions.
    System,
}

impl Context {
    /// All contexts.
    pub const ALL: [Context; 3] = [Context::Self_, Context::Surroundings, Context::System];

    /// The lower-case name used in the language and the CLI.
    pub fn name(self) -> &'static str {
        match self {
            Context::Self_ => "self",
            Context::Surroundings => "surroundings",
            Context::System => "system",
        }
    }
}

impl fmt::Display for Context {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Context {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Context::ALL
            .into_iter()
            .find(|c| c.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| format!("unknown context {s:?}: expected self, surroundings or system"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses_have_three_segments() {
        let a = Address::new("team/r1/nav").unwrap();
        assert_eq!((a.team(), a.robot(), a.module()), ("team", "r1", "nav"));
        assert!(matches!(
            Address::new("team/r1"),
            Err(AddressError::Shape(_))
        ));
        assert!(matches!(
            Address::new("team//nav"),
            Err(AddressError::Segment(..))
        ));
        assert!(matches!(
            Address::new("t/r 1/nav"),
            Err(AddressError::Segment(..))
        ));
    }

    #[test]
    fn addresses_compare_by_text_whatever_their_allocation() {
        let a = |s| Address::new(s).unwrap();
        let nav = a("team/r1/nav");
        assert_eq!(nav, nav.clone());
        assert_eq!(nav, a("team/r1/nav"), "two allocations, one address");
        assert_eq!(nav.cmp(&a("team/r1/nav")), std::cmp::Ordering::Equal);
        assert_ne!(nav, a("team/r1/cam"));
        assert!(a("team/r1/cam") < nav && nav < a("team/r2/a"));
        let mut sorted = vec![a("t/b/x"), a("t/a/y"), a("t/a/x")];
        sorted.sort();
        assert_eq!(sorted, vec![a("t/a/x"), a("t/a/y"), a("t/b/x")]);
    }

    #[test]
    fn modules_share_a_robot_by_team_and_robot() {
        let a = |s| Address::new(s).unwrap();
        assert_eq!(a("team/r1/nav").robot_path(), "team/r1");
        assert!(a("team/r1/nav").same_robot(&a("team/r1/cam")));
        assert!(!a("team/r1/nav").same_robot(&a("team/r2/nav")));
        assert!(!a("team/r1/nav").same_robot(&a("other/r1/nav")));
        assert!(!a("t/r1x/nav").same_robot(&a("t/r1/nav")));
        assert!(Address::unknown().same_robot(&Address::unknown()));
    }

    #[test]
    fn contexts_parse_by_name() {
        assert_eq!("SELF".parse::<Context>(), Ok(Context::Self_));
        assert_eq!("system".parse::<Context>(), Ok(Context::System));
        assert!("elsewhere".parse::<Context>().is_err());
    }
}
