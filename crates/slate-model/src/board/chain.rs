//! The chain of active functions an access runs inside, to cut cycles and deep chains.

use std::sync::Arc;

use crate::{ChainError, Key, Trigger};

/// The accesses (key and trigger) whose active functions are running, outermost first.
#[derive(Clone, Debug, Default)]
pub(crate) struct Chain {
    steps: Vec<(Key, Trigger, Arc<str>, Arc<str>)>,
}

impl Chain {
    /// May an access to `key` with `trigger` run inside this chain? An access outside any
    /// active function always may.
    pub fn admit(
        &self,
        key: Key,
        trigger: Trigger,
        limit: usize,
        names: impl FnOnce() -> (Arc<str>, Arc<str>),
    ) -> Result<(), ChainError> {
        if self.steps.is_empty() {
            return Ok(());
        }
        let (object, attr) = names();
        if let Some(start) = self
            .steps
            .iter()
            .position(|(k, t, ..)| *k == key && *t == trigger)
        {
            let mut path: Vec<String> = self.steps[start..]
                .iter()
                .map(|(_, _, o, a)| format!("{o}.{a}"))
                .collect();
            path.push(format!("{object}.{attr}"));
            return Err(ChainError::Cycle { path });
        }
        if self.steps.len() > limit {
            return Err(ChainError::DepthLimit {
                limit,
                object: object.to_string(),
                attr: attr.to_string(),
            });
        }
        Ok(())
    }

    /// This chain with one more step.
    pub fn with(&self, key: Key, trigger: Trigger, object: &Arc<str>, attr: &Arc<str>) -> Chain {
        let mut steps = self.steps.clone();
        steps.push((key, trigger, object.clone(), attr.clone()));
        Chain { steps }
    }
}
