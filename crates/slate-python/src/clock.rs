//! `Clock`: the board's hybrid logical clock, system or manual.

use std::time::Duration;

use pyo3::prelude::*;
use slate_model::{Clock, ClockError};

use crate::errors::{self, Kind};

/// A board's clock: the system clock, or a manual clock that only moves when told to.
///
/// A manual clock starts at 2026-01-01T00:00:00Z. Moving it runs, at once, everything due
/// on it (plan deadlines such as `age(x) > 2s`). Several boards may share one clock:
/// `Board(clock=other_board.clock)`.
#[pyclass(module = "slate", name = "Clock", frozen)]
#[derive(Clone)]
pub(crate) struct PyClock {
    pub(crate) inner: Clock,
}

#[pymethods]
impl PyClock {
    /// A new clock: `"system"` (default) or `"manual"`.
    #[new]
    #[pyo3(signature = (kind="system"))]
    fn new(py: Python<'_>, kind: &str) -> PyResult<Self> {
        Ok(PyClock {
            inner: clock_of_kind(py, kind)?,
        })
    }

    /// Is this a manual clock?
    #[getter]
    fn is_manual(&self) -> bool {
        self.inner.is_manual()
    }

    /// Current time, in seconds since the Unix epoch.
    fn now(&self) -> f64 {
        self.inner.physical().as_secs_f64()
    }

    /// Moves a manual clock forward by `seconds`, then runs what became due (plan
    /// deadlines), in this thread. Raises `ClockError` on a system clock.
    fn advance(&self, py: Python<'_>, seconds: f64) -> PyResult<()> {
        let refusal =
            || format!("cannot advance the clock by {seconds} s: time only moves forward");
        self.move_with(py, seconds, refusal, Clock::advance)
    }

    /// Sets a manual clock to `seconds` since the Unix epoch (never backwards), then runs
    /// what became due.
    fn set(&self, py: Python<'_>, seconds: f64) -> PyResult<()> {
        let refusal =
            || format!("cannot set the clock to {seconds}: not a time since the Unix epoch");
        self.move_with(py, seconds, refusal, Clock::set)
    }

    fn __repr__(&self) -> String {
        let kind = if self.inner.is_manual() {
            "manual"
        } else {
            "system"
        };
        format!("Clock('{kind}', now={:.6})", self.now())
    }
}

impl PyClock {
    /// Moves the clock with `step` (advance or set) to or by `seconds`, outside the GIL;
    /// `refusal` says why `seconds` is no duration.
    fn move_with(
        &self,
        py: Python<'_>,
        seconds: f64,
        refusal: impl FnOnce() -> String,
        step: fn(&Clock, Duration) -> Result<(), ClockError>,
    ) -> PyResult<()> {
        let by = Duration::try_from_secs_f64(seconds)
            .map_err(|_| errors::new(py, Kind::Clock, refusal()))?;
        let clock = self.inner.clone();
        py.detach(move || step(&clock, by))
            .map_err(|e| errors::clock(py, e))
    }
}

/// A clock from its name.
pub(crate) fn clock_of_kind(py: Python<'_>, kind: &str) -> PyResult<Clock> {
    match kind {
        "system" => Ok(Clock::system()),
        "manual" => Ok(Clock::manual()),
        other => Err(errors::new(
            py,
            Kind::Clock,
            format!("unknown clock {other:?}: use \"system\" or \"manual\""),
        )),
    }
}
