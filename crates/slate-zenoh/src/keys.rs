//! Every Zenoh key expression slate uses, built here and nowhere else.
//!
//! ```text
//! slate/pub/{link}/{team}/{robot}/{module}/{kind}                         publications
//! slate/to/{team}/{robot}/{module}/from/{team}/{robot}/{module}/{kind}    direct sends
//! slate/alive/{team}/{robot}/{module}                                     liveliness tokens
//! ```
//! Address segments are letters, digits, `_` and `-` (checked by `Address`), so they never
//! contain Zenoh's special characters.

use slate_ici::{LinkKind, MsgKind};
use slate_model::Address;

const ROOT: &str = "slate";

/// Where `from` publishes messages of `kind` on `link`.
pub fn publication(from: &Address, link: LinkKind, kind: MsgKind) -> String {
    format!("{ROOT}/pub/{}/{from}/{}", link.name(), kind.name())
}

/// What `me` subscribes to for publications on `link`: its robot's modules for the robot
/// link, the whole team for the team link (its own robot is filtered out on receipt).
pub fn publications_for(me: &Address, link: LinkKind) -> String {
    match link {
        LinkKind::Robot => format!("{ROOT}/pub/robot/{}/{}/*/*", me.team(), me.robot()),
        LinkKind::Team => format!("{ROOT}/pub/team/{}/*/*/*", me.team()),
    }
}

/// Where `from` sends a message of `kind` to `to` directly.
pub fn direct(to: &Address, from: &Address, kind: MsgKind) -> String {
    format!("{ROOT}/to/{to}/from/{from}/{}", kind.name())
}

/// Everything sent directly to `me`.
pub fn inbox(me: &Address) -> String {
    format!("{ROOT}/to/{me}/from/*/*/*/*")
}

/// The liveliness token of `me`.
pub fn alive(me: &Address) -> String {
    format!("{ROOT}/alive/{me}")
}

/// Every liveliness token of a team.
pub fn alive_in(team: &str) -> String {
    format!("{ROOT}/alive/{team}/*/*")
}

/// The sending module of a publication or direct key, or of a liveliness key.
pub fn source(key: &str) -> Option<Address> {
    let parts: Vec<&str> = key.split('/').collect();
    let addr = match parts.as_slice() {
        [ROOT, "pub", _link, t, r, m, _kind] => [*t, *r, *m],
        [ROOT, "to", _, _, _, "from", t, r, m, _kind] => [*t, *r, *m],
        [ROOT, "alive", t, r, m] => [*t, *r, *m],
        _ => return None,
    };
    Address::new(&addr.join("/")).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn a(s: &str) -> Address {
        Address::new(s).unwrap()
    }

    #[test]
    fn keys_carry_their_source() {
        let nav = a("t/r1/nav");
        let cam = a("t/r1/cam");
        let k = publication(&nav, LinkKind::Team, MsgKind::Report);
        assert_eq!(k, "slate/pub/team/t/r1/nav/report");
        assert_eq!(source(&k), Some(nav.clone()));
        let d = direct(&cam, &nav, MsgKind::Plan);
        assert_eq!(d, "slate/to/t/r1/cam/from/t/r1/nav/plan");
        assert_eq!(source(&d), Some(nav.clone()));
        assert_eq!(source(&alive(&cam)), Some(cam));
        assert_eq!(source("slate/elsewhere"), None);
        assert_eq!(source("slate/alive/t/r 1/x"), None);
    }

    #[test]
    fn subscriptions_cover_the_right_publications() {
        let nav = a("t/r1/nav");
        assert_eq!(
            publications_for(&nav, LinkKind::Robot),
            "slate/pub/robot/t/r1/*/*"
        );
        assert_eq!(
            publications_for(&nav, LinkKind::Team),
            "slate/pub/team/t/*/*/*"
        );
        assert_eq!(inbox(&nav), "slate/to/t/r1/nav/from/*/*/*/*");
        assert_eq!(alive_in("t"), "slate/alive/t/*/*");
    }
}
