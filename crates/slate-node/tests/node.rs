//! Integration tests of slate-node: nodes on the simulator (`sim`), the dashboard a node
//! serves (`dashboard`), configs and start errors (`config`), a node's ICI over Zenoh
//! beside a peer that never reads (`slow_reader`).

mod node {
    pub mod common;
    mod config;
    mod dashboard;
    mod sim;
    mod slow_reader;
}
