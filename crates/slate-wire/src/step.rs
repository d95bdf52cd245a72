//! What a plan step says about itself: its text, its kind, whether it ends the circuit and
//! the state it leaves the plan in. Every reader of acknowledgements (the dashboards, the
//! CLI, the Python binding) takes these from here, so one step reads the same everywhere.

use std::fmt;

use crate::PlanStep;

impl PlanStep {
    /// The step's kind as one word: `received`, `accepted`, `rejected`, `initiated`,
    /// `triggered` (whether or not the action succeeded), `terminated`, `cancelled`,
    /// `destination_lost`.
    pub fn kind(&self) -> &'static str {
        match self {
            PlanStep::Received => "received",
            PlanStep::Accepted => "accepted",
            PlanStep::Rejected { .. } => "rejected",
            PlanStep::Initiated => "initiated",
            PlanStep::Triggered { .. } => "triggered",
            PlanStep::Terminated => "terminated",
            PlanStep::Cancelled => "cancelled",
            PlanStep::DestinationLost => "destination_lost",
        }
    }

    /// What the step carries: why a plan was rejected, what its action did or why it
    /// failed; empty for the other steps.
    pub fn detail(&self) -> &str {
        match self {
            PlanStep::Rejected { reason } => reason,
            PlanStep::Triggered { detail, .. } => detail,
            _ => "",
        }
    }

    /// False for a rejection, a failed action and a lost destination: the steps the
    /// origin must act on.
    pub fn is_ok(&self) -> bool {
        match self {
            PlanStep::Rejected { .. } | PlanStep::DestinationLost => false,
            PlanStep::Triggered { ok, .. } => *ok,
            _ => true,
        }
    }

    /// Does this step end the plan's progress as its origin shows it? After a rejection,
    /// termination or cancellation nothing follows; after a lost destination nothing
    /// follows unless the destination comes back (its circuit stays open for that).
    pub fn is_final(&self) -> bool {
        matches!(
            self,
            PlanStep::Rejected { .. }
                | PlanStep::Terminated
                | PlanStep::Cancelled
                | PlanStep::DestinationLost
        )
    }

    /// Does this step close the circuit? The final steps but a lost destination, which
    /// may come back (its circuit stays open, sends the plan again, and the steps
    /// resume): whoever follows a circuit waits on after `DestinationLost`.
    pub fn closes_circuit(&self) -> bool {
        self.is_final() && *self != PlanStep::DestinationLost
    }

    /// The state a plan is in, as its origin sees it, once this is its latest step:
    /// `pending`, `rejected`, `active`, `triggered`, `failed`, `terminated`, `cancelled`,
    /// `lost` (the dashboard colours plans by these).
    pub fn plan_state(&self) -> &'static str {
        match self {
            PlanStep::Received | PlanStep::Accepted => "pending",
            PlanStep::Rejected { .. } => "rejected",
            PlanStep::Initiated => "active",
            PlanStep::Triggered { ok: true, .. } => "triggered",
            PlanStep::Triggered { ok: false, .. } => "failed",
            PlanStep::Terminated => "terminated",
            PlanStep::Cancelled => "cancelled",
            PlanStep::DestinationLost => "lost",
        }
    }
}

/// A few words: `received`, `accepted`, `rejected: why`, `initiated`, `triggered ok`,
/// `triggered ok: what`, `triggered failed: why`, `terminated`, `cancelled`,
/// `destination lost`.
impl fmt::Display for PlanStep {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PlanStep::Rejected { reason } => write!(f, "rejected: {reason}"),
            PlanStep::Triggered { ok: true, detail } if detail.is_empty() => {
                f.write_str("triggered ok")
            }
            PlanStep::Triggered { ok: true, detail } => write!(f, "triggered ok: {detail}"),
            PlanStep::Triggered { ok: false, detail } => write!(f, "triggered failed: {detail}"),
            PlanStep::DestinationLost => f.write_str("destination lost"),
            other => f.write_str(other.kind()),
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Every kind of step, with and without details; the codec's tests use it too.
    pub(crate) fn every_step() -> Vec<PlanStep> {
        vec![
            PlanStep::Received,
            PlanStep::Accepted,
            PlanStep::Rejected {
                reason: "no such class".into(),
            },
            PlanStep::Initiated,
            PlanStep::Triggered {
                ok: true,
                detail: String::new(),
            },
            PlanStep::Triggered {
                ok: true,
                detail: "fired 2".into(),
            },
            PlanStep::Triggered {
                ok: false,
                detail: "no such object".into(),
            },
            PlanStep::Terminated,
            PlanStep::Cancelled,
            PlanStep::DestinationLost,
        ]
    }

    #[test]
    fn every_step_reads_as_a_few_words() {
        let texts: Vec<String> = every_step().iter().map(ToString::to_string).collect();
        assert_eq!(
            texts,
            [
                "received",
                "accepted",
                "rejected: no such class",
                "initiated",
                "triggered ok",
                "triggered ok: fired 2",
                "triggered failed: no such object",
                "terminated",
                "cancelled",
                "destination lost",
            ]
        );
    }

    #[test]
    fn a_failed_action_reads_failed_and_is_not_ok() {
        let failed = PlanStep::Triggered {
            ok: false,
            detail: "why".into(),
        };
        assert_eq!(failed.plan_state(), "failed");
        assert_eq!(
            (failed.kind(), failed.detail(), failed.is_ok()),
            ("triggered", "why", false)
        );
    }

    #[test]
    fn only_rejection_termination_cancellation_and_loss_end_a_circuit() {
        let finals: Vec<&str> = every_step()
            .iter()
            .filter(|s| s.is_final())
            .map(PlanStep::kind)
            .collect();
        assert_eq!(
            finals,
            ["rejected", "terminated", "cancelled", "destination_lost"]
        );
    }

    #[test]
    fn a_lost_destination_ends_a_step_sequence_but_not_its_circuit() {
        let closing: Vec<&str> = every_step()
            .iter()
            .filter(|s| s.closes_circuit())
            .map(PlanStep::kind)
            .collect();
        assert_eq!(closing, ["rejected", "terminated", "cancelled"]);
    }
}
