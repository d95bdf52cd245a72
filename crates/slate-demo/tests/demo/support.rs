//! Shared helpers: fast configurations and a timeout guard.

use std::time::Duration;

use slate_demo::DemoConfig;

/// The default mission for `seed`, on the simulator.
pub fn config(seed: u64) -> DemoConfig {
    DemoConfig::default().seed(seed)
}

/// Runs `f` on its own thread and fails the test if it takes longer than `limit` (a
/// guard against hangs, not a performance assertion).
pub fn within<T: Send + 'static>(limit: Duration, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(limit)
        .unwrap_or_else(|_| panic!("did not finish within {limit:?}"))
}

/// The cargo target directory this test binary was built into (`target/`).
pub fn target_dir() -> std::path::PathBuf {
    let exe = std::env::current_exe().expect("current exe");
    // <target>/<profile>/deps/<test binary>
    exe.ancestors().nth(3).expect("target dir").to_path_buf()
}
