//! Building a board: its clock, address and limits, and the built-in classes it starts with.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use parking_lot::{Mutex, RwLock};

use super::state::State;
use super::txn::Inner;
use super::{Board, DEFAULT_MAX_DEPTH};
use crate::{Address, Clock};

/// Builds a [`Board`] with a clock, an address and limits.
#[derive(Debug, Default)]
pub struct BoardBuilder {
    clock: Option<Clock>,
    address: Option<Address>,
    max_depth: Option<usize>,
}

impl BoardBuilder {
    /// The clock that stamps writes (default: the system clock).
    pub fn clock(mut self, clock: Clock) -> Self {
        self.clock = Some(clock);
        self
    }

    /// The module this board belongs to: the source of its writes and owner of the
    /// objects it creates (default `local/robot/module`).
    pub fn address(mut self, address: Address) -> Self {
        self.address = Some(address);
        self
    }

    /// The deepest chain of active functions allowed (default [`DEFAULT_MAX_DEPTH`]).
    pub fn max_depth(mut self, depth: usize) -> Self {
        self.max_depth = Some(depth);
        self
    }

    /// Builds the board.
    pub fn build(self) -> Board {
        let default_address =
            || Address::new("local/robot/module").unwrap_or_else(|_| Address::unknown());
        static NEXT_ID: AtomicU64 = AtomicU64::new(1);
        let board = Board {
            id: NEXT_ID.fetch_add(1, Ordering::Relaxed),
            inner: RwLock::new(Inner {
                state: State::new(),
                watchers: Vec::new(),
                hooks: Arc::new([]),
            }),
            clock: self.clock.unwrap_or_default(),
            address: self.address.unwrap_or_else(default_address),
            max_depth: self.max_depth.unwrap_or(DEFAULT_MAX_DEPTH),
            subscribers: Mutex::new(Vec::new()),
            function_failures: AtomicU64::new(0),
            chain_cuts: AtomicU64::new(0),
            future_stamps: AtomicU64::new(0),
            not_owner: AtomicU64::new(0),
            unauthorised: AtomicU64::new(0),
            news: Mutex::new(super::news_limit()),
            fn_seq: AtomicU64::new(0),
        };
        board.define_builtins();
        board
    }
}
