//! What the ICI itself costs per update, without a network: two modules of one robot
//! joined by an in-memory queue, the sender committing batches of updates of 100 tracked
//! objects and the receiver merging each report, in one thread.
//!
//! `cargo run --release -p slate-ici --example ici_cost [BATCHES [SIZE [COLD]]]` prints
//! the time per update, the sender's and the receiver's apart (SIZE updates a batch, 100
//! at most; SIZE 1 writes one bare value at a time, as a latency probe does); under
//! `valgrind --tool=callgrind` it shows where the instructions go.
//!
//! COLD (MiB) sweeps that much memory after every batch, so that each finds the caches
//! as a robot's occasional update does after other work ran (a few MiB cover an L2,
//! more than the L3 covers everything); under `valgrind --tool=cachegrind
//! --cache-sim=yes` it shows which functions miss.

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Instant;

use parking_lot::Mutex;
use slate_ici::{Handler, Ici, IciConfig, LinkKind, LinkStats, MsgKind, SendError, Transport};
use slate_model::{Address, AttrDecl, Board, ClassDef, Update, ValueType};

type Error = Box<dyn std::error::Error>;

/// A module: its board, its end of the queue, its ICI.
type Node = (Arc<Board>, Arc<Endpoint>, Ici);

/// Messages in flight: (to, from, bytes).
type Queue = Arc<Mutex<VecDeque<(Address, Address, Vec<u8>)>>>;

struct Endpoint {
    me: Address,
    peer: Address,
    queue: Queue,
    handler: Mutex<Option<Arc<dyn Handler>>>,
}

impl Transport for Endpoint {
    fn address(&self) -> &Address {
        &self.me
    }

    fn set_handler(&self, handler: Arc<dyn Handler>) {
        handler.peer(&self.peer, true);
        *self.handler.lock() = Some(handler);
    }

    fn publish(&self, _: LinkKind, _: MsgKind, payload: &[u8]) -> Result<(), SendError> {
        self.send(&self.peer.clone(), MsgKind::Unknown, payload)
    }

    fn send(&self, to: &Address, _: MsgKind, payload: &[u8]) -> Result<(), SendError> {
        let item = (to.clone(), self.me.clone(), payload.to_vec());
        self.queue.lock().push_back(item);
        Ok(())
    }

    fn peers(&self) -> Vec<Address> {
        vec![self.peer.clone()]
    }

    fn stats(&self) -> LinkStats {
        LinkStats::default()
    }

    fn close(&self) {}
}

fn main() -> Result<(), Error> {
    let arg = |i: usize, default: usize| -> Result<usize, std::num::ParseIntError> {
        std::env::args().nth(i).map_or(Ok(default), |a| a.parse())
    };
    let (batches, size) = (arg(1, 2000)?, arg(2, 100)?.clamp(1, 100));
    let mut sweep = vec![0u8; arg(3, 0)? << 20];
    let queue: Queue = Arc::default();
    let (a, b) = (Address::new("t/r1/a")?, Address::new("t/r1/b")?);
    let level = |name| {
        AttrDecl::new(name, ValueType::Real)
            .bounds(0.0, 1000.0)
            .resolution(0.01)
    };
    let attrs = ["range", "level", "depth", "width"];
    let class = attrs
        .iter()
        .fold(ClassDef::new("Tracked"), |c, n| c.attr(level(n)));
    let node = |me: &Address, peer: &Address| -> Result<Node, slate_ici::Error> {
        let board = Arc::new(Board::builder().address(me.clone()).build());
        board.define(class.clone())?;
        let t = Arc::new(Endpoint {
            me: me.clone(),
            peer: peer.clone(),
            queue: queue.clone(),
            handler: Mutex::new(None),
        });
        let ici = Ici::new(board.clone(), t.clone(), IciConfig::default())?;
        Ok((board, t, ici))
    };
    let (board_a, ta, _ica) = node(&a, &b)?;
    let (board_b, tb, _icb) = node(&b, &a)?;
    let deliver = || {
        loop {
            let next = queue.lock().pop_front();
            let Some((to, from, bytes)) = next else { break };
            let t = if to == a { &ta } else { &tb };
            let h = t.handler.lock().clone();
            if let Some(h) = h {
                h.message(&from, &bytes);
            }
        }
    };
    deliver();
    let mut batch = board_a.batch();
    for i in 0..100 {
        batch.create("Tracked", &format!("t{i}"));
    }
    batch.commit()?;
    deliver();
    let keys = (0..100)
        .map(|i| {
            attrs
                .iter()
                .map(|n| board_a.key(&format!("t{i}"), n))
                .collect::<Result<Vec<_>, _>>()
        })
        .collect::<Result<Vec<_>, _>>()?;
    let (mut sending, mut receiving) = (0u128, 0u128);
    let mut n = 0usize;
    let update = |n: usize| {
        let v = (n % 100_000) as f64 / 100.0;
        Update::new(v)
            .accuracy(0.013 + (n % 7) as f64)
            .confidence(0.9)
    };
    for _ in 0..batches {
        let t0 = Instant::now();
        if size == 1 {
            // One write at a time: the latency path, as `slate bench net` probes it (a
            // bare value, to one attribute).
            board_a.write_key(keys[0][0], (n % 100_000) as f64 / 100.0)?;
            n += 1;
        } else {
            let mut batch = board_a.batch();
            for k in &keys[..size] {
                batch.write_key(k[n % attrs.len()], update(n));
                n += 1;
            }
            batch.commit()?;
        }
        let t1 = Instant::now();
        deliver();
        let t2 = Instant::now();
        sending += (t1 - t0).as_nanos();
        receiving += (t2 - t1).as_nanos();
        if !sweep.is_empty() {
            // Write every cache line: what other work would leave behind.
            for line in sweep.chunks_mut(64) {
                line[0] = line[0].wrapping_add(1);
            }
            std::hint::black_box(&sweep);
        }
    }
    let attr = if size == 1 { 0 } else { (n - 1) % attrs.len() };
    let name = format!("t{}", size - 1);
    let (sent, got) = (
        board_a.read_key(keys[size - 1][attr])?,
        board_b.read(&name, attrs[attr])?,
    );
    assert_eq!(sent, got, "the receiver holds the sender's last packet");
    let per = |ns: u128| ns as f64 / n as f64;
    println!(
        "{n} updates in {batches} batches: {:.0} ns per update (sender and receiver, one thread: \
         sender {:.0}, receiver {:.0}){}",
        per(sending + receiving),
        per(sending),
        per(receiving),
        if sweep.is_empty() {
            ""
        } else {
            ", caches swept between batches"
        }
    );
    Ok(())
}
