//! The world as expressions see it: a board snapshot (plan conditions, evaluated at one
//! revision) or an active function's call (derived attributes and rules).

use std::cell::Cell;
use std::sync::Arc;
use std::time::Duration;

use slate_model::{Call, Clock, Key, Packet, Snapshot};

use crate::eval::{Env, KeyCache};

/// Conditions evaluated on one consistent snapshot.
pub(crate) struct SnapEnv<'a> {
    pub snap: &'a Snapshot<'a>,
    pub clock: &'a Clock,
    /// Did an expression read the clock?
    pub timed: Cell<bool>,
}

impl<'a> SnapEnv<'a> {
    pub fn new(snap: &'a Snapshot<'a>, clock: &'a Clock) -> Self {
        SnapEnv {
            snap,
            clock,
            timed: Cell::new(false),
        }
    }
}

impl Env for SnapEnv<'_> {
    fn read(&self, object: &str, attr: &str) -> Option<Packet> {
        self.snap.read(object, attr).ok()
    }

    fn read_cached(&self, object: &str, attr: &str, cache: &KeyCache) -> Option<Packet> {
        if let Some(Ok(p)) = cache.get().map(|k| self.snap.read_key(k)) {
            return Some(p);
        }
        let key = self.key(object, attr, cache)?;
        self.snap.read_key(key).ok()
    }

    fn key(&self, object: &str, attr: &str, cache: &KeyCache) -> Option<Key> {
        if let Some(k) = cache
            .get()
            .filter(|k| self.snap.name_of(k.object).is_some())
        {
            return Some(k);
        }
        let key = self.snap.key(object, attr).ok()?;
        cache.set(key);
        Some(key)
    }

    fn instances(&self, class: &str) -> Vec<Arc<str>> {
        let ids = self.snap.instances(class).unwrap_or_default();
        ids.into_iter()
            .filter_map(|id| self.snap.name_of(id))
            .collect()
    }

    fn exists(&self, object: &str) -> bool {
        self.snap.exists(object)
    }

    fn now(&self) -> Duration {
        self.timed.set(true);
        self.clock.physical()
    }
}

/// Expressions inside an active function, reading through its call (chain limits apply)
/// and the clock through [`Call::now`] (what a derived attribute's value is kept for).
pub(crate) struct CallEnv<'a, 'c> {
    pub call: &'a Call<'c>,
}

impl Env for CallEnv<'_, '_> {
    fn read(&self, object: &str, attr: &str) -> Option<Packet> {
        self.call.read(object, attr).ok()
    }

    fn instances(&self, class: &str) -> Vec<Arc<str>> {
        let ids = self.call.instances(class).unwrap_or_default();
        ids.into_iter()
            .filter_map(|id| self.call.name_of(id))
            .collect()
    }

    fn exists(&self, object: &str) -> bool {
        self.call.exists(object)
    }

    fn now(&self) -> Duration {
        self.call.now()
    }
}
