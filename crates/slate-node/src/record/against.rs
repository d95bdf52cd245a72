//! A plan tested against a recording (`slate plan test PLAN.slate --against FILE.mcap`):
//! the recording replayed into a board of its own, on a manual clock, with the plan
//! installed on a plan engine and no network; what the plan would have done (initiated,
//! triggered with what its action wrote and would have sent, terminated), beside what
//! the plans of that name did in the recorded run.

use std::collections::{BTreeSet, HashMap};
use std::sync::Arc;
use std::time::Duration;

use crossbeam_channel::Receiver;
use serde_json::{Value as Json, json};
use slate_model::{Address, Board, ChangeItem, Clock, Filter, Watch};
use slate_plans::{Engine, Item, Outgoing, PlanEvent};

use super::replay::{Recording, Step, Timed};
use super::{message, topic};

/// The board's address when the file does not say whose it was.
const UNKNOWN: &str = "replay/plan/test";

/// Why a plan cannot be tested against a recording.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum AgainstError {
    /// The file holds no plan.
    #[error("{0}: no `plan NAME {{ ... }}` to test")]
    NoPlan(String),
    /// The file does not parse.
    #[error("{0}")]
    Parse(String),
    /// A file given to load first (`with`) did not load on the empty board.
    #[error("{0}")]
    With(String),
    /// The plan never checked against the recorded board (an unknown class, object or
    /// attribute): the last diagnostics.
    #[error("the plan does not load on the recorded board:\n{0}")]
    Load(String),
}

/// One thing a plan did, or would have done: when (since the recording's first
/// message), the event as the `/slate/plans` channel writes it (`event`, `plan`,
/// `fired`, `error`), and for a trigger what its action wrote and would have sent.
#[derive(Clone, Debug, PartialEq)]
pub struct Firing {
    /// Since the recording's first message.
    pub at: Duration,
    /// `{"event": ..., "plan": ..., "fired": ..., "error": ...}`.
    pub event: Json,
    /// `{"object", "attr", "value"}` of each packet the action wrote.
    pub wrote: Vec<Json>,
    /// What the action would have sent: plans (`plan NAME to ADDRESS`) and reports.
    pub sent: Vec<String>,
}

impl Firing {
    /// The firing as one JSON object: `at` in seconds, the event's fields, `wrote` and
    /// `sent` when not empty.
    pub fn to_json(&self) -> Json {
        let mut j = self.event.clone();
        j["at"] = json!(self.at.as_secs_f64());
        if !self.wrote.is_empty() {
            j["wrote"] = json!(self.wrote);
        }
        if !self.sent.is_empty() {
            j["sent"] = json!(self.sent);
        }
        j
    }

    /// The event's name (`initiated`, `triggered`...).
    pub fn name(&self) -> &str {
        self.event["event"].as_str().unwrap_or("")
    }
}

/// What a test found.
#[derive(Clone, Debug, Default)]
pub struct PlanTest {
    /// The plans tested, by name.
    pub plans: Vec<String>,
    /// When the plans were installed (since the recording's first message): once the
    /// file's initial state was replayed and the plans checked against it.
    pub installed_at: Option<Duration>,
    /// What they would have done, in order.
    pub predicted: Vec<Firing>,
    /// What the plans of the same names did in the recorded run (the recording's
    /// `/slate/plans` messages), in order.
    pub recorded: Vec<Firing>,
    /// Messages replayed (a class channel's message counts each packet it holds).
    pub messages: u64,
    /// Messages the board refused (as `slate play` counts them).
    pub refused: u64,
}

/// Replays `recording` into a board of its own with the plans of `text` (file `label`)
/// installed once its initial state is on the board; nothing is sent anywhere.
///
/// `with` (`(label, text)`) are loaded first, on the empty board: a recording holds
/// packets and class definitions, not the functions behind derived attributes and
/// rules, so plans that read a derived attribute need the file that declares it.
pub fn test_plans(
    recording: &Recording,
    with: &[(String, String)],
    label: &str,
    text: &str,
) -> Result<PlanTest, AgainstError> {
    let plans = plan_names(label, text)?;
    let live = first_live(&recording.steps);
    let start = origin(&recording.steps, live);
    let mut run = Run::new(recording, plans, start)?;
    for (label, text) in with {
        run.engine
            .load(label, text)
            .map_err(|e| AgainstError::With(e.rendered))?;
    }
    let mut last_error = None;
    for (i, timed) in recording.steps.iter().enumerate() {
        if run.test.installed_at.is_none() && i >= live {
            last_error = run.install(label, text, run.since(start)).err();
        }
        run.step(timed, start);
    }
    if run.test.installed_at.is_none() {
        return Err(AgainstError::Load(last_error.unwrap_or_else(|| {
            "the recording holds nothing after its initial state".into()
        })));
    }
    Ok(run.test)
}

/// The names of the plans a file declares.
fn plan_names(label: &str, text: &str) -> Result<BTreeSet<String>, AgainstError> {
    let file = slate_plans::parse(text).map_err(|d| AgainstError::Parse(d.render(label, text)))?;
    let names: BTreeSet<String> = file
        .items
        .iter()
        .filter_map(|item| match item {
            Item::Plan(p) => Some(p.name.name.clone()),
            _ => None,
        })
        .collect();
    if names.is_empty() {
        return Err(AgainstError::NoPlan(label.to_owned()));
    }
    Ok(names)
}

/// Where the replay's clock starts: the first message's time, or the stamp of the first
/// packet recorded as it happened if that is earlier (a message is logged when the
/// recorder handled it, which can be after the change). The clock then follows the
/// packets' stamps: never ahead of the recorded board's, so a write of the tested plans
/// never wins over a recorded packet that won over the recorded plans' write.
fn origin(steps: &[Timed], live: usize) -> Duration {
    let first = steps.first().map_or(Duration::ZERO, |t| t.time);
    let stamp = steps[live.min(steps.len())..]
        .iter()
        .find_map(|t| match &t.step {
            Step::Packet { packet, .. } => Some(packet.timestamp.physical()),
            _ => None,
        });
    stamp.map_or(first, |s| s.min(first))
}

/// The first message after the file's initial state: the plans are installed before it,
/// so that they first see the board as it was, not half of it. A file begins with the
/// classes (and their class-level packets), then each object there (`exists`) followed
/// by its packets; the first message of any other kind, or a packet of another object,
/// is a change recorded as it happened.
fn first_live(steps: &[Timed]) -> usize {
    let mut classes = BTreeSet::new();
    let mut last: Option<&str> = None;
    steps
        .iter()
        .position(|t| match &t.step {
            Step::Class(def) => {
                classes.insert(def.name.as_str());
                false
            }
            Step::Exists(spec) => {
                last = Some(&spec.name);
                false
            }
            Step::Packet { object, .. } => {
                last != Some(object.as_str()) && !classes.contains(object.as_str())
            }
            _ => true,
        })
        .unwrap_or(steps.len())
}

/// The board, its engine, and what they have told so far.
struct Run {
    board: Arc<Board>,
    clock: Clock,
    engine: Engine,
    events: Receiver<PlanEvent>,
    outgoing: Receiver<Outgoing>,
    watch: Watch,
    test: PlanTest,
}

impl Run {
    fn new(
        recording: &Recording,
        plans: BTreeSet<String>,
        start: Duration,
    ) -> Result<Run, AgainstError> {
        let address = recording
            .address
            .as_deref()
            .and_then(|a| Address::new(a).ok())
            .unwrap_or_else(|| Address::new(UNKNOWN).expect("a valid address"));
        let clock = Clock::manual();
        let _ = clock.set(start.max(clock.physical()));
        let board = Arc::new(
            Board::builder()
                .address(address)
                .clock(clock.clone())
                .build(),
        );
        let engine = Engine::new(&board);
        let watch = board
            .watch(Filter::all())
            .map_err(|e| AgainstError::Load(e.to_string()))?;
        Ok(Run {
            events: engine.events(),
            outgoing: engine.outgoing(),
            watch,
            board,
            clock,
            engine,
            test: PlanTest {
                plans: plans.into_iter().collect(),
                ..PlanTest::default()
            },
        })
    }

    /// Loads the plans: an error (the diagnostics) while the board lacks what they name.
    fn install(&mut self, label: &str, text: &str, at: Duration) -> Result<(), String> {
        self.engine.load(label, text).map_err(|e| e.rendered)?;
        self.test.installed_at = Some(at);
        self.collect(at);
        Ok(())
    }

    /// The clock's time since `start`.
    fn since(&self, start: Duration) -> Duration {
        self.clock.physical().saturating_sub(start)
    }

    /// Applies one message (the tested plans' own recorded objects are left out: the
    /// engine writes them) and collects what the plans did.
    ///
    /// The clock follows the packets' stamps, not the messages' log times: a message is
    /// logged when the recorder handled it, which can be well after the change, and a
    /// clock ahead of the recorded packets would let the plans' own writes win over the
    /// recorded ones that came after them.
    fn step(&mut self, timed: &Timed, start: Duration) {
        if let Step::Packet { packet, .. } = &timed.step {
            let _ = self
                .clock
                .set(packet.timestamp.physical().max(self.clock.physical()));
        }
        let at = self.since(start);
        if let Some(firing) = self.recorded(&timed.step, timed.time.saturating_sub(start)) {
            self.test.recorded.push(firing);
        }
        if self.tested_object(&timed.step) {
            self.already_active(&timed.step, at);
            return;
        }
        self.test.messages += 1;
        if !Recording::apply(&self.board, &timed.step) {
            self.test.refused += 1;
        }
        self.collect(at);
    }

    /// A tested plan already active when the recording began (its `Plan` object's
    /// `state` in the file's initial state) was initiated before it: that is told as a
    /// recorded `initiated` with `before_recording`.
    fn already_active(&mut self, step: &Step, at: Duration) {
        let Step::Packet {
            object,
            attr,
            value,
            ..
        } = step
        else {
            return;
        };
        let first = !self
            .test
            .recorded
            .iter()
            .any(|f| f.event["plan"] == **object);
        if attr == "state" && value == "active" && first && self.test.installed_at.is_none() {
            self.test.recorded.push(Firing {
                at,
                event: json!({"event": "initiated", "plan": object, "before_recording": true}),
                wrote: Vec::new(),
                sent: Vec::new(),
            });
        }
    }

    /// A recorded plan event of one of the tested plans.
    fn recorded(&self, step: &Step, at: Duration) -> Option<Firing> {
        let Step::Other { topic, json } = step else {
            return None;
        };
        let plan = json["plan"].as_str()?;
        (topic == topic::PLANS && self.is_tested(plan)).then(|| Firing {
            at,
            event: json.clone(),
            wrote: Vec::new(),
            sent: Vec::new(),
        })
    }

    fn is_tested(&self, name: &str) -> bool {
        self.test.plans.iter().any(|p| p == name)
    }

    /// Is this message about a tested plan's own `Plan` object?
    fn tested_object(&self, step: &Step) -> bool {
        match step {
            Step::Create(spec) | Step::Exists(spec) => self.is_tested(&spec.name),
            Step::Delete(name) | Step::Packet { object: name, .. } => self.is_tested(name),
            _ => false,
        }
    }

    /// The engine's events since the last look, each trigger with what its action wrote
    /// and would have sent.
    fn collect(&mut self, at: Duration) {
        let mut wrote = self.action_writes();
        let mut sent = self.would_send();
        while let Ok(e) = self.events.try_recv() {
            let event = message::plan_event(&e);
            let plan = event["plan"].as_str().unwrap_or("").to_owned();
            let triggered = matches!(e, PlanEvent::Triggered { .. });
            self.test.predicted.push(Firing {
                at,
                event,
                wrote: if triggered { wrote.remove(&plan) } else { None }.unwrap_or_default(),
                sent: if triggered { sent.remove(&plan) } else { None }.unwrap_or_default(),
            });
        }
    }

    /// The packets each plan's action wrote: a committed action writes its plan's
    /// `fired` in the same change as its own writes.
    fn action_writes(&self) -> HashMap<String, Vec<Json>> {
        let mut by_plan: HashMap<String, Vec<Json>> = HashMap::new();
        while let Some(change) = self.watch.try_recv() {
            let Some(plan) = change.items.iter().find_map(|item| match item {
                ChangeItem::Write { object, attr, .. } if &**attr == "fired" => {
                    self.is_tested(object).then(|| object.to_string())
                }
                _ => None,
            }) else {
                continue;
            };
            let writes = change.items.iter().filter_map(|item| match item {
                ChangeItem::Write {
                    object,
                    attr,
                    packet,
                } if !self.is_tested(object) => Some(json!({
                    "object": &**object, "attr": &**attr, "value": message::value(&packet.value),
                })),
                _ => None,
            });
            by_plan.entry(plan).or_default().extend(writes);
        }
        by_plan
    }

    /// What the actions handed the network (which there is none of), by plan.
    fn would_send(&self) -> HashMap<String, Vec<String>> {
        let mut by_plan: HashMap<String, Vec<String>> = HashMap::new();
        while let Ok(out) = self.outgoing.try_recv() {
            let (origin, what) = match out {
                Outgoing::Plan(p) => (p.origin, format!("plan {} to {}", p.name, p.to)),
                Outgoing::Report(r) => {
                    let to =
                        r.to.map_or_else(|| "every interested module".into(), |a| a.to_string());
                    (
                        r.origin,
                        format!("report of {} packets to {to}", r.items.len()),
                    )
                }
            };
            by_plan.entry(origin).or_default().push(what);
        }
        by_plan
    }
}
