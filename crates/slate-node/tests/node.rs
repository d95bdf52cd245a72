//! Integration tests of slate-node: nodes on the simulator (`sim`), the dashboard a node
//! serves (`dashboard`), configs and start errors (`config`).

mod node {
    pub mod common;
    mod config;
    mod dashboard;
    mod sim;
}
