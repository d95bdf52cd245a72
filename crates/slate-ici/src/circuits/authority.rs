//! Who may send this module plans (docs/security.md, "Authority over plans").
//!
//! A plan runs with the authority of its origin: the module whose plan it is, named in
//! the `Plan` message's `origin`. A module that sends on a plan it received (a `send`
//! action of that plan) names that plan's origin, not itself, so a plan cannot reach a
//! module its origin may not send plans to. A destination accepts a plan only if both
//! the module that sent it and the origin it names are allowed by its [`PlanAuthority`].

use slate_model::Address;

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

/// Which modules may send this module plans: the origin of a plan and the module that
/// sent it must both match one of its patterns.
///
/// The ICI's default ([`PlanAuthority::own_robot`]) is the modules of this module's
/// robot; a node adds the team's operators and what its config declares
/// (`[authority] plans_from`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PlanAuthority {
    allowed: Vec<AddressPattern>,
}

impl PlanAuthority {
    /// Only the modules of `me`'s robot (`TEAM/ROBOT/*`), `me` among them.
    pub fn own_robot(me: &Address) -> PlanAuthority {
        PlanAuthority {
            allowed: vec![AddressPattern::robot_of(me)],
        }
    }

    /// Exactly the modules matching `patterns` (none: no module, not even this one).
    pub fn only(patterns: Vec<AddressPattern>) -> PlanAuthority {
        PlanAuthority { allowed: patterns }
    }

    /// Every module (`*/*/*`): for tests and trusted setups, never a default.
    pub fn anyone() -> PlanAuthority {
        PlanAuthority {
            allowed: vec![AddressPattern {
                text: "*/*/*".to_owned(),
            }],
        }
    }

    /// The same, and the modules matching `pattern`.
    pub fn allow(mut self, pattern: AddressPattern) -> PlanAuthority {
        if !self.allowed.contains(&pattern) {
            self.allowed.push(pattern);
        }
        self
    }

    /// May `address` send plans here (or be the origin of one)?
    pub fn permits(&self, address: &Address) -> bool {
        self.allowed.iter().any(|p| p.matches(address))
    }

    /// The patterns, in the order given.
    pub fn patterns(&self) -> &[AddressPattern] {
        &self.allowed
    }

    /// Why a plan sent by `sender` for `origin` may not run on `me`, or `None` if it may.
    pub fn refusal(&self, me: &Address, sender: &Address, origin: &Address) -> Option<String> {
        let who = if !self.permits(sender) {
            format!("{sender} may not send plans to {me}")
        } else if !self.permits(origin) {
            format!("{sender} sent on a plan of {origin}, which may not send plans to {me}")
        } else {
            return None;
        };
        Some(format!(
            "{who}: {me} accepts plans only from {}; a module's config names more in [authority] plans_from (docs/security.md)",
            self.listed()
        ))
    }

    /// The patterns as a list for a reason, at most [`MAX_LISTED`] of them.
    fn listed(&self) -> String {
        if self.allowed.is_empty() {
            return "no module".to_owned();
        }
        let mut list: Vec<&str> = self
            .allowed
            .iter()
            .take(MAX_LISTED)
            .map(|p| p.as_str())
            .collect();
        let more = self.allowed.len().saturating_sub(MAX_LISTED);
        let more_text = format!("{more} more");
        if more > 0 {
            list.push(&more_text);
        }
        list.join(", ")
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
    fn the_default_is_the_own_robot_and_a_refusal_names_who_may() {
        let me = addr("t/r2/cell");
        let authority = PlanAuthority::own_robot(&me);
        assert!(authority.permits(&addr("t/r2/exec")) && authority.permits(&me));
        assert!(!authority.permits(&addr("t/r1/planner")));
        let reason = authority
            .refusal(&me, &addr("t/r1/planner"), &addr("t/r1/planner"))
            .unwrap_or_default();
        assert!(
            reason.contains("t/r1/planner may not send plans to t/r2/cell"),
            "{reason}"
        );
        assert!(reason.contains("only from t/r2/*"), "{reason}");
        let relayed = authority
            .refusal(&me, &addr("t/r2/exec"), &addr("t/r1/planner"))
            .unwrap_or_default();
        assert!(
            relayed.contains("sent on a plan of t/r1/planner"),
            "{relayed}"
        );
        assert!(authority.refusal(&me, &addr("t/r2/exec"), &me).is_none());
    }
}
