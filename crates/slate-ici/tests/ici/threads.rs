//! The ICI under threads: writers on several threads while the network runs on another
//! (as Zenoh's callbacks would), without deadlock, and the boards still agree.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use slate_ici::{Ici, SimConfig, SimNet, SimTransport};
use slate_model::Board;

use crate::common::{Team, secs};

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
    for n in &team.nodes {
        let name = format!("rock_{}_{}", n.address.robot(), n.address.module());
        n.board.create("Rock", &name).unwrap();
    }
    let done = Arc::new(AtomicBool::new(false));
    let boards: Vec<(Arc<Board>, String)> = team
        .nodes
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
    for n in &team.nodes {
        let own = format!("rock_{}_{}", n.address.robot(), n.address.module());
        for other in &team.nodes {
            let x = other.board.read(&own, "x").unwrap().value.as_f64();
            assert_eq!(x, Some(299.0), "{own} on {}", other.address);
        }
    }
}
