//! The transport conformance suite, over real Zenoh sessions on 127.0.0.1.

use std::sync::Arc;
use std::thread;
use std::time::{Duration, Instant};

use slate_model::Address;
use slate_testing::free_port;
use slate_zenoh::{ZenohConfig, ZenohTransport};

/// A fresh Zenoh network per test: every endpoint listens on its own loopback port and
/// connects to the ones before it.
#[derive(Default)]
pub struct Loopback {
    endpoints: Vec<String>,
}

impl slate_transport::conformance::TransportFactory for Loopback {
    type Transport = ZenohTransport;

    fn join(&mut self, address: &Address) -> Arc<ZenohTransport> {
        let endpoint = format!("tcp/127.0.0.1:{}", free_port());
        let config = ZenohConfig {
            listen: vec![endpoint.clone()],
            connect: self.endpoints.clone(),
            ..ZenohConfig::default()
        };
        self.endpoints.push(endpoint);
        ZenohTransport::open(address.clone(), &config).expect("zenoh session opens")
    }

    fn run_until(&mut self, done: &mut dyn FnMut() -> bool) -> bool {
        let deadline = Instant::now() + Duration::from_secs(10);
        while Instant::now() < deadline {
            if done() {
                return true;
            }
            thread::sleep(Duration::from_millis(10));
        }
        done()
    }

    fn settle(&mut self) {
        thread::sleep(Duration::from_millis(300));
    }
}

slate_transport::transport_conformance!(Loopback::default());
