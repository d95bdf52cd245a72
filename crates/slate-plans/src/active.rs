//! Declarative active functions: derived attributes (computed on read) and `on write`
//! rules, compiled from the language and run by the board like native ones.

use std::sync::Weak;
use std::time::Duration;

use slate_model::{ActiveFn, Call, FnError, Timestamp, Value};

use crate::action::{Act, Effect, effects};
use crate::engine::{Shared, report_items};
use crate::env::CallEnv;
use crate::eval::{CompiledExpr, Ctx};
use crate::outbox::{Outgoing, PlanMessage, ReportRequest};

/// `attr: T derived = value [accuracy a] [confidence c]`.
pub(crate) struct Derived {
    pub name: String,
    pub value: CompiledExpr,
    pub accuracy: Option<CompiledExpr>,
    pub confidence: Option<CompiledExpr>,
    pub slots: usize,
    pub real: bool,
}

impl ActiveFn for Derived {
    fn name(&self) -> &str {
        &self.name
    }

    fn call(&self, call: &mut Call<'_>) -> Result<(), FnError> {
        let (value, accuracy, confidence, newest) = {
            let env = CallEnv { call };
            let mut cx = Ctx::new(&env, self.slots, &[]);
            cx.this = Some(call.object().into());
            let fail = |e: crate::eval::EvalError| FnError::Message(e.to_string());
            let value = self.value.eval(&mut cx).map_err(fail)?;
            let accuracy = self
                .accuracy
                .as_ref()
                .map(|n| n.eval(&mut cx))
                .transpose()
                .map_err(fail)?;
            let confidence = self
                .confidence
                .as_ref()
                .map(|n| n.eval(&mut cx))
                .transpose()
                .map_err(fail)?;
            (value, accuracy, confidence, cx.newest)
        };
        let mut p = call.packet().clone();
        p.value = match value {
            Value::Int(i) if self.real => Value::Real(i as f64),
            v => v,
        };
        if let Some(a) = accuracy.and_then(|v| v.as_f64()) {
            p.accuracy = a.max(0.0);
        }
        if let Some(c) = confidence.and_then(|v| v.as_f64()) {
            p.confidence = c.clamp(0.0, 1.0);
        }
        if newest > 0.0 {
            p.timestamp = Timestamp::from_duration(Duration::from_secs_f64(newest));
        }
        call.set_packet(p);
        Ok(())
    }

    /// An expression reads the board through the call and the clock through
    /// [`Call::now`], and does nothing else: the board keeps what it computes until what
    /// it read changes.
    fn pure(&self) -> bool {
        true
    }
}

/// `on write ATTR { actions }`.
pub(crate) struct Rule {
    pub name: String,
    pub acts: Vec<Act>,
    pub slots: usize,
    pub engine: Weak<Shared>,
}

impl ActiveFn for Rule {
    fn name(&self) -> &str {
        &self.name
    }

    fn call(&self, call: &mut Call<'_>) -> Result<(), FnError> {
        let planned = {
            let env = CallEnv { call };
            let mut cx = Ctx::new(&env, self.slots, &[]);
            cx.this = Some(call.object().into());
            effects(&self.acts, &mut cx).map_err(|e| FnError::Message(e.to_string()))?
        };
        for e in &planned {
            if let Effect::Write(o, a, u, _) = e {
                call.write(o, a, u.clone())?;
            }
        }
        self.send(&planned);
        Ok(())
    }
}

impl Rule {
    fn send(&self, planned: &[Effect]) {
        let Some(engine) = self.engine.upgrade() else {
            return;
        };
        let Some(board) = engine.board() else { return };
        for e in planned {
            match e {
                Effect::Report { targets, to } => {
                    let items = report_items(&board, targets);
                    engine.outbox.send(Outgoing::Report(ReportRequest {
                        origin: self.name.clone(),
                        to: to.clone(),
                        items,
                    }));
                }
                Effect::Send { name, text, to } => {
                    if let Some(text) = text.clone().or_else(|| engine.plan_text(name)) {
                        let msg = PlanMessage {
                            origin: self.name.clone(),
                            name: name.clone(),
                            text,
                            to: to.clone(),
                        };
                        engine.outbox.send(Outgoing::Plan(msg));
                    }
                }
                _ => {}
            }
        }
    }
}
