//! What the simulated network carried: per directed link and message kind, per
//! transmitter, and what it dropped.

use std::collections::BTreeMap;
use std::time::Duration;

use rustc_hash::FxHashMap;
use slate_model::Address;

use crate::{LinkKind, MsgKind};

/// One directed link's counters for one message kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LinkCounter {
    /// Transmissions put on the link (a reliable send's retransmissions included).
    pub sent_msgs: u64,
    /// Bytes put on the link (retransmissions included).
    pub sent_bytes: u64,
    /// Messages delivered (duplicates included).
    pub delivered_msgs: u64,
    /// Bytes delivered.
    pub delivered_bytes: u64,
    /// Deliveries lost to the link's loss rate (a reliable send: after every attempt).
    pub lost: u64,
    /// Extra copies delivered.
    pub duplicated: u64,
    /// Dropped because a partition separated the two ends.
    pub cut: u64,
    /// Dropped because the receiver was dead (killed, closed, restarted).
    pub dead: u64,
    /// Retransmissions of reliable sends.
    pub retransmits: u64,
}

impl LinkCounter {
    /// Adds another counter to this one.
    pub fn add(&mut self, o: &LinkCounter) {
        self.sent_msgs += o.sent_msgs;
        self.sent_bytes += o.sent_bytes;
        self.delivered_msgs += o.delivered_msgs;
        self.delivered_bytes += o.delivered_bytes;
        self.lost += o.lost;
        self.duplicated += o.duplicated;
        self.cut += o.cut;
        self.dead += o.dead;
        self.retransmits += o.retransmits;
    }
}

/// One sender's transmitter on one kind of link.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Radio {
    /// Messages transmitted (a publish once, however many receive it).
    pub msgs: u64,
    /// Bytes transmitted.
    pub bytes: u64,
    /// Time spent transmitting.
    pub busy: Duration,
    /// Total time messages waited for the transmitter.
    pub queued: Duration,
    /// The longest any message waited.
    pub max_queued: Duration,
}

/// One kind of link's air, all its transmitters together: frames, airtime, sizes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Channel {
    /// Frames put on the air (a publish's once, however many receive it; a reliable
    /// send's every attempt).
    pub frames_sent: u64,
    /// Frames lost: per receiver for a publish, per attempt for a reliable send.
    pub frames_lost: u64,
    /// The largest frame put on the air, bytes.
    pub largest_frame: usize,
    /// The largest message put on the air, bytes.
    pub largest_message: usize,
    /// Airtime reserved so far, queued transmissions included.
    pub airtime: Duration,
    /// Messages the senders dropped because they would have waited longer than the
    /// link's `max_queue` (never on the air, in no other counter).
    pub dropped: u64,
}

/// Everything a [`SimNet`](crate::SimNet) counted. Same seed, same scenario: same stats.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SimStats {
    /// Per directed link `(from, to)` and message kind.
    pub links: BTreeMap<(Address, Address), BTreeMap<MsgKind, LinkCounter>>,
    /// Per transmitter `(sender, kind of link)`.
    pub radios: BTreeMap<(Address, LinkKind), Radio>,
    /// Per kind of link, its air (every transmitter together).
    pub channels: BTreeMap<LinkKind, Channel>,
    /// Events processed by the step loop.
    pub events: u64,
}

impl SimStats {
    /// All links of one kind and message kinds together.
    pub fn total(&self, kind: LinkKind) -> LinkCounter {
        self.sum(|link, _| link == kind)
    }

    /// One message kind over all links of one kind.
    pub fn kind(&self, kind: LinkKind, msg: MsgKind) -> LinkCounter {
        self.sum(|link, m| link == kind && m == msg)
    }

    fn sum(&self, pick: impl Fn(LinkKind, MsgKind) -> bool) -> LinkCounter {
        let mut total = LinkCounter::default();
        for ((from, to), kinds) in &self.links {
            let link = LinkKind::between(from, to);
            for (msg, c) in kinds.iter().filter(|(m, _)| pick(link, **m)) {
                let _ = msg;
                total.add(c);
            }
        }
        total
    }
}

/// The per-link counters while the network runs: found by hashing the two addresses, not
/// by comparing address texts down a `BTreeMap` of address pairs (which also cloned
/// both addresses for every look-up), once per message and receiver. The ordered
/// [`SimStats::links`] is built from them when the stats are read.
#[derive(Default)]
pub(crate) struct LinkCounters(
    FxHashMap<Address, FxHashMap<Address, BTreeMap<MsgKind, LinkCounter>>>,
);

impl LinkCounters {
    pub(crate) fn link(&mut self, from: &Address, to: &Address, kind: MsgKind) -> &mut LinkCounter {
        if !self.0.contains_key(from) {
            self.0.insert(from.clone(), FxHashMap::default());
        }
        let tos = self.0.get_mut(from).expect("inserted above");
        if !tos.contains_key(to) {
            tos.insert(to.clone(), BTreeMap::new());
        }
        tos.get_mut(to)
            .expect("inserted above")
            .entry(kind)
            .or_default()
    }

    /// The counters by `(from, to)`, in address order.
    pub(crate) fn ordered(&self) -> BTreeMap<(Address, Address), BTreeMap<MsgKind, LinkCounter>> {
        self.0
            .iter()
            .flat_map(|(from, tos)| {
                tos.iter()
                    .map(move |(to, kinds)| ((from.clone(), to.clone()), kinds.clone()))
            })
            .collect()
    }
}
