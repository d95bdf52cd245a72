//! The transport conformance suite, on the simulator.

use slate_ici::conformance::SimFactory;

slate_ici::transport_conformance!(SimFactory::new(7));

#[test]
fn the_whole_suite_runs_from_one_call() {
    slate_ici::conformance::run_all(|| SimFactory::new(11));
}
