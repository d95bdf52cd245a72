//! The ICI under threads: writers on several threads while the network runs on another
//! (as Zenoh's callbacks would), without deadlock, and the boards still agree.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use slate_ici::{Ici, SimConfig, SimNet, SimTransport};
use slate_model::Board;

use crate::support::{Team, secs};

#[test]
fn ici_and_the_simulator_are_send_and_sync() {
    fn both<T: Send + Sync>() {}
    both::<Ici>();
    both::<SimNet>();
    both::<SimTransport>();
}

#[test]
fn writers_on_other_threads_while_the_network_runs() {
    let team = Team::grid(50, SimConfig::default(), 2, 2);
    team.run(0.5);
    for n in &team.members {
        let name = format!("rock_{}_{}", n.address.robot(), n.address.module());
        n.board.create("Rock", &name).unwrap();
    }
    let done = Arc::new(AtomicBool::new(false));
    let boards: Vec<(Arc<Board>, String)> = team
        .members
        .iter()
        .map(|n| {
            let own = format!("rock_{}_{}", n.address.robot(), n.address.module());
            (n.board.clone(), own)
        })
        .collect();
    let net = team.net.clone();
    std::thread::scope(|s| {
        for (i, (board, own)) in boards.iter().enumerate() {
            s.spawn(move || {
                for k in 0..300 {
                    board.write(own, "x", f64::from(k)).unwrap();
                    let _ = board.write("Tracked", "label", format!("w{i}_{k}"));
                }
            });
        }
        let done = done.clone();
        s.spawn(move || {
            for _ in 0..200 {
                net.run_for(secs(0.01));
            }
            done.store(true, Ordering::SeqCst);
        });
    });
    assert!(done.load(Ordering::SeqCst));
    team.assert_converges(30);
    for n in &team.members {
        let own = format!("rock_{}_{}", n.address.robot(), n.address.module());
        for other in &team.members {
            let x = other.board.read(&own, "x").unwrap().value.as_f64();
            assert_eq!(x, Some(299.0), "{own} on {}", other.address);
        }
    }
}

#[test]
fn the_last_own_write_survives_normalisation_on_another_thread() {
    // The normalisation of a write (its packet replaced by the quantised one) may be
    // applied by another thread while the writer writes again: after each burst, the
    // last write must stand, quantised, whatever the interleaving.
    use slate_ici::IciConfig;
    use slate_model::{AttrDecl, ClassDef, Update, ValueType};
    let net = SimNet::new(51);
    let address = crate::support::addr("t/r1/a");
    let board = Arc::new(Board::builder().address(address.clone()).build());
    let decl = AttrDecl::new("v", ValueType::Real)
        .bounds(0.0, 1000.0)
        .resolution(0.01);
    board.define(ClassDef::new("Gauge").attr(decl)).unwrap();
    board.create("Gauge", "g").unwrap();
    let ici = Ici::new(board.clone(), net.join(&address), IciConfig::default()).unwrap();
    /// Stops the other thread even if an assertion fails (the scope waits for it).
    struct Stop<'a>(&'a AtomicBool);
    impl Drop for Stop<'_> {
        fn drop(&mut self) {
            self.0.store(true, Ordering::SeqCst);
        }
    }
    let stop = AtomicBool::new(false);
    std::thread::scope(|s| {
        s.spawn(|| {
            while !stop.load(Ordering::SeqCst) {
                ici.tick();
            }
        });
        let _stop = Stop(&stop);
        for round in 0..300u32 {
            let mut last = 0.0;
            for k in 0..40u32 {
                last = f64::from((round * 40 + k) % 1000) + 0.123_456;
                board
                    .write("g", "v", Update::new(last).confidence(0.5))
                    .unwrap();
            }
            // The other thread may still be applying: the board settles on the last
            // write, quantised (a stale packet never would).
            let want = (last * 100.0).round() / 100.0;
            let settled = |p: &slate_model::Packet| {
                p.value.as_f64().is_some_and(|v| (v - want).abs() < 1e-9)
                    && p.confidence == (0.5f64 * 255.0).round() / 255.0
            };
            let deadline = std::time::Instant::now() + std::time::Duration::from_secs(5);
            let mut p = board.read("g", "v").unwrap();
            while !settled(&p) && std::time::Instant::now() < deadline {
                ici.tick();
                std::thread::sleep(std::time::Duration::from_millis(1));
                p = board.read("g", "v").unwrap();
            }
            assert!(settled(&p), "round {round}: {p:?} after writing {last}");
        }
    });
}
