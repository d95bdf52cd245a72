//! The team protocol being built (docs/team-protocol.md): one speaker per robot on the
//! team link, a numbered robot stream relaying its modules' messages, repairs by NACK
//! with suppression. Its parts are built and tested one by one here and wired into the
//! ICI's send and receive paths by later steps; until then nothing outside this module
//! calls them.
#![allow(dead_code)]

mod frame;
mod history;
mod nack;
mod outer;
