//! Every Zenoh key expression slate uses, built here and nowhere else.
//!
//! ```text
//! slate/pub/{link}/{team}/{robot}/{module}                         publications
//! slate/to/{team}/{robot}/{module}/from/{team}/{robot}/{module}    direct sends
//! slate/alive/{team}/{robot}/{module}                              liveliness tokens
//! slate/sync/{team}/{robot}/{module}                               listen barriers
//! slate/stats/{team}/{robot}/{module}                              counters (a query)
//! ```
//! A key names the sending module (and the addressee); the message kind is the first byte
//! of the payload, so that a module needs one key per link kind and one per addressee,
//! and a receiver can declare each peer's two keys ([`from_peer`]) once, when it comes up.
//! Address segments are letters, digits, `_` and `-` (checked by `Address`), so they never
//! contain Zenoh's special characters.

use slate_model::Address;
use slate_transport::LinkKind;

const ROOT: &str = "slate";

/// Where `from` publishes on `link`.
pub fn publication(from: &Address, link: LinkKind) -> String {
    format!("{ROOT}/pub/{}/{from}", link.name())
}

/// What `me` subscribes to for publications on `link`: its robot's modules for the robot
/// link, the whole team for the team link (its own robot is filtered out on receipt).
pub fn publications_for(me: &Address, link: LinkKind) -> String {
    match link {
        LinkKind::Robot => format!("{ROOT}/pub/robot/{}/{}/*", me.team(), me.robot()),
        LinkKind::Team => format!("{ROOT}/pub/team/{}/*/*", me.team()),
    }
}

/// Where `from` sends to `to` directly.
pub fn direct(to: &Address, from: &Address) -> String {
    format!("{ROOT}/to/{to}/from/{from}")
}

/// Everything sent directly to `me`.
pub fn inbox(me: &Address) -> String {
    format!("{ROOT}/to/{me}/from/*/*/*")
}

/// The keys on which `peer`'s messages reach `me`: its publications on the link between
/// them, and its direct sends to `me`. `me`'s subscriptions already cover both (with
/// wildcards); declaring them lets Zenoh route the peer's messages through a table
/// instead of matching each key against every subscription.
pub fn from_peer(me: &Address, peer: &Address) -> [String; 2] {
    [
        publication(peer, LinkKind::between(me, peer)),
        direct(me, peer),
    ]
}

/// The liveliness token of `me`.
pub fn alive(me: &Address) -> String {
    format!("{ROOT}/alive/{me}")
}

/// Every liveliness token of a team.
pub fn alive_in(team: &str) -> String {
    format!("{ROOT}/alive/{team}/*/*")
}

/// Where `me` answers the listen barrier: a query on it is answered once every message
/// the querier sent before it has been processed (one link, in order), so a subscription
/// declared before the query is known here when the answer leaves.
pub fn sync(me: &Address) -> String {
    format!("{ROOT}/sync/{me}")
}

/// The barriers of every module that publishes on `link` to `me`: its robot's modules for
/// the robot link, the whole team for the team link (as [`publications_for`]).
pub fn sync_for(me: &Address, link: LinkKind) -> String {
    match link {
        LinkKind::Robot => format!("{ROOT}/sync/{}/{}/*", me.team(), me.robot()),
        LinkKind::Team => format!("{ROOT}/sync/{}/*/*", me.team()),
    }
}

/// Where `me` answers queries for its counters (`slate stats`).
pub fn stats(me: &Address) -> String {
    format!("{ROOT}/stats/{me}")
}

/// The counters' keys of the modules matching `team`, `robot` and `module`, each a
/// segment or `*`.
pub fn stats_of(team: &str, robot: &str, module: &str) -> String {
    format!("{ROOT}/stats/{team}/{robot}/{module}")
}

/// The sending module of a publication or direct key, or of a liveliness key.
pub fn source(key: &str) -> Option<Address> {
    let parts: Vec<&str> = key.split('/').collect();
    let addr = match parts.as_slice() {
        [ROOT, "pub", _link, t, r, m] => [*t, *r, *m],
        [ROOT, "to", _, _, _, "from", t, r, m] => [*t, *r, *m],
        [ROOT, "alive" | "stats", t, r, m] => [*t, *r, *m],
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
        let k = publication(&nav, LinkKind::Team);
        assert_eq!(k, "slate/pub/team/t/r1/nav");
        assert_eq!(source(&k), Some(nav.clone()));
        let d = direct(&cam, &nav);
        assert_eq!(d, "slate/to/t/r1/cam/from/t/r1/nav");
        assert_eq!(source(&d), Some(nav.clone()));
        assert_eq!(source(&alive(&cam)), Some(cam.clone()));
        assert_eq!(source(&stats(&cam)), Some(cam));
        assert_eq!(stats_of("t", "*", "*"), "slate/stats/t/*/*");
        assert_eq!(source("slate/elsewhere"), None);
        assert_eq!(source("slate/alive/t/r 1/x"), None);
    }

    #[test]
    fn subscriptions_cover_the_right_publications() {
        let nav = a("t/r1/nav");
        assert_eq!(
            publications_for(&nav, LinkKind::Robot),
            "slate/pub/robot/t/r1/*"
        );
        assert_eq!(
            publications_for(&nav, LinkKind::Team),
            "slate/pub/team/t/*/*"
        );
        assert_eq!(inbox(&nav), "slate/to/t/r1/nav/from/*/*/*");
        assert_eq!(alive_in("t"), "slate/alive/t/*/*");
    }

    #[test]
    fn a_listen_barrier_reaches_the_modules_that_publish_on_the_link() {
        let nav = a("t/r1/nav");
        assert_eq!(sync(&nav), "slate/sync/t/r1/nav");
        assert_eq!(sync_for(&nav, LinkKind::Robot), "slate/sync/t/r1/*");
        assert_eq!(sync_for(&nav, LinkKind::Team), "slate/sync/t/*/*");
    }

    /// A peer's declared keys are ones this module's subscriptions match.
    #[test]
    fn a_peers_keys_are_covered_by_the_subscriptions() {
        let nav = a("t/r1/nav");
        let covers = |pattern: &str, key: &str| {
            let (p, k): (Vec<&str>, Vec<&str>) =
                (pattern.split('/').collect(), key.split('/').collect());
            p.len() == k.len() && p.iter().zip(&k).all(|(p, k)| *p == "*" || p == k)
        };
        let subscriptions = [
            publications_for(&nav, LinkKind::Robot),
            publications_for(&nav, LinkKind::Team),
            inbox(&nav),
        ];
        for peer in [a("t/r1/cam"), a("t/r2/nav")] {
            for key in from_peer(&nav, &peer) {
                assert!(subscriptions.iter().any(|s| covers(s, &key)), "{key}");
                assert_eq!(source(&key), Some(peer.clone()));
            }
        }
        let [robot, _] = from_peer(&nav, &a("t/r1/cam"));
        assert!(robot.starts_with("slate/pub/robot/"));
        let [team, _] = from_peer(&nav, &a("t/r2/nav"));
        assert!(team.starts_with("slate/pub/team/"));
    }
}
