//! The transport conformance suite, on the simulator.

use slate_transport::conformance::SimFactory;

slate_transport::transport_conformance!(SimFactory::new(7));

#[test]
fn the_whole_suite_runs_from_one_call() {
    slate_transport::conformance::run_all(|| SimFactory::new(11));
}
