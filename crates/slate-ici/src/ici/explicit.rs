//! Explicit reports: packets a caller (a plan's `report` action) wants delivered now, to
//! one module or to every interested peer, whoever wrote them. They skip the report
//! filters and the export policy (the plan is the export decision), not the receivers'
//! interest.

use std::sync::Arc;

use slate_model::{Address, Packet};
use slate_wire::Assertion;

use super::ops::own_packet;
use super::send::Item;
use super::state::State;
use crate::LinkKind;

impl State {
    /// Sends `packets` now: on every link kind's stream to the peers interested
    /// (`to: None`), or reliably to one module. Returns how many packets went out.
    pub fn report_explicit(
        &mut self,
        to: Option<&Address>,
        packets: Vec<(Arc<str>, Arc<str>, Packet)>,
    ) -> usize {
        let items: Vec<Item> = packets
            .into_iter()
            .filter_map(|(o, a, p)| self.explicit_item(o, a, p))
            .collect();
        let sent = match to {
            None => self.explicit_to_all(&items),
            Some(to) if *to == self.me => 0,
            Some(to) => self.explicit_to(to, &items),
        };
        self.stats.reports.explicit += sent as u64;
        sent
    }

    /// An item for a packet the object (or class) holds itself: an inherited or default
    /// value is not the object's to report (its class reports it).
    fn explicit_item(&mut self, object: Arc<str>, attr: Arc<str>, packet: Packet) -> Option<Item> {
        if packet.value.is_none() {
            return None;
        }
        own_packet(&self.board, &(object.clone(), attr.clone()))?;
        self.value_item(&object, &attr, packet)
    }

    fn explicit_to_all(&mut self, items: &[Item]) -> usize {
        let mut sent = 0;
        for link in LinkKind::ALL {
            let peers = self.up_peers(link);
            let chosen: Vec<&Item> = items
                .iter()
                .filter(|i| peers.iter().any(|p| self.peer_wants_item(p, i)))
                .collect();
            sent += chosen.len();
            self.emit(link, &chosen);
        }
        sent
    }

    /// To one module: off the stream (its position does not move, so the other
    /// receivers see no gap), as a current-state message sent reliably. A peer whose
    /// interest is not known yet gets everything.
    fn explicit_to(&mut self, to: &Address, items: &[Item]) -> usize {
        let known = self.peers.get(to).is_some_and(|p| p.interest.is_some());
        let chosen: Vec<Assertion> = items
            .iter()
            .filter(|i| !known || self.peer_wants_item(to, i))
            .filter_map(|i| match i {
                Item::Value(s, packet) => Some(Assertion {
                    object: s.object.clone(),
                    attr: s.attr.clone(),
                    packet: packet.clone(),
                }),
                _ => None,
            })
            .collect();
        let link = LinkKind::between(&self.me, to);
        let seq = self.out.get(&link).map_or(0, |o| o.seq);
        for chunk in chosen.chunks(self.config.max_report_items.max(1)) {
            self.send_answer(super::catchup::Audience::Peer(to), seq, chunk);
        }
        chosen.len()
    }
}
