//! The shared channel: one half-duplex transmitter for every sender on a kind of link,
//! frames of bounded size, per-frame loss (an acoustic modem's regime). Every figure is
//! on the simulator's virtual clock, which is deterministic.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use slate_model::Address;
use slate_transport::{
    Handler, LinkConfig, LinkKind, MsgKind, SendError, SimConfig, SimNet, SimTransport, Transport,
};

/// 800 bit/s: a 32-byte frame is 320 ms of airtime, plus the per-frame overhead.
const RATE: u64 = 800;
const FRAME: usize = 32;
const OVERHEAD: Duration = Duration::from_millis(100);
const DELAY: Duration = Duration::from_secs(1);

/// Keeps what arrives and when (virtual time).
struct Arrivals {
    net: SimNet,
    got: Mutex<Vec<(Duration, Address, usize)>>,
}

impl Handler for Arrivals {
    fn message(&self, from: &Address, payload: &[u8]) {
        let at = self.net.now();
        self.got
            .lock()
            .unwrap()
            .push((at, from.clone(), payload.len()));
    }
    fn peer(&self, _peer: &Address, _up: bool) {}
}

fn acoustic(loss: f64) -> LinkConfig {
    LinkConfig::clean()
        .delay(DELAY)
        .bandwidth(RATE)
        .loss(loss)
        .shared()
        .frames(FRAME, OVERHEAD)
}

fn net_with(team: LinkConfig, seed: u64) -> SimNet {
    SimNet::with_config(
        seed,
        SimConfig {
            team,
            ..SimConfig::default()
        },
    )
}

fn addr(s: &str) -> Address {
    Address::new(s).expect("address")
}

/// Joins `senders` and one receiver (`team/rx/m`), lets liveliness settle.
fn team(net: &SimNet, senders: &[&str]) -> (Vec<Arc<SimTransport>>, Arc<Arrivals>) {
    let out: Vec<_> = senders.iter().map(|s| net.join(&addr(s))).collect();
    let rx = net.join(&addr("team/rx/m"));
    let arrivals = Arc::new(Arrivals {
        net: net.clone(),
        got: Mutex::new(Vec::new()),
    });
    rx.set_handler(arrivals.clone());
    net.run_for(Duration::from_millis(500));
    (out, arrivals)
}

fn frame_airtime() -> Duration {
    Duration::from_millis(320) + OVERHEAD
}

#[test]
fn a_100_byte_message_on_a_32_byte_frame_channel_takes_4_frames() {
    let net = net_with(acoustic(0.0), 1);
    let (tx, arrivals) = team(&net, &["team/r1/m"]);
    let sent_at = net.now();
    tx[0]
        .publish(LinkKind::Team, MsgKind::Report, &[7; 100])
        .unwrap();
    net.run_for(Duration::from_secs(5));
    let channel = net.stats().channels[&LinkKind::Team];
    assert_eq!(channel.frames_sent, 4);
    assert_eq!(channel.largest_frame, 32);
    assert_eq!(channel.largest_message, 100);
    // 800 bits of payload at 800 bit/s, four frame overheads, then the delay.
    let expected = sent_at + Duration::from_secs(1) + OVERHEAD * 4 + DELAY;
    let got = arrivals.got.lock().unwrap().clone();
    assert_eq!(got, vec![(expected, addr("team/r1/m"), 100)]);
}

/// Two senders publish one full frame each at the same instant; returns the net, the
/// instant they sent at and when each message arrived.
fn two_senders_one_frame_each(team_link: LinkConfig) -> (SimNet, Duration, Vec<Duration>) {
    let net = net_with(team_link, 2);
    let (tx, arrivals) = team(&net, &["team/r1/m", "team/r2/m"]);
    let sent_at = net.now();
    for t in &tx {
        t.publish(LinkKind::Team, MsgKind::Report, &[1; FRAME])
            .unwrap();
    }
    net.run_for(Duration::from_secs(5));
    let times: Vec<Duration> = arrivals.got.lock().unwrap().iter().map(|g| g.0).collect();
    (net, sent_at, times)
}

#[test]
fn two_senders_on_a_shared_channel_queue_behind_each_other() {
    let (net, sent_at, times) = two_senders_one_frame_each(acoustic(0.0));
    let first = sent_at + frame_airtime() + DELAY;
    assert_eq!(times, vec![first, first + frame_airtime()]);
    let r2 = net.stats().radios[&(addr("team/r2/m"), LinkKind::Team)];
    assert_eq!(r2.max_queued, frame_airtime());
}

#[test]
fn senders_with_their_own_radios_do_not_queue_behind_each_other() {
    let own_radios = LinkConfig::clean().delay(DELAY).bandwidth(RATE);
    let (net, sent_at, times) = two_senders_one_frame_each(own_radios);
    let both = sent_at + Duration::from_millis(320) + DELAY;
    assert_eq!(times, vec![both, both]);
    assert_eq!(net.stats().channels[&LinkKind::Team].frames_sent, 2);
}

/// One sender sends `n` messages with `send` on the acoustic channel losing 20 % of its
/// frames; runs until every retransmission is over.
fn through_20_percent_frame_loss(
    seed: u64,
    n: usize,
    send: impl Fn(&SimTransport) -> Result<(), SendError>,
) -> (SimNet, Arc<Arrivals>) {
    let net = net_with(acoustic(0.2), seed);
    let (tx, arrivals) = team(&net, &["team/r1/m"]);
    for _ in 0..n {
        send(&tx[0]).unwrap();
    }
    net.run_for(Duration::from_secs(5000));
    (net, arrivals)
}

#[test]
fn a_lost_frame_loses_the_whole_message() {
    let (net, arrivals) = through_20_percent_frame_loss(3, 1000, |tx| {
        tx.publish(LinkKind::Team, MsgKind::Report, &[5; 100])
    });
    let stats = net.stats();
    let channel = stats.channels[&LinkKind::Team];
    let link = stats.kind(LinkKind::Team, MsgKind::Report);
    let delivered = arrivals.got.lock().unwrap().len() as u64;
    assert!(arrivals.got.lock().unwrap().iter().all(|g| g.2 == 100));
    assert_eq!(channel.frames_sent, 4000);
    assert_eq!(delivered + link.lost, 1000);
    // A message survives only if its four frames do: 0.8^4 = 41 %, where one frame
    // would survive 80 % of the time.
    assert!((340..=480).contains(&delivered), "{delivered} delivered");
    assert!(channel.frames_lost >= link.lost, "{channel:?} {link:?}");
    assert!((700..=900).contains(&channel.frames_lost), "{channel:?}");
}

#[test]
fn a_reliable_send_retransmits_every_frame_of_a_message_a_frame_of_which_was_lost() {
    let (net, arrivals) = through_20_percent_frame_loss(4, 100, |tx| {
        tx.send(&addr("team/rx/m"), MsgKind::Plan, &[9; 100])
    });
    let stats = net.stats();
    let channel = stats.channels[&LinkKind::Team];
    let link = stats.kind(LinkKind::Team, MsgKind::Plan);
    assert_eq!(arrivals.got.lock().unwrap().len(), 100);
    assert_eq!(channel.frames_sent, 4 * link.sent_msgs);
    assert_eq!(link.sent_msgs, 100 + link.retransmits);
    assert!(link.retransmits > 0 && channel.frames_lost >= link.retransmits);
}

#[test]
fn the_channel_reports_its_utilisation_and_largest_frame() {
    let net = net_with(acoustic(0.0), 5);
    let (tx, _arrivals) = team(&net, &["team/r1/m", "team/r2/m"]);
    let start = net.now();
    for t in &tx {
        for _ in 0..5 {
            t.publish(LinkKind::Team, MsgKind::Report, &[3; 20])
                .unwrap();
        }
    }
    // Ten frames of 20 bytes: 200 ms + 100 ms each, 3 s in all, back to back.
    let airtime = (Duration::from_millis(200) + OVERHEAD) * 10;
    net.run_for(Duration::from_secs(1));
    // Only the airtime already spent counts: the channel was busy all that second.
    let busy_so_far = net.channel_utilisation(LinkKind::Team) * net.now().as_secs_f64();
    let expected = (net.now() - start).as_secs_f64();
    assert!((busy_so_far - expected).abs() < 1e-9, "{busy_so_far}");
    net.run_for(Duration::from_secs(10));
    let utilisation = net.channel_utilisation(LinkKind::Team);
    let expected = airtime.as_secs_f64() / net.now().as_secs_f64();
    assert!(
        (utilisation - expected).abs() < 1e-9,
        "{utilisation} {expected}"
    );
    let channel = net.stats().channels[&LinkKind::Team];
    assert_eq!((channel.largest_frame, channel.largest_message), (20, 20));
    assert_eq!(channel.airtime, airtime);
}

#[test]
fn a_shared_channel_run_is_the_same_for_the_same_seed() {
    let run = |seed| {
        let net = net_with(acoustic(0.2), seed);
        let (tx, _arrivals) = team(&net, &["team/r1/m", "team/r2/m"]);
        for (i, t) in tx.iter().enumerate() {
            t.publish(LinkKind::Team, MsgKind::Report, &vec![0; 40 + i * 30])
                .unwrap();
        }
        net.run_for(Duration::from_secs(30));
        net.stats()
    };
    assert_eq!(run(9), run(9));
}

#[test]
fn a_full_transmit_queue_drops_what_would_wait_too_long() {
    let net = net_with(acoustic(0.0).max_queue(Duration::from_secs(2)), 6);
    let (tx, arrivals) = team(&net, &["team/r1/m", "team/r2/m"]);
    // 420 ms a frame: the sixth message would wait 2.1 s, longer than the bound.
    for i in 0..10 {
        let t = &tx[i % 2];
        t.publish(LinkKind::Team, MsgKind::Report, &[2; FRAME])
            .unwrap();
    }
    net.run_for(Duration::from_secs(10));
    let channel = net.stats().channels[&LinkKind::Team];
    assert_eq!(arrivals.got.lock().unwrap().len(), 5);
    assert_eq!((channel.frames_sent, channel.dropped), (5, 5));
}
