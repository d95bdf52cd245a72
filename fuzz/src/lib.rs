//! What the fuzz targets share: the ICI receive harness (one module on a simulated
//! network, fed raw bytes from peers), the record format of its inputs, and the checks
//! made on `.slate` texts. The seed writer (`examples/seeds.rs`) uses the same harness
//! to record real traffic, so the corpus starts from frames a team really sends.
//!
//! Every function here must never panic on any input: a panic is what libFuzzer reports.

use std::sync::Arc;
use std::time::Duration;

use slate_ici::{
    Ici, IciConfig, LinkKind, MsgKind, SimConfig, SimNet, SimTransport, TeamProtocol, Transport,
};
use slate_model::{Address, Board};

/// The module under test.
pub const ME: &str = "fz/r1/me";

/// The peers an input speaks as: two on the module's robot (robot link), two on
/// another robot (team link). A record's selector picks one.
pub const PEERS: [&str; 4] = ["fz/r1/nav", "fz/r1/loco", "fz/r2/exec", "fz/r2/nav"];

/// The most records one input may hold, so that one input's run stays short.
pub const MAX_RECORDS: usize = 64;

/// Simulated time one selector step is worth (the selector's top 5 bits count steps).
pub const STEP: Duration = Duration::from_millis(40);

/// The configuration every module of the harness runs: the team protocol on (its radio
/// preset), exporting everything, so that every frame kind has a receiver.
pub fn config() -> IciConfig {
    IciConfig::default()
        .export(slate_ici::ClassSet::all())
        .team_protocol(Some(TeamProtocol::radio()))
}

/// A board at `address` on `net`'s clock, knowing slate-wire's fuzz classes.
pub fn board(net: &SimNet, address: &Address) -> Option<Arc<Board>> {
    let board = Board::builder()
        .clock(net.clock())
        .address(address.clone())
        .build();
    for def in slate_wire::fuzz_classes() {
        board.define(def).ok()?;
    }
    Some(Arc::new(board))
}

/// An address of the harness (all are valid; `None` would be a bug in the constants).
pub fn address(text: &str) -> Option<Address> {
    Address::new(text).ok()
}

/// One message of an input: who sends it, whether addressed to [`ME`] or published on
/// the link between them, the bytes, and how long the network runs after it.
#[derive(Clone, Debug, PartialEq)]
pub struct Record<'a> {
    pub peer: usize,
    pub addressed: bool,
    pub bytes: &'a [u8],
    pub then: Duration,
}

/// The selector byte of a record: peer in bits 0-1, addressed in bit 2, steps in 3-7.
fn selector(byte: u8) -> (usize, bool, Duration) {
    let steps = u32::from(byte >> 3);
    (usize::from(byte & 3), byte & 4 != 0, STEP * steps)
}

/// Splits an input into records: a selector byte, a 2-byte big-endian length, then that
/// many bytes (fewer if the input ends first). At most [`MAX_RECORDS`].
pub fn records(mut input: &[u8]) -> Vec<Record<'_>> {
    let mut out = Vec::new();
    while let [sel, hi, lo, rest @ ..] = input {
        let len = usize::from(u16::from_be_bytes([*hi, *lo])).min(rest.len());
        let (peer, addressed, then) = selector(*sel);
        let (bytes, after) = rest.split_at(len);
        out.push(Record {
            peer,
            addressed,
            bytes,
            then,
        });
        input = after;
        if out.len() == MAX_RECORDS {
            break;
        }
    }
    out
}

/// Writes one record in the format [`records`] reads.
pub fn write_record(out: &mut Vec<u8>, peer: usize, addressed: bool, steps: u8, bytes: &[u8]) {
    let sel = (steps.min(31) << 3) | (u8::from(addressed) << 2) | (peer as u8 & 3);
    let len = bytes.len().min(usize::from(u16::MAX));
    out.push(sel);
    out.extend_from_slice(&(len as u16).to_be_bytes());
    out.extend_from_slice(&bytes[..len]);
}

/// The module under test and the raw endpoints of its peers, on one network.
pub struct Harness {
    pub net: SimNet,
    pub ici: Ici,
    pub peers: Vec<Arc<SimTransport>>,
}

impl Harness {
    /// A fresh network (seed 1) with the module started and its peers joined. The
    /// network's clock moves in steps of up to [`STEP`], not the simulator's 10 ms: the
    /// module's timers fire at most a step late, and an input's run costs a quarter of
    /// the ticks.
    pub fn new() -> Option<Harness> {
        let sim = SimConfig {
            step: STEP,
            ..SimConfig::default()
        };
        let net = SimNet::with_config(1, sim);
        let me = address(ME)?;
        let ici = Ici::new(board(&net, &me)?, net.join(&me), config()).ok()?;
        let peers = PEERS
            .iter()
            .map(|p| address(p).map(|a| net.join(&a)))
            .collect::<Option<Vec<_>>>()?;
        Some(Harness { net, ici, peers })
    }

    /// Delivers one record to the module and runs the network on. Refusals by the
    /// transport (a congested queue) are ignored: the bytes are what is being fuzzed.
    pub fn deliver(&self, record: &Record<'_>) {
        let Some(peer) = self.peers.get(record.peer) else {
            return;
        };
        let kind = MsgKind::of(record.bytes);
        let me = self.ici.address();
        let _ = if record.addressed {
            peer.send(me, kind, record.bytes)
        } else {
            peer.publish(LinkKind::between(peer.address(), me), kind, record.bytes)
        };
        self.net.run_for(record.then);
    }
}

/// The `ici_receive` target: every record delivered in turn, then the timers given a
/// second to react (catch-up requests, NACKs, repairs, timeouts).
pub fn ici_receive(input: &[u8]) {
    let Some(harness) = Harness::new() else {
        panic!("the harness does not start");
    };
    for record in records(input) {
        harness.deliver(&record);
    }
    harness.net.run_for(Duration::from_secs(1));
}

/// The `slate_parse` target: the lexer and parser on any text. A parsed file's trigger
/// expressions print (fully parenthesised) and must parse back to the same print; every
/// diagnostic of a refused text must point inside it and render.
pub fn slate_parse(source: &str) {
    match slate_plans::parse(source) {
        Ok(file) => triggers_print_back(&file),
        Err(diagnostics) => diagnostics_point_inside(source, &diagnostics),
    }
}

/// Each plan trigger of `file` printed, parsed again as a trigger, prints the same.
/// A printed expression deeper than the parser's nesting cap is refused, not compared.
fn triggers_print_back(file: &slate_plans::File) {
    for item in &file.items {
        let slate_plans::Item::Plan(plan) = item else {
            continue;
        };
        let Some(trigger) = &plan.trigger else {
            continue;
        };
        let printed = trigger.to_string();
        let again = format!("plan p {{ trigger: {printed}; action {{}} }}");
        match slate_plans::parse(&again) {
            Ok(back) => assert_eq!(first_trigger(&back), Some(printed), "{again}"),
            Err(d) => assert!(
                too_deep(&d),
                "a printed trigger does not parse: {again}\n{d:?}"
            ),
        }
    }
}

fn first_trigger(file: &slate_plans::File) -> Option<String> {
    file.items.iter().find_map(|item| match item {
        slate_plans::Item::Plan(plan) => plan.trigger.as_ref().map(ToString::to_string),
        _ => None,
    })
}

/// Whether the parser refused a text only for its nesting (the printed form adds one
/// level of parentheses per operator, so it can pass the cap the source kept to).
fn too_deep(d: &slate_plans::Diagnostics) -> bool {
    d.0.iter().all(|d| d.message.contains("levels"))
}

/// Every diagnostic's span lies inside `source` on character boundaries, and the whole
/// list renders.
fn diagnostics_point_inside(source: &str, d: &slate_plans::Diagnostics) {
    for diagnostic in &d.0 {
        let span = diagnostic.span;
        assert!(
            span.start <= span.end && span.end <= source.len(),
            "{diagnostic:?}"
        );
        assert!(source.is_char_boundary(span.start), "{diagnostic:?}");
        assert!(source.is_char_boundary(span.end), "{diagnostic:?}");
    }
    let rendered = d.render("fuzz.slate", source);
    assert!(!rendered.is_empty());
}

/// The `slate_check` target: the whole load (parse, check, apply, install plans) of a
/// text on a fresh board, as `slate check` and a node's start do. A refusal must render.
pub fn slate_check(source: &str) {
    let board = Arc::new(Board::new());
    let engine = slate_plans::Engine::new(&board);
    if let Err(e) = engine.load("fuzz.slate", source) {
        assert!(!e.diagnostics.0.is_empty(), "a refusal without a reason");
        assert!(!e.rendered.is_empty());
    }
}

/// The `node_config` target: a node's TOML config read as `slate node` reads it. A
/// refusal must say something. Built with the `node` feature only.
#[cfg(feature = "node")]
pub fn node_config(text: &str) {
    let base = std::path::Path::new("/nonexistent-slate-fuzz");
    if let Err(e) = slate_node::NodeConfig::parse("fuzz.toml", text, base) {
        assert!(!e.to_string().is_empty());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_read_back_what_write_record_wrote() {
        let mut input = Vec::new();
        write_record(&mut input, 2, true, 3, b"abc");
        write_record(&mut input, 1, false, 0, b"");
        let got = records(&input);
        assert_eq!(got.len(), 2);
        assert_eq!(
            (got[0].peer, got[0].addressed, got[0].bytes),
            (2, true, &b"abc"[..])
        );
        assert_eq!(got[0].then, STEP * 3);
        assert_eq!(
            (got[1].peer, got[1].addressed, got[1].bytes),
            (1, false, &b""[..])
        );
    }
}
