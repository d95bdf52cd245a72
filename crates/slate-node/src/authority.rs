//! Who may send a node plans, `[authority] plans_from` (docs/security.md, "Authority
//! over plans"), turned into the plan circuits' [`PlanAuthority`]; and who may write
//! which classes and attributes on its board, `[authority.writes]` ("Authority over
//! writes"), turned into the board's [`WriteAuthority`]. Both take the same entries.
//!
//! By default a node accepts plans from the modules of its own robot and from the team's
//! operators: on a secured team, the operators whose certificates are in its keys folder
//! (their CLI observers, `TEAM/*/cli-NAME-*`, which only they and the modules relaying
//! for them may speak as); on an insecure team, any CLI observer of the team
//! (`TEAM/*/cli-*`), since nothing there tells an operator from anyone else.

use std::str::FromStr;

use slate_ici::{AddressPattern, PatternError, PlanAuthority};
use slate_model::{Address, Board, WriteAuthority};

use crate::observer::OBSERVER_PREFIX;

/// One entry of `plans_from`, or of a rule of `[authority.writes]`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum PlanSender {
    /// `"robot"`: the modules of this module's robot.
    Robot,
    /// `"operators"`: the team's operators (see the module's doc).
    Operators,
    /// An address pattern, like `"team/base/console"` or `"team/*/planner"`.
    Modules(AddressPattern),
}

/// The default `plans_from`: this robot's modules and the team's operators.
pub fn default_plans_from() -> Vec<PlanSender> {
    vec![PlanSender::Robot, PlanSender::Operators]
}

impl FromStr for PlanSender {
    type Err = PatternError;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        match text {
            "robot" => Ok(PlanSender::Robot),
            "operators" => Ok(PlanSender::Operators),
            _ => AddressPattern::new(text).map(PlanSender::Modules),
        }
    }
}

/// The authority of the node at `me` whose `plans_from` is `senders`; `operators` are
/// the names of a secured team's operators (`None` on an insecure team).
pub fn plan_authority(
    me: &Address,
    senders: &[PlanSender],
    operators: Option<&[String]>,
) -> PlanAuthority {
    let mut authority = PlanAuthority::only(Vec::new());
    for sender in senders {
        for pattern in patterns(me, sender, operators) {
            authority = authority.allow(pattern);
        }
    }
    authority
}

/// One rule of `[authority.writes]`: only `writers` (and the node's own module) may
/// write `class` (and its subclasses) on the node's board, or with `attr` only that
/// attribute of it (`"Class.attr" = [...]`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WritesFrom {
    /// The class.
    pub class: String,
    /// The attribute, if the rule is for one only.
    pub attr: Option<String>,
    /// Who may write it.
    pub writers: Vec<PlanSender>,
}

impl WritesFrom {
    /// The rule for `target`, `"Class"` or `"Class.attr"`.
    pub fn new(target: &str, writers: Vec<PlanSender>) -> WritesFrom {
        let (class, attr) = match target.split_once('.') {
            Some((class, attr)) => (class, Some(attr.to_owned())),
            None => (target, None),
        };
        WritesFrom {
            class: class.to_owned(),
            attr,
            writers,
        }
    }

    /// `Class` or `Class.attr`.
    pub fn target(&self) -> String {
        match &self.attr {
            Some(attr) => format!("{}.{attr}", self.class),
            None => self.class.clone(),
        }
    }
}

/// The write rules of the node at `me` whose `[authority.writes]` is `rules`, for its
/// board; `operators` as for [`plan_authority`]. A rule naming a class or an attribute
/// `board` does not have (after its files loaded) is an error: it would guard nothing.
pub fn write_authority(
    me: &Address,
    rules: &[WritesFrom],
    operators: Option<&[String]>,
    board: &Board,
) -> Result<WriteAuthority, String> {
    let mut authority = WriteAuthority::default();
    for rule in rules {
        let known = match &rule.attr {
            Some(attr) => board.attr_decl(&rule.class, attr).is_some(),
            None => board.class_def(&rule.class).is_some() || rule.class == slate_model::THING,
        };
        if !known {
            return Err(format!(
                "authority.writes: `{}` names no class or attribute of this module's files",
                rule.target()
            ));
        }
        let writers = rule
            .writers
            .iter()
            .flat_map(|w| patterns(me, w, operators))
            .collect();
        authority = authority.rule(&rule.class, rule.attr.as_deref(), writers);
    }
    Ok(authority)
}

/// The address patterns one entry stands for.
fn patterns(
    me: &Address,
    sender: &PlanSender,
    operators: Option<&[String]>,
) -> Vec<AddressPattern> {
    match sender {
        PlanSender::Robot => vec![AddressPattern::robot_of(me)],
        PlanSender::Modules(pattern) => vec![pattern.clone()],
        PlanSender::Operators => {
            let names = match operators {
                Some(names) => names.iter().map(|n| format!("{n}-*")).collect(),
                None => vec!["*".to_owned()],
            };
            let team = me.team();
            names
                .iter()
                .filter_map(|n| AddressPattern::new(&format!("{team}/*/{OBSERVER_PREFIX}{n}")).ok())
                .collect()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn addr(text: &str) -> Address {
        Address::new(text).unwrap_or_else(|e| panic!("{e}"))
    }

    #[test]
    fn the_default_is_the_robot_and_the_teams_operators() {
        let me = addr("t/r2/loco");
        let insecure = plan_authority(&me, &default_plans_from(), None);
        assert!(insecure.permits(&addr("t/r2/exec")));
        assert!(insecure.permits(&addr("t/r1/cli-4242")));
        assert!(!insecure.permits(&addr("t/r1/nav")));
        assert!(!insecure.permits(&addr("u/r1/cli-4242")));
        let alice = ["alice".to_owned()];
        let secured = plan_authority(&me, &default_plans_from(), Some(&alice));
        assert!(secured.permits(&addr("t/r1/cli-alice-12")));
        assert!(!secured.permits(&addr("t/r1/cli-bob-12")));
        assert!(!secured.permits(&addr("t/r1/cli-12")));
    }

    #[test]
    fn entries_are_words_or_address_patterns() {
        assert_eq!("robot".parse(), Ok(PlanSender::Robot));
        assert_eq!("operators".parse(), Ok(PlanSender::Operators));
        let console: PlanSender = "t/base/console".parse().unwrap_or_else(|e| panic!("{e}"));
        let authority = plan_authority(&addr("t/r1/nav"), &[console], None);
        assert!(authority.permits(&addr("t/base/console")));
        assert!(
            !authority.permits(&addr("t/r1/exec")),
            "only what is listed"
        );
        assert!("everyone".parse::<PlanSender>().is_err());
    }
}
