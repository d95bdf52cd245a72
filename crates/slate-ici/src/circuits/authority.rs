//! Who may send this module plans (docs/security.md, "Authority over plans").
//!
//! A plan runs with the authority of its origin: the module whose plan it is, named in
//! the `Plan` message's `origin`. A module that sends on a plan it received (a `send`
//! action of that plan) names that plan's origin, not itself, so a plan cannot reach a
//! module its origin may not send plans to. A destination accepts a plan only if both
//! the module that sent it and the origin it names are allowed by its [`PlanAuthority`].

use slate_model::{Address, AddressPattern};

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
            allowed: vec![AddressPattern::any()],
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
            slate_model::listed_patterns(&self.allowed)
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn addr(text: &str) -> Address {
        Address::new(text).unwrap_or_else(|e| panic!("{e}"))
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
