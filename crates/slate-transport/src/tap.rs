//! A transport that passes everything on to another, and each publication through a
//! test's tap first: to note what the ICI published (its kind, its [`Flow`]) or to lose
//! some as a congested link would. Compiled only with the crate's `testing` feature.

use std::sync::Arc;

use slate_model::Address;

use crate::{Flow, Handler, LinkKind, LinkStats, MsgKind, SendError, Transport};

/// Says whether a publication of this kind and flow on this link goes on (`false`: it
/// is lost, and the publisher is told it went).
type Tap = dyn Fn(LinkKind, MsgKind, Flow) -> bool + Send + Sync;

/// `inner`, with every publication passed through a tap first (see the module).
pub struct Tapped {
    inner: Arc<dyn Transport>,
    tap: Box<Tap>,
}

impl Tapped {
    /// `inner`, its publications passed through `tap`.
    pub fn new(
        inner: Arc<dyn Transport>,
        tap: impl Fn(LinkKind, MsgKind, Flow) -> bool + Send + Sync + 'static,
    ) -> Self {
        Tapped {
            inner,
            tap: Box::new(tap),
        }
    }
}

impl Transport for Tapped {
    fn address(&self) -> &Address {
        self.inner.address()
    }

    fn set_handler(&self, handler: Arc<dyn Handler>) {
        self.inner.set_handler(handler)
    }

    fn publish(&self, link: LinkKind, kind: MsgKind, payload: &[u8]) -> Result<(), SendError> {
        self.publish_with(link, kind, payload, Flow::Latest)
    }

    fn publish_with(
        &self,
        link: LinkKind,
        kind: MsgKind,
        payload: &[u8],
        flow: Flow,
    ) -> Result<(), SendError> {
        if !(self.tap)(link, kind, flow) {
            return Ok(());
        }
        self.inner.publish_with(link, kind, payload, flow)
    }

    fn send(&self, to: &Address, kind: MsgKind, payload: &[u8]) -> Result<(), SendError> {
        self.inner.send(to, kind, payload)
    }

    fn peers(&self) -> Vec<Address> {
        self.inner.peers()
    }

    fn stats(&self) -> LinkStats {
        self.inner.stats()
    }

    fn close(&self) {
        self.inner.close()
    }

    fn listen(&self, link: LinkKind, on: bool) -> bool {
        self.inner.listen(link, on)
    }

    fn retransmits(&self) -> bool {
        self.inner.retransmits()
    }
}
