//! Shared helpers: fast configurations (and the shared timeout guard).

use slate_demo::DemoConfig;
pub use slate_testing::within;

/// The default mission for `seed`, on the simulator.
pub fn config(seed: u64) -> DemoConfig {
    DemoConfig::default().seed(seed)
}
