//! Counting the team link by inner kind (step 16): a frame's or repair's bytes are
//! attributed to the messages inside it, and only the rest (header, position, part
//! bytes and lengths) to the frame itself, so `IciStats::traffic` shows reports, lifecycle,
//! object lists ... on the team link as it did before the team protocol, and the bytes by
//! kind still add up to what the transport carried.

use slate_model::Address;

use super::frame::{Part, RepairContent, TeamMsg};
use crate::ici::state::State;
use crate::ici::stats::Inner;
use crate::{LinkKind, MsgKind};

/// The inner messages of a team protocol message, by kind and bytes. Only frames and
/// repairs hold any; a repair's replayed messages count under their kinds, like the
/// retransmissions they are (docs/team-protocol.md 2.10).
pub(crate) fn inner_of(msg: &TeamMsg) -> Vec<Inner> {
    match msg {
        TeamMsg::Frame(f) => inner_of_parts(&f.parts).collect(),
        TeamMsg::Repair(r) => match &r.content {
            RepairContent::Replay(bodies) => {
                bodies.iter().flat_map(|b| inner_of_parts(b)).collect()
            }
            RepairContent::Difference { parts, .. } => inner_of_parts(parts).collect(),
        },
        _ => Vec::new(),
    }
}

/// The inner messages of a list of parts. A continuation fragment (`cont`) is left to the
/// envelope: its first bytes are the middle of a message, not a header that names a kind
/// (fragments are rare: messages longer than the MTU).
fn inner_of_parts(parts: &[Part]) -> impl Iterator<Item = Inner> + '_ {
    parts.iter().filter_map(inner_of_part)
}

/// A part's message, unless it is a continuation. An addressed part's message (a plan,
/// an ack) counts under its kind; its destination bytes are the envelope's.
fn inner_of_part(part: &Part) -> Option<Inner> {
    (!part.cont).then(|| Inner {
        kind: MsgKind::of(&part.bytes),
        bytes: part.bytes.len(),
    })
}

impl State {
    /// Publishes a team protocol message on the team link and counts it by inner kind
    /// (a refused publish counts as a send error, as `publish_now` does). A gateway's
    /// bucket is charged for it (2.3).
    pub(super) fn publish_team(&mut self, kind: MsgKind, bytes: &[u8], inner: &[Inner]) {
        self.team_aired(LinkKind::Team, bytes.len());
        match self.transport.publish(LinkKind::Team, kind, bytes) {
            Ok(()) => self
                .stats
                .sent_team(LinkKind::Team, kind, bytes.len(), inner),
            Err(e) => {
                self.stats.reports.send_errors += 1;
                tracing::debug!(%kind, error = %e, "team publish refused");
            }
        }
    }

    /// Counts a received team frame or repair by inner kind (`on_message` leaves them to
    /// this); one that did not decode (`msg` `None`) counts whole under its header's kind.
    pub(super) fn count_team_received(
        &mut self,
        from: &Address,
        bytes: &[u8],
        msg: Option<&TeamMsg>,
    ) {
        let kind = MsgKind::of(bytes);
        if !matches!(kind, MsgKind::TeamFrame | MsgKind::TeamRepair) {
            return;
        }
        let inner = msg.map(inner_of).unwrap_or_default();
        let link = LinkKind::between(&self.me, from);
        self.stats.received_team(link, kind, bytes.len(), &inner);
    }

    /// Encodes a team protocol message, publishes it and counts it; returns the bytes.
    pub(super) fn publish_team_msg(&mut self, kind: MsgKind, msg: &TeamMsg) -> Vec<u8> {
        let bytes = msg.encode();
        self.publish_team(kind, &bytes, &inner_of(msg));
        bytes
    }
}

#[cfg(test)]
mod tests {
    use slate_testing::addr;

    use super::super::frame::{StreamTag, TeamFrame, TeamRepair};
    use super::super::test_state::{START, alone, lifecycle, robot_hello};
    use super::*;

    use crate::ici::stats::IciStats;
    use crate::{IciConfig, TeamProtocol};

    /// Stand-in report bytes: the `Report` header byte, then `len - 1` bytes.
    fn report(len: usize) -> Vec<u8> {
        let mut bytes = vec![0x11];
        bytes.resize(len, 7);
        bytes
    }

    fn sent_bytes(stats: &IciStats, kind: MsgKind) -> u64 {
        stats.get(LinkKind::Team, kind).sent_bytes
    }

    fn count_sent(stats: &mut IciStats, kind: MsgKind, msg: &TeamMsg) -> usize {
        let total = msg.encode().len();
        stats.sent_team(LinkKind::Team, kind, total, &inner_of(msg));
        total
    }

    fn two_reports() -> Vec<Part> {
        vec![Part::member(0, report(40)), Part::member(1, report(25))]
    }

    #[test]
    fn a_frame_of_two_reports_counts_two_reports_and_the_header_bytes() {
        let mut stats = IciStats::default();
        let frame = TeamMsg::Frame(TeamFrame {
            seq: 3,
            check: 0,
            parts: two_reports(),
        });
        let total = count_sent(&mut stats, MsgKind::TeamFrame, &frame);
        let reports = stats.get(LinkKind::Team, MsgKind::Report);
        assert_eq!((reports.sent_msgs, reports.sent_bytes), (2, 65));
        let envelope = stats.get(LinkKind::Team, MsgKind::TeamFrame);
        // Header, tag check, seq, the first part's byte and length, the last part's byte.
        assert_eq!((envelope.sent_msgs, envelope.sent_bytes), (1, 6));
        assert_eq!(stats.link(LinkKind::Team).sent_bytes, total as u64);
        assert_eq!((stats.team.frames, stats.team.envelope_bytes), (1, 6));
    }

    #[test]
    fn a_repair_counts_its_replayed_reports_as_reports_and_its_bytes_apart() {
        let mut stats = IciStats::default();
        let bodies = vec![two_reports(), vec![Part::member(0, report(30))]];
        let repair = TeamMsg::Repair(TeamRepair {
            from: 1,
            check: 0,
            content: RepairContent::Replay(bodies),
        });
        let total = count_sent(&mut stats, MsgKind::TeamRepair, &repair);
        assert_eq!(sent_bytes(&stats, MsgKind::Report), 95);
        assert_eq!(sent_bytes(&stats, MsgKind::TeamRepair), total as u64 - 95);
        assert_eq!(
            (stats.team.repairs, stats.team.repair_bytes),
            (1, total as u64)
        );
        assert_eq!(stats.link(LinkKind::Team).sent_bytes, total as u64);
    }

    #[test]
    fn a_continued_fragment_counts_as_the_frames_own_bytes() {
        let first = Part {
            more: true,
            ..Part::member(0, report(20))
        };
        let rest = Part {
            cont: true,
            ..Part::member(0, vec![0x11; 10])
        };
        let mut stats = IciStats::default();
        let frame = TeamMsg::Frame(TeamFrame {
            seq: 9,
            check: 0,
            parts: vec![first, rest],
        });
        let total = count_sent(&mut stats, MsgKind::TeamFrame, &frame);
        assert_eq!(stats.get(LinkKind::Team, MsgKind::Report).sent_msgs, 1);
        assert_eq!(sent_bytes(&stats, MsgKind::TeamFrame), total as u64 - 20);
    }

    #[test]
    fn other_team_messages_count_whole_under_their_kind() {
        let mut stats = IciStats::default();
        let gone = TeamMsg::Gone(super::super::frame::Gone {
            tag: StreamTag(5),
            span: super::super::frame::Span { from: 1, n: 2 },
            positions: vec![],
        });
        let total = count_sent(&mut stats, MsgKind::Gone, &gone);
        assert_eq!(sent_bytes(&stats, MsgKind::Gone), total as u64);
        assert_eq!((stats.team.gone, stats.team.envelope_bytes), (1, 0));
    }

    fn team_state() -> (crate::SimNet, State) {
        let config = IciConfig::default().team_protocol(Some(TeamProtocol::radio()));
        let (net, mut st) = alone("t/r0/m0", config);
        st.now = START;
        (net, st)
    }

    fn hello(gateway: &slate_model::Address) -> Vec<u8> {
        TeamMsg::Hello(robot_hello(gateway, 9, &["m1"])).encode()
    }

    #[test]
    fn a_received_frames_inner_messages_count_once_under_their_kind() {
        let (_net, mut st) = team_state();
        let gw = addr("t/r1/m1");
        st.on_message(&gw, &hello(&gw));
        let parts = vec![Part::member(0, lifecycle(1)), Part::member(0, lifecycle(2))];
        let inner: usize = parts.iter().map(|p| p.bytes.len()).sum();
        let frame = TeamMsg::Frame(TeamFrame {
            seq: 1,
            check: 0,
            parts,
        })
        .encode();
        st.on_message(&gw, &frame);
        let lifecycle = st.stats.get(LinkKind::Team, MsgKind::Lifecycle);
        assert_eq!(
            (lifecycle.recv_msgs, lifecycle.recv_bytes),
            (2, inner as u64)
        );
        let envelope = st.stats.get(LinkKind::Team, MsgKind::TeamFrame).recv_bytes;
        assert_eq!(envelope, (frame.len() - inner) as u64);
    }

    #[test]
    fn a_received_frame_heard_twice_counts_twice_but_delivers_once() {
        let (_net, mut st) = team_state();
        let gw = addr("t/r1/m1");
        st.on_message(&gw, &hello(&gw));
        let parts = vec![Part::member(0, lifecycle(1))];
        let frame = TeamMsg::Frame(TeamFrame {
            seq: 1,
            check: 0,
            parts,
        })
        .encode();
        st.on_message(&gw, &frame);
        st.on_message(&gw, &frame);
        let all = st.stats.link(LinkKind::Team).recv_bytes;
        assert_eq!(all, (hello(&gw).len() + 2 * frame.len()) as u64);
        assert_eq!(
            st.stats.get(LinkKind::Team, MsgKind::Lifecycle).recv_msgs,
            2
        );
    }

    #[test]
    fn the_team_bytes_counted_equal_what_the_simulator_transmitted() {
        let (net, mut st) = team_state();
        // A publication nobody hears is not transmitted: another robot listens.
        let _other_robot = net.join(&addr("t/r1/m1"));
        let frame = TeamMsg::Frame(TeamFrame {
            seq: 1,
            check: 0,
            parts: two_reports(),
        });
        st.publish_team_msg(MsgKind::TeamFrame, &frame);
        let bodies = vec![two_reports()];
        let repair = TeamMsg::Repair(TeamRepair {
            from: 1,
            check: 0,
            content: RepairContent::Replay(bodies),
        });
        st.publish_team_msg(MsgKind::TeamRepair, &repair);
        let radio = net.stats().radios[&(addr("t/r0/m0"), LinkKind::Team)];
        assert_eq!(st.stats.link(LinkKind::Team).sent_bytes, radio.bytes);
        let endpoint = st.transport.stats().link(LinkKind::Team).sent_bytes;
        assert_eq!(st.stats.link(LinkKind::Team).sent_bytes, endpoint);
        assert_eq!(sent_bytes(&st.stats, MsgKind::Report), 2 * 65);
    }
}
