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
/// board is gone (checked between slices). An item already waiting (`waiting`) is taken
/// without letting go of the GIL: a reader behind its subscription takes each in one
/// call, not a release and a re-acquisition of the GIL (and clock reads) per item.
pub(crate) fn next<T: Send>(
    py: Python<'_>,
    timeout: Option<Duration>,
    alive: &dyn Fn() -> bool,
    waiting: impl FnOnce() -> Option<T>,
    mut recv: impl FnMut(Duration) -> Result<T, RecvTimeoutError> + Send,
) -> PyResult<Option<T>> {
    if let Some(item) = waiting() {
        return Ok(Some(item));
    }
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
    next(
        py,
        timeout,
        alive,
        || rx.try_recv().ok(),
        |slice| rx.recv_timeout(slice),
    )
}

/// The Python methods every subscription class shares (`Events`, `Watch`, `Outbox`):
/// `get`, `drain`, `close`, iteration (each step waits for the next item, with the
/// class's own timeout) and the context-manager protocol (leaving closes). The class
/// provides `next_item(py, timeout)`, `waiting(py)`, `unsubscribe()` and a `timeout`
/// field; `{ ... }` adds the class's own methods to the same `#[pymethods]` block.
macro_rules! subscription_methods {
    ($class:ty, $item:ty, { $($own:tt)* }) => {
        #[pyo3::pymethods]
        impl $class {
            /// The next item, waiting at most `timeout` seconds (`None`: the
            /// subscription's own timeout); `None` if nothing came.
            #[pyo3(signature = (timeout=None))]
            fn get(&self, py: Python<'_>, timeout: Option<f64>) -> PyResult<Option<$item>> {
                let timeout = $crate::stream::timeout(timeout)?.or(self.timeout);
                self.next_item(py, timeout)
            }

            /// Items already waiting, without blocking.
            fn drain(&self, py: Python<'_>) -> PyResult<Vec<$item>> {
                self.waiting(py)
            }

            /// Unsubscribes; iteration ends.
            fn close(&self) {
                self.unsubscribe();
            }

            fn __iter__(slf: Py<Self>) -> Py<Self> {
                slf
            }

            fn __next__(&self, py: Python<'_>) -> PyResult<Option<$item>> {
                self.next_item(py, self.timeout)
            }

            fn __enter__(slf: Py<Self>) -> Py<Self> {
                slf
            }

            #[pyo3(signature = (exc_type=None, exc_value=None, traceback=None))]
            fn __exit__(
                &self,
                exc_type: Option<&Bound<'_, PyAny>>,
                exc_value: Option<&Bound<'_, PyAny>>,
                traceback: Option<&Bound<'_, PyAny>>,
            ) -> bool {
                let _ = (exc_type, exc_value, traceback);
                self.unsubscribe();
                false
            }

            $($own)*
        }
    };
}
pub(crate) use subscription_methods;
