//! The simulator's team-link settings for the team protocol (docs/team-protocol.md,
//! step 6): loss drawn per receiving robot, endpoints that do not listen to the team,
//! no liveliness across robots, switching the team link mid-run, and the test hook that
//! loses one publication at named receivers. Every figure is a count or a virtual time.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use slate_model::Address;
use slate_transport::{
    Handler, LinkConfig, LinkKind, LinkStats, MsgKind, SendError, SimConfig, SimNet, SimTransport,
    Transport,
};

const DELAY: Duration = Duration::from_millis(500);

/// Keeps what arrives (virtual time, sender, first byte) and the peer events.
struct Inbox {
    net: SimNet,
    got: Mutex<Vec<(Duration, Address, u8)>>,
    peers: Mutex<Vec<(Address, bool)>>,
}

impl Inbox {
    /// The first bytes of what arrived, sorted (arrivals at one virtual time come in
    /// the seed's order).
    fn tags(&self) -> Vec<u8> {
        let mut tags: Vec<u8> = self.got.lock().unwrap().iter().map(|g| g.2).collect();
        tags.sort_unstable();
        tags
    }

    fn times(&self) -> Vec<Duration> {
        self.got.lock().unwrap().iter().map(|g| g.0).collect()
    }
}

impl Handler for Inbox {
    fn message(&self, from: &Address, payload: &[u8]) {
        let tag = payload.first().copied().unwrap_or_default();
        let at = self.net.now();
        self.got.lock().unwrap().push((at, from.clone(), tag));
    }
    fn peer(&self, peer: &Address, up: bool) {
        self.peers.lock().unwrap().push((peer.clone(), up));
    }
}

/// An endpoint and what it received.
type Endpoint = (Arc<SimTransport>, Arc<Inbox>);

fn addr(s: &str) -> Address {
    Address::new(s).expect("address")
}

fn net_with(team: LinkConfig, seed: u64) -> SimNet {
    let config = SimConfig {
        team,
        ..SimConfig::default()
    };
    SimNet::with_config(seed, config)
}

/// Joins one endpoint per address, each with an inbox, in order.
fn join_all(net: &SimNet, addresses: &[String]) -> Vec<Endpoint> {
    addresses
        .iter()
        .map(|a| {
            let t = net.join(&addr(a));
            let inbox = Arc::new(Inbox {
                net: net.clone(),
                got: Mutex::new(Vec::new()),
                peers: Mutex::new(Vec::new()),
            });
            t.set_handler(inbox.clone());
            (t, inbox)
        })
        .collect()
}

fn publish(t: &SimTransport, link: LinkKind, tag: u8) {
    t.publish(link, MsgKind::Report, &[tag; 8])
        .expect("publish");
}

/// A sender `team/r0/tx` and `robots` robots of `modules` endpoints each.
fn team(net: &SimNet, robots: usize, modules: usize) -> Vec<Endpoint> {
    let mut addresses = vec!["team/r0/tx".to_owned()];
    for r in 1..=robots {
        addresses.extend((0..modules).map(|m| format!("team/r{r}/m{m}")));
    }
    let all = join_all(net, &addresses);
    net.run_for(Duration::from_millis(500));
    all
}

/// Publishes `n` team messages from the sender (tags 0..n), lets them arrive, and
/// returns the tags each receiving endpoint got.
fn publish_n(net: &SimNet, all: &[Endpoint], n: u8) -> Vec<Vec<u8>> {
    for tag in 0..n {
        publish(&all[0].0, LinkKind::Team, tag);
    }
    net.run_for(Duration::from_secs(2));
    all[1..].iter().map(|(_, inbox)| inbox.tags()).collect()
}

fn frames_lost(net: &SimNet) -> u64 {
    net.stats().channels[&LinkKind::Team].frames_lost
}

#[test]
fn with_loss_per_robot_a_robots_endpoints_lose_the_same_publications() {
    let net = net_with(LinkConfig::clean().loss(0.5).loss_per_robot(), 1);
    let all = team(&net, 8, 3);
    let got = publish_n(&net, &all, 60);
    for robot in got.chunks(3) {
        assert!(robot.iter().all(|m| *m == robot[0]), "{robot:?}");
    }
    // One draw per (publication, robot): the losses count once per robot.
    let missed: usize = got.chunks(3).map(|robot| 60 - robot[0].len()).sum();
    assert_eq!(frames_lost(&net), missed as u64);
    let robots_heard: Vec<&Vec<u8>> = got.iter().step_by(3).collect();
    assert!(
        robots_heard.windows(2).any(|w| w[0] != w[1]),
        "robots draw apart"
    );
    assert!((missed as f64 / 480.0 - 0.5).abs() < 0.1, "{missed} of 480");
}

#[test]
fn a_run_with_loss_per_robot_is_the_same_for_the_same_seed() {
    let run = |seed| {
        let link = LinkConfig::clean().loss(0.3).loss_per_robot().jitter(DELAY);
        let net = net_with(link, seed);
        let all = team(&net, 4, 2);
        publish_n(&net, &all, 20);
        net.stats()
    };
    assert_eq!(run(21), run(21));
}

#[test]
fn without_loss_per_robot_each_endpoint_draws_its_own_loss() {
    let net = net_with(LinkConfig::clean().loss(0.5), 1);
    let all = team(&net, 8, 3);
    let got = publish_n(&net, &all, 60);
    let missed: usize = got.iter().map(|m| 60 - m.len()).sum();
    assert_eq!(frames_lost(&net), missed as u64);
    assert!(got.chunks(3).any(|robot| robot[0] != robot[1]), "{got:?}");
}

#[test]
fn loss_per_robot_leaves_duplication_per_endpoint() {
    let link = LinkConfig::clean().loss_per_robot().duplicate(1.0);
    let net = net_with(link, 2);
    let all = team(&net, 2, 2);
    let got = publish_n(&net, &all, 3);
    assert!(got.iter().all(|m| *m == vec![0, 0, 1, 1, 2, 2]), "{got:?}");
    assert_eq!(frames_lost(&net), 0);
}

#[test]
fn the_default_team_link_draws_loss_per_endpoint() {
    assert!(!SimConfig::default().team.loss_per_robot);
    assert!(!LinkConfig::clean().loss_per_robot);
    assert!(SimConfig::default().team_liveliness);
}

/// `team/r1/a`, `team/r1/b`, `team/r2/c`, each seeing the others.
fn trio(net: &SimNet) -> Vec<Endpoint> {
    let addresses = ["team/r1/a", "team/r1/b", "team/r2/c"].map(str::to_owned);
    let all = join_all(net, &addresses);
    net.run_for(Duration::from_millis(500));
    all
}

#[test]
fn an_endpoint_not_listening_to_the_team_gets_no_team_publication_and_still_robot_link_ones() {
    let net = net_with(LinkConfig::clean().delay(DELAY), 3);
    let t = trio(&net);
    assert!(t[0].0.listen(LinkKind::Team, false));
    publish(&t[2].0, LinkKind::Team, 1);
    publish(&t[1].0, LinkKind::Robot, 2);
    t[2].0
        .send(t[0].0.address(), MsgKind::Plan, &[3])
        .expect("send");
    net.run_for(Duration::from_secs(2));
    assert_eq!(
        t[0].1.tags(),
        vec![2, 3],
        "robot publish and team send only"
    );
    assert_eq!(t[1].1.tags(), vec![1]);
    let c_to_a = net.stats().links[&(addr("team/r2/c"), addr("team/r1/a"))].clone();
    assert_eq!(c_to_a.get(&MsgKind::Report), None, "a is no receiver");
    assert!(t[0].0.listen(LinkKind::Team, true));
    publish(&t[2].0, LinkKind::Team, 4);
    net.run_for(Duration::from_secs(2));
    assert_eq!(t[0].1.tags(), vec![2, 3, 4]);
}

#[test]
fn an_endpoint_not_listening_to_its_robot_gets_team_publications() {
    let net = SimNet::new(4);
    let t = trio(&net);
    assert!(t[0].0.listen(LinkKind::Robot, false));
    publish(&t[1].0, LinkKind::Robot, 1);
    publish(&t[2].0, LinkKind::Team, 2);
    net.run_for(Duration::from_secs(1));
    assert_eq!(t[0].1.tags(), vec![2]);
}

#[test]
fn a_revived_endpoint_keeps_its_choice_and_a_restarted_one_listens_again() {
    let net = SimNet::new(13);
    let t = trio(&net);
    assert!(t[0].0.listen(LinkKind::Team, false));
    let a = addr("team/r1/a");
    net.kill(&a);
    net.revive(&a);
    net.run_for(Duration::from_millis(500));
    publish(&t[2].0, LinkKind::Team, 1);
    net.run_for(Duration::from_secs(1));
    assert!(t[0].1.tags().is_empty(), "revived: still not listening");
    let restarted = join_all(&net, &["team/r1/a".to_owned()]);
    net.run_for(Duration::from_millis(500));
    publish(&t[2].0, LinkKind::Team, 2);
    net.run_for(Duration::from_secs(1));
    assert_eq!(restarted[0].1.tags(), vec![2]);
}

#[test]
fn a_publication_nobody_listens_to_still_goes_on_the_air() {
    let net = net_with(LinkConfig::clean().bandwidth(800), 5);
    let t = trio(&net);
    for (endpoint, _) in &t[..2] {
        assert!(endpoint.listen(LinkKind::Team, false));
    }
    publish(&t[2].0, LinkKind::Team, 1);
    net.run_for(Duration::from_secs(1));
    let radio = net.stats().radios[&(addr("team/r2/c"), LinkKind::Team)];
    assert_eq!((radio.msgs, radio.bytes), (1, 8));
    assert!(t[0].1.tags().is_empty() && t[1].1.tags().is_empty());
}

fn without_team_liveliness(seed: u64) -> SimNet {
    let config = SimConfig {
        team_liveliness: false,
        ..SimConfig::default()
    };
    SimNet::with_config(seed, config)
}

#[test]
fn without_team_liveliness_no_peer_events_cross_robots() {
    let net = without_team_liveliness(6);
    let t = trio(&net);
    assert_eq!(t[0].0.peers(), vec![addr("team/r1/b")]);
    assert!(t[2].0.peers().is_empty());
    net.kill(&addr("team/r1/b"));
    net.kill(&addr("team/r2/c"));
    net.run_for(Duration::from_secs(5));
    let events = |i: usize| t[i].1.peers.lock().unwrap().clone();
    let b = addr("team/r1/b");
    assert_eq!(events(0), vec![(b.clone(), true), (b, false)]);
    assert!(events(2).is_empty(), "{:?}", events(2));
    assert_eq!(events(1), vec![(addr("team/r1/a"), true)]);
}

#[test]
fn without_team_liveliness_team_messages_still_cross() {
    let net = without_team_liveliness(7);
    let t = trio(&net);
    publish(&t[0].0, LinkKind::Team, 1);
    t[0].0
        .send(t[2].0.address(), MsgKind::Plan, &[2])
        .expect("send");
    net.run_for(Duration::from_secs(1));
    assert_eq!(t[2].1.tags(), vec![1, 2]);
}

#[test]
fn set_team_link_changes_delay_and_loss_from_then_on() {
    let net = net_with(LinkConfig::clean().delay(DELAY), 8);
    let t = trio(&net);
    let start = net.now();
    publish(&t[0].0, LinkKind::Team, 1);
    net.run_for(Duration::from_millis(100));
    net.set_team_link(LinkConfig::clean().delay(Duration::from_secs(2)));
    publish(&t[0].0, LinkKind::Team, 2);
    net.run_for(Duration::from_secs(3));
    let expected = vec![start + DELAY, start + Duration::from_millis(2100)];
    assert_eq!(t[2].1.times(), expected, "the first keeps its fate");
    net.set_team_link(LinkConfig::clean().loss(1.0));
    publish(&t[0].0, LinkKind::Team, 3);
    net.run_for(Duration::from_secs(3));
    assert_eq!(t[2].1.tags(), vec![1, 2]);
    let lost = net.stats().kind(LinkKind::Team, MsgKind::Report).lost;
    assert_eq!(lost, 1);
    assert_eq!(net.config().team, LinkConfig::clean().loss(1.0));
}

/// Publishes 100 bytes from one of three robots, switches the team link to `after`, publishes
/// again, and returns when the third robot heard each, counted from the first publication.
fn arrivals_across_a_switch(before: LinkConfig, after: LinkConfig, seed: u64) -> Vec<Duration> {
    let net = net_with(before, seed);
    let addresses = ["team/r1/a", "team/r2/b", "team/r3/c"].map(str::to_owned);
    let t = join_all(&net, &addresses);
    net.run_for(Duration::from_millis(500));
    let start = net.now();
    t[0].0
        .publish(LinkKind::Team, MsgKind::Report, &[1; 100])
        .expect("publish");
    net.set_team_link(after);
    t[1].0
        .publish(LinkKind::Team, MsgKind::Report, &[2; 100])
        .expect("publish");
    net.run_for(Duration::from_secs(3));
    t[2].1.times().into_iter().map(|at| at - start).collect()
}

#[test]
fn switching_to_a_shared_channel_waits_for_what_is_on_the_air() {
    // 100 bytes at 800 bit/s: 1 s on the air.
    let deck = LinkConfig::clean().bandwidth(800);
    let second = Duration::from_secs(1);
    assert_eq!(
        arrivals_across_a_switch(deck, deck.shared(), 9),
        vec![second, second * 2]
    );
}

#[test]
fn leaving_a_shared_channel_waits_for_what_is_on_the_air() {
    let acoustic = LinkConfig::clean().bandwidth(800).shared();
    let second = Duration::from_secs(1);
    assert_eq!(
        arrivals_across_a_switch(acoustic, LinkConfig::clean().bandwidth(800), 12),
        vec![second, second * 2]
    );
}

#[test]
fn drop_next_publish_drops_at_exactly_the_named_receivers() {
    let net = SimNet::new(10);
    let addresses =
        ["r0/tx", "r0/mate", "r1/a", "r1/b", "r2/a", "r3/a"].map(|a| format!("team/{a}"));
    let all = join_all(&net, &addresses);
    net.run_for(Duration::from_millis(500));
    let named = [addr("team/r1/a"), addr("team/r2/a")];
    net.drop_next_publish(&addr("team/r0/tx"), &named);
    publish(&all[0].0, LinkKind::Robot, 1);
    publish(&all[0].0, LinkKind::Team, 2);
    publish(&all[0].0, LinkKind::Team, 3);
    net.run_for(Duration::from_secs(1));
    let got: BTreeMap<String, Vec<u8>> = all[1..]
        .iter()
        .map(|(t, inbox)| (t.address().to_string(), inbox.tags()))
        .collect();
    let expected = [
        ("team/r0/mate", vec![1]),
        ("team/r1/a", vec![3]),
        ("team/r1/b", vec![2, 3]),
        ("team/r2/a", vec![3]),
        ("team/r3/a", vec![2, 3]),
    ];
    let expected = expected.map(|(a, tags)| (a.to_owned(), tags)).into();
    assert_eq!(got, expected);
    assert_eq!(net.stats().kind(LinkKind::Team, MsgKind::Report).lost, 2);
}

#[test]
fn drop_next_publish_with_loss_per_robot_spares_the_named_receivers_mates() {
    let net = net_with(LinkConfig::clean().loss_per_robot(), 11);
    let addresses = ["r0/tx", "r1/a", "r1/b"].map(|a| format!("team/{a}"));
    let all = join_all(&net, &addresses);
    net.run_for(Duration::from_millis(500));
    net.drop_next_publish(&addr("team/r0/tx"), &[addr("team/r1/a")]);
    publish(&all[0].0, LinkKind::Team, 1);
    net.run_for(Duration::from_secs(1));
    assert!(all[1].1.tags().is_empty());
    assert_eq!(all[2].1.tags(), vec![1]);
}

/// A transport that only counts: it relies on the trait's default `listen`.
struct Deaf(Address);

impl Transport for Deaf {
    fn address(&self) -> &Address {
        &self.0
    }
    fn set_handler(&self, _handler: Arc<dyn Handler>) {}
    fn publish(&self, _: LinkKind, _: MsgKind, _: &[u8]) -> Result<(), SendError> {
        Ok(())
    }
    fn send(&self, _: &Address, _: MsgKind, _: &[u8]) -> Result<(), SendError> {
        Ok(())
    }
    fn peers(&self) -> Vec<Address> {
        Vec::new()
    }
    fn stats(&self) -> LinkStats {
        LinkStats::default()
    }
    fn close(&self) {}
}

#[test]
fn a_transport_that_cannot_choose_what_it_hears_says_so() {
    let t = Deaf(addr("team/r1/a"));
    assert!(!t.listen(LinkKind::Team, false));
    assert!(!t.listen(LinkKind::Team, true));
}

/// t/r1/a and t/r2/b on a clean network, cut apart just before a sends b a reliable
/// message (tag 7).
fn send_across_a_cut(seed: u64) -> (SimNet, Vec<Endpoint>) {
    let net = net_with(LinkConfig::clean(), seed);
    let all = join_all(&net, &["t/r1/a".into(), "t/r2/b".into()]);
    net.run_for(Duration::from_millis(300));
    net.partition(&[addr("t/r1/a")], &[addr("t/r2/b")]);
    all[0]
        .0
        .send(&addr("t/r2/b"), MsgKind::CatchUpAnswer, &[7; 8])
        .unwrap();
    (net, all)
}

/// A reliable send keeps trying while its addressee stays reachable: a cut shorter than
/// the liveliness lease goes unnoticed (no peer event), so a send that meets it is
/// retransmitted after the retry timeout and arrives after the heal, as TCP's would.
/// Dropping it instead lost a catch-up answer whose object list then arrived alone.
#[test]
fn a_reliable_send_that_meets_a_short_cut_arrives_after_the_heal() {
    let (net, all) = send_across_a_cut(5);
    net.run_for(Duration::from_millis(800));
    assert!(all[1].1.tags().is_empty(), "nothing crosses the cut");
    net.heal();
    net.run_for(Duration::from_millis(1500));
    assert_eq!(all[1].1.tags(), [7]);
    assert!(all[1].1.peers.lock().unwrap().iter().all(|(_, up)| *up));
}

/// A cut longer than the lease is noticed: once the sender holds the addressee down it
/// stops retransmitting (the send is dropped, as the contract allows), so a long
/// partition does not keep sends alive for ever.
#[test]
fn a_reliable_send_is_dropped_once_the_cut_outlasts_the_lease() {
    let (net, all) = send_across_a_cut(6);
    net.run_for(Duration::from_secs(5));
    assert!(
        all[0]
            .1
            .peers
            .lock()
            .unwrap()
            .contains(&(addr("t/r2/b"), false))
    );
    net.heal();
    net.run_for(Duration::from_secs(3));
    assert!(
        all[1].1.tags().is_empty(),
        "the send was dropped with the peer"
    );
}
