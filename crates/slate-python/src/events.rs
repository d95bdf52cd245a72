//! `Event`: something a board or its plans report about themselves (not a change of the
//! world model), and `Events`, the iterator that yields them.

use std::sync::{Arc, Weak};
use std::time::Duration;

use crossbeam_channel::Receiver;
use parking_lot::Mutex;
use pyo3::prelude::*;
use slate_model::{Address, Board, BoardEvent};
use slate_plans::PlanEvent;

use crate::packet::quote;
use crate::stream;

/// An event. `kind` says which; the other fields are set where they apply:
///
/// - board events: `"function_failed"` (`function`, `object`, `attr`, `trigger`, `error`:
///   an active function raised or failed; the access that ran it stands; at most one a
///   second per function, with `suppressed`),
///   `"chain_cut"` (`error`: a chain of active functions was too deep or a cycle),
///   `"future_stamp"` (`object`, `attr`, `source`, `error`: a received packet stamped
///   beyond the clock's tolerance was refused), `"class_conflict"` (`object` is the
///   class, `source` the module that defines it differently; their objects are not merged),
///   `"not_owner"` (`object`, `attr`, `source` the writer, `error` naming the owner: a
///   received packet for an `owned` attribute from another module than its owner was
///   refused), `"unauthorised"` (`object`, `attr` unless an object's creation was
///   refused, `source` the writer, `error` naming the rule: this board's `[authority]
///   writes` do not let the writer write it), `"object_limit"` (`object`, `source` its owner), `"name_limit"` (`source`)
///   and `"module_limit"` (`source` the address refused): what arrived was past one of
///   the node's bounds and was refused. The refusals (`future_stamp`, `not_owner`,
///   `unauthorised` and
///   the limits) are told at most once a second per source; `suppressed` says how many
///   more like it came since the last one. `"other"` is a kind this version does not
///   name (`error` describes it);
/// - plan events: `"installed"`, `"initiated"`, `"triggered"` (`fired`, and `error` if the
///   action failed), `"terminated"`, `"cancelled"`, `"failed"` (`error`: a condition could
///   not be evaluated), all with `plan`.
#[pyclass(module = "slate", name = "Event", frozen, get_all)]
#[derive(Clone, Debug, Default)]
pub(crate) struct Event {
    /// What happened.
    kind: &'static str,
    /// The plan, for plan events.
    plan: Option<String>,
    /// The active function, for `function_failed`.
    function: Option<String>,
    /// The object accessed, for `function_failed`.
    object: Option<String>,
    /// The attribute accessed, for `function_failed`.
    attr: Option<String>,
    /// `"read"` or `"write"`, for `function_failed`.
    trigger: Option<String>,
    /// The module concerned, for `future_stamp` and `class_conflict`.
    source: Option<String>,
    /// What went wrong, if something did.
    error: Option<String>,
    /// Times the plan has fired, for `triggered`.
    fired: Option<u64>,
    /// For refusals: how many more like it (same kind, same source) came since the last
    /// such event and were not told one by one.
    suppressed: Option<u64>,
}

#[pymethods]
impl Event {
    fn __repr__(&self) -> String {
        let mut parts = vec![quote(self.kind)];
        let fields = [
            ("plan", &self.plan),
            ("function", &self.function),
            ("object", &self.object),
            ("attr", &self.attr),
            ("trigger", &self.trigger),
            ("source", &self.source),
            ("error", &self.error),
        ];
        for (name, value) in fields {
            if let Some(v) = value {
                parts.push(format!("{name}={}", quote(v)));
            }
        }
        if let Some(n) = self.fired {
            parts.push(format!("fired={n}"));
        }
        if let Some(n) = self.suppressed {
            parts.push(format!("suppressed={n}"));
        }
        format!("Event({})", parts.join(", "))
    }
}

impl From<BoardEvent> for Event {
    fn from(e: BoardEvent) -> Self {
        match e {
            BoardEvent::FunctionFailed {
                function,
                object,
                attr,
                trigger,
                error,
                suppressed,
            } => Event {
                kind: "function_failed",
                function: Some(function),
                object: Some(object),
                attr: Some(attr),
                trigger: Some(trigger.to_string()),
                error: Some(error),
                suppressed: Some(suppressed),
                ..Event::default()
            },
            BoardEvent::ChainCut(cut) => Event {
                kind: "chain_cut",
                error: Some(cut.to_string()),
                ..Event::default()
            },
            BoardEvent::FutureStamp {
                object,
                attr,
                source,
                stamp,
                ahead,
                suppressed,
            } => Event {
                kind: "future_stamp",
                suppressed: Some(suppressed),
                object: Some(object),
                attr: Some(attr),
                error: Some(format!(
                    "packet stamped {stamp}, {:.3} s ahead of this board's clock: refused",
                    ahead.as_secs_f64()
                )),
                source: Some(source.to_string()),
                ..Event::default()
            },
            BoardEvent::ClassConflict { class, peer } => Event {
                error: Some(format!(
                    "class {class} is defined differently by {peer}: its objects are not merged"
                )),
                kind: "class_conflict",
                object: Some(class),
                source: Some(peer.to_string()),
                ..Event::default()
            },
            refusal @ (BoardEvent::NotOwner { .. }
            | BoardEvent::Unauthorised { .. }
            | BoardEvent::ObjectLimit { .. }
            | BoardEvent::NameLimit { .. }
            | BoardEvent::ModuleLimit { .. }) => refused(refusal),
            other => Event {
                kind: "other",
                error: Some(format!("{other:?}")),
                ..Event::default()
            },
        }
    }
}

/// A refusal past a bound or of a non-owner's packet, as an event.
fn refused(e: BoardEvent) -> Event {
    let error = Some(refusal_text(&e));
    match e {
        BoardEvent::NotOwner {
            object,
            attr,
            writer,
            suppressed,
            ..
        } => Event {
            kind: "not_owner",
            object: Some(object),
            attr: Some(attr),
            source: Some(writer.to_string()),
            suppressed: Some(suppressed),
            error,
            ..Event::default()
        },
        BoardEvent::Unauthorised {
            object,
            attr,
            writer,
            suppressed,
            ..
        } => Event {
            kind: "unauthorised",
            object: Some(object),
            attr,
            source: Some(writer.to_string()),
            suppressed: Some(suppressed),
            error,
            ..Event::default()
        },
        BoardEvent::ObjectLimit {
            owner,
            object,
            suppressed,
            ..
        } => Event {
            kind: "object_limit",
            object: Some(object),
            source: Some(owner.to_string()),
            suppressed: Some(suppressed),
            error,
            ..Event::default()
        },
        BoardEvent::NameLimit {
            source, suppressed, ..
        } => limit("name_limit", source, suppressed, error),
        BoardEvent::ModuleLimit {
            address,
            suppressed,
            ..
        } => limit("module_limit", address, suppressed, error),
        other => Event {
            kind: "other",
            error: Some(format!("{other:?}")),
            ..Event::default()
        },
    }
}

/// A limit's event: `kind`, about `source`.
fn limit(kind: &'static str, source: Address, suppressed: u64, error: Option<String>) -> Event {
    Event {
        kind,
        source: Some(source.to_string()),
        suppressed: Some(suppressed),
        error,
        ..Event::default()
    }
}

/// What a refusal says, in a sentence.
fn refusal_text(e: &BoardEvent) -> String {
    match e {
        BoardEvent::NotOwner { owner, .. } => {
            format!("the attribute is owned, and only its owner {owner} may write it: refused")
        }
        BoardEvent::Unauthorised { rule, .. } => {
            format!("{rule} on this board ([authority] writes): refused")
        }
        BoardEvent::ObjectLimit { limit, total, .. } => {
            let whose = if *total {
                "other modules together"
            } else {
                "one module"
            };
            format!(
                "{whose} may own at most {limit} objects on this board: refused (ici.max_objects_per_source, ici.max_objects)"
            )
        }
        BoardEvent::NameLimit { limit, .. } => format!(
            "it would make this board's node hold more than {limit} names of that module: refused (ici.max_names_per_source)"
        ),
        BoardEvent::ModuleLimit { limit, .. } => {
            format!("the node keeps track of at most {limit} modules: refused (ici.max_modules)")
        }
        other => format!("{other:?}"),
    }
}

impl From<PlanEvent> for Event {
    fn from(e: PlanEvent) -> Self {
        let (kind, plan, fired, error) = match e {
            PlanEvent::Installed { plan } => ("installed", plan, None, None),
            PlanEvent::Initiated { plan } => ("initiated", plan, None, None),
            PlanEvent::Triggered { plan, fired, error } => ("triggered", plan, Some(fired), error),
            PlanEvent::Terminated { plan } => ("terminated", plan, None, None),
            PlanEvent::Cancelled { plan } => ("cancelled", plan, None, None),
            PlanEvent::Failed { plan, error } => ("failed", plan, None, Some(error)),
        };
        Event {
            kind,
            plan: Some(plan),
            fired,
            error,
            ..Event::default()
        }
    }
}

/// The two sources of events.
enum Source {
    Board(Receiver<BoardEvent>),
    Plans(Receiver<PlanEvent>),
}

/// A subscription to a board's events (`Board.events`) or its plans' (`Board.plan_events`).
///
/// Iterating waits for the next event (with the GIL released); with a `timeout`, the
/// iteration stops when none comes within it. Events from before the subscription are
/// not seen.
#[pyclass(module = "slate", name = "Events", frozen)]
pub(crate) struct Events {
    source: Mutex<Option<Arc<Source>>>,
    board: Weak<Board>,
    timeout: Option<Duration>,
}

impl Events {
    pub(crate) fn board(rx: Receiver<BoardEvent>, board: &Arc<Board>, t: Option<Duration>) -> Self {
        Events::new(Source::Board(rx), board, t)
    }

    pub(crate) fn plans(rx: Receiver<PlanEvent>, board: &Arc<Board>, t: Option<Duration>) -> Self {
        Events::new(Source::Plans(rx), board, t)
    }

    fn new(source: Source, board: &Arc<Board>, timeout: Option<Duration>) -> Self {
        Events {
            source: Mutex::new(Some(Arc::new(source))),
            board: Arc::downgrade(board),
            timeout,
        }
    }

    fn next_item(&self, py: Python<'_>, timeout: Option<Duration>) -> PyResult<Option<Event>> {
        let Some(source) = self.source.lock().clone() else {
            return Ok(None);
        };
        let alive = || self.source.lock().is_some() && self.board.strong_count() > 0;
        Ok(match source.as_ref() {
            Source::Board(rx) => stream::next_from(py, rx, timeout, &alive)?.map(Event::from),
            Source::Plans(rx) => stream::next_from(py, rx, timeout, &alive)?.map(Event::from),
        })
    }

    /// Events already waiting, without blocking.
    fn waiting(&self, _py: Python<'_>) -> PyResult<Vec<Event>> {
        let Some(source) = self.source.lock().clone() else {
            return Ok(Vec::new());
        };
        Ok(match source.as_ref() {
            Source::Board(rx) => rx.try_iter().map(Event::from).collect(),
            Source::Plans(rx) => rx.try_iter().map(Event::from).collect(),
        })
    }

    fn unsubscribe(&self) {
        self.source.lock().take();
    }
}

stream::subscription_methods!(Events, Event, {});
