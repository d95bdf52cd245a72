//! Waiting for the next item of a subscription (changes, events, outgoing messages) with the
//! GIL released, in slices, so that Ctrl-C still interrupts a long wait.

use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, RecvTimeoutError};
use pyo3::prelude::*;

/// Longest wait between two checks for signals (Ctrl-C) and for the board being gone.
const SLICE: Duration = Duration::from_millis(100);

/// A timeout in seconds from Python: `None` waits for ever.
pub(crate) fn timeout(seconds: Option<f64>) -> PyResult<Option<Duration>> {
    seconds
        .map(|s| {
            Duration::try_from_secs_f64(s.max(0.0)).map_err(|_| {
                pyo3::exceptions::PyValueError::new_err(format!(
                    "timeout {s} is not a number of seconds"
                ))
            })
        })
        .transpose()
}

/// Waits for the next item: `None` on timeout, or once `alive` says the subscription or its
/// board is gone (checked between slices).
pub(crate) fn next<T: Send>(
    py: Python<'_>,
    timeout: Option<Duration>,
    alive: &dyn Fn() -> bool,
    mut recv: impl FnMut(Duration) -> Result<T, RecvTimeoutError> + Send,
) -> PyResult<Option<T>> {
    let deadline = timeout.map(|t| Instant::now() + t);
    loop {
        let slice = deadline.map_or(SLICE, |d| {
            d.saturating_duration_since(Instant::now()).min(SLICE)
        });
        match py.detach(|| recv(slice)) {
            Ok(item) => return Ok(Some(item)),
            Err(RecvTimeoutError::Disconnected) => return Ok(None),
            Err(RecvTimeoutError::Timeout) => {}
        }
        py.check_signals()?;
        if deadline.is_some_and(|d| Instant::now() >= d) || !alive() {
            return Ok(None);
        }
    }
}

/// [`next`] over a channel.
pub(crate) fn next_from<T: Send>(
    py: Python<'_>,
    rx: &Receiver<T>,
    timeout: Option<Duration>,
    alive: &dyn Fn() -> bool,
) -> PyResult<Option<T>> {
    next(py, timeout, alive, |slice| rx.recv_timeout(slice))
}
