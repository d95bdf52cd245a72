//! The summary of a run: what was found and by whom, the fault and its recovery, what the
//! links carried against their budget, how consistent the boards stayed. As text for
//! people, as one JSON object for scripts.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use serde_json::{Value, json};

/// One target at the end of the run.
#[derive(Clone, Debug, PartialEq)]
pub struct TargetOutcome {
    /// Its name.
    pub name: String,
    /// Who found it (empty: nobody).
    pub found_by: String,
    /// When, seconds into the run.
    pub found_at: Option<f64>,
    /// Who investigated it (came within inspection range while holding its claim).
    pub investigators: Vec<String>,
}

/// The team link's air, as the simulator measured it.
#[derive(Clone, Debug, PartialEq)]
pub struct TeamChannel {
    /// `radio` or `acoustic`.
    pub medium: String,
    /// The fraction of the run the one shared channel was on the air (`None` for
    /// radios: each has its own).
    pub utilisation: Option<f64>,
    /// Frames put on the air (a radio sends a message as one frame).
    pub frames_sent: u64,
    /// Frames lost (per receiver for a broadcast, per attempt for a reliable send).
    pub frames_lost: u64,
    /// The largest frame on the air, bytes.
    pub largest_frame_bytes: usize,
    /// The largest message on the air, bytes.
    pub largest_message_bytes: usize,
    /// The longest a message waited for its transmitter (the shared channel, for the
    /// acoustic medium), seconds.
    pub max_queued_seconds: f64,
    /// Messages their senders dropped because they would have waited longer than the
    /// link's transmit queue allows.
    pub dropped_msgs: u64,
}

/// Everything a run measured.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Summary {
    /// The seed.
    pub seed: u64,
    /// Robots in the team.
    pub robots: usize,
    /// `sim` or `zenoh`.
    pub network: String,
    /// World time the mission ran, seconds.
    pub mission_seconds: f64,
    /// Wall-clock time the whole run took, seconds.
    pub wall_seconds: f64,
    /// Did the console declare the mission complete with every target found?
    pub mission_complete: bool,
    /// The console's last mission phase.
    pub mission_phase: String,
    /// Targets in the world.
    pub targets_total: usize,
    /// Targets found (on the console's board).
    pub targets_found: usize,
    /// Per target.
    pub targets: Vec<TargetOutcome>,
    /// Targets investigated by two robots while both were alive.
    pub duplicate_investigations: usize,
    /// Robots that died.
    pub robot_failures: usize,
    /// Which robot died, when.
    pub fault: Option<(String, f64)>,
    /// Seconds from the death to every survivor holding it dead.
    pub detection_seconds: Option<f64>,
    /// Seconds from the death to none of its unfinished work being left with it.
    pub recovery_seconds: Option<f64>,
    /// What was taken over.
    pub taken_over: Vec<String>,
    /// Bytes on the team link (all radios).
    pub team_link_bytes: u64,
    /// Bytes on the robots' own links.
    pub intra_robot_bytes: u64,
    /// Declared capacity of one radio, bit/s.
    pub team_link_budget_bps: u64,
    /// Highest one-second air rate of one radio (a robot's modules share one; the
    /// console has its own): at most the budget.
    pub team_link_peak_bps: f64,
    /// Highest one-second bit rate offered to one radio (bursts queue).
    pub team_link_offered_peak_bps: f64,
    /// Longest a message waited for a radio, seconds.
    pub team_link_max_backlog_seconds: f64,
    /// Whose radio that was.
    pub team_link_peak_radio: String,
    /// Highest one-second air rate of all radios together.
    pub team_channel_peak_bps: f64,
    /// Mean bit rate of the team link (all radios together).
    pub team_link_mean_bps: f64,
    /// Team-link bytes per message kind (as the ICIs sent them).
    pub team_bytes_by_kind: BTreeMap<String, u64>,
    /// Robot-link bytes per message kind.
    pub intra_bytes_by_kind: BTreeMap<String, u64>,
    /// Seconds the team-view boards took to agree after the last change (`None`: they
    /// did not within the limit).
    pub consistency_lag_seconds: Option<f64>,
    /// Changes (differences between the team-view boards) seen during the run.
    pub propagation_changes: usize,
    /// Median seconds a change took to reach every team-view board.
    pub propagation_median_seconds: Option<f64>,
    /// 95th percentile of the same.
    pub propagation_p95_seconds: Option<f64>,
    /// Longest.
    pub propagation_max_seconds: Option<f64>,
    /// The disagreement left, if they did not agree.
    pub disagreement: Option<String>,
    /// Plans sent on circuits, accepted, rejected.
    pub plans_sent: usize,
    /// Accepted.
    pub plans_accepted: usize,
    /// Rejected.
    pub plans_rejected: usize,
    /// Events logged.
    pub events: usize,
    /// The team link's air on the simulator (`None` on Zenoh).
    pub team_channel: Option<TeamChannel>,
    /// The deck phase before launch, seconds (`None`: none). With one, the mission's
    /// time, rates, peaks and backlogs count from launch; its bytes count in
    /// [`Self::team_link_bytes`] too.
    pub deck_seconds: Option<f64>,
    /// Team-link bytes on deck, before launch (0 without a deck phase).
    pub deck_bytes: u64,
    /// Team-link bytes on deck per message kind, as the ICIs sent them (part of
    /// [`Self::team_bytes_by_kind`]; empty without a deck phase).
    pub deck_bytes_by_kind: BTreeMap<String, u64>,
    /// Team-link bytes of the team protocol's repairs (`TeamRepair`), as the ICIs sent
    /// them: already in [`Self::team_bytes_by_kind`], the replayed messages under their
    /// kinds (repairs of reports are report bytes, docs/team-protocol.md 2.10), told
    /// apart here so that the choice is visible. 0 without the team protocol.
    pub team_repair_bytes: u64,
    /// The longest a module's message waited in its gateway's queue for the radio (the
    /// team protocol paces itself, so a backlog waits there rather than in the radio:
    /// it has not vanished). 0 without the team protocol; `None` with module processes,
    /// whose stats answers do not carry it.
    pub team_queue_max_seconds: Option<f64>,
    /// With `--record` or `--final-board`: the recorder's counters (`messages`, `bytes`,
    /// `dropped`, `files`, `by_topic`), `final_board`, and `failed` if either failed.
    pub recording: Option<Value>,
}

impl Summary {
    /// Team-link bytes as a fraction of intra-robot bytes.
    pub fn team_fraction(&self) -> f64 {
        if self.intra_robot_bytes == 0 {
            0.0
        } else {
            self.team_link_bytes as f64 / self.intra_robot_bytes as f64
        }
    }

    /// Team-link report bytes (the world model itself, without the protocol's overhead)
    /// as a fraction of intra-robot report bytes.
    pub fn team_report_fraction(&self) -> f64 {
        let team = self.team_bytes_by_kind.get("report").copied().unwrap_or(0);
        let intra = self.intra_bytes_by_kind.get("report").copied().unwrap_or(0);
        if intra == 0 {
            0.0
        } else {
            team as f64 / intra as f64
        }
    }

    /// Team-link bytes that are protocol overhead (neither reports, plans nor plan
    /// acks: greetings, heartbeats, object lists, catch-up, lifecycle) over all team-link
    /// bytes, both as the ICIs sent them (so the two sides count the same thing).
    pub fn team_overhead_fraction(&self) -> f64 {
        let all: u64 = self.team_bytes_by_kind.values().sum();
        let model: u64 = MODEL_KINDS
            .iter()
            .filter_map(|k| self.team_bytes_by_kind.get(*k))
            .sum();
        if all == 0 {
            0.0
        } else {
            all.saturating_sub(model) as f64 / all as f64
        }
    }

    /// Team-link bytes (on the air, retransmissions included, the deck's too) per robot
    /// per minute of mission from launch: the load each robot adds to the team link.
    pub fn team_bytes_per_robot_minute(&self) -> f64 {
        let minutes = self.mission_seconds / 60.0;
        if self.robots == 0 || minutes <= 0.0 {
            0.0
        } else {
            self.team_link_bytes as f64 / self.robots as f64 / minutes
        }
    }

    /// The summary as one JSON object.
    pub fn to_json(&self) -> Value {
        let targets: Vec<Value> = self
            .targets
            .iter()
            .map(|t| json!({"name": t.name, "found_by": t.found_by, "found_at": t.found_at, "investigators": t.investigators}))
            .collect();
        let mut summary = json!({
            "seed": self.seed,
            "robots": self.robots,
            "network": self.network,
            "mission_complete": self.mission_complete,
            "mission_phase": self.mission_phase,
            "mission_seconds": round(self.mission_seconds),
            "wall_seconds": round(self.wall_seconds),
            "targets_total": self.targets_total,
            "targets_found": self.targets_found,
            "targets": targets,
            "duplicate_investigations": self.duplicate_investigations,
            "robot_failures": self.robot_failures,
            "fault": self.fault.as_ref().map(|(r, t)| json!({"robot": r, "at": round(*t)})),
            "detection_seconds": self.detection_seconds.map(round),
            "recovery_seconds": self.recovery_seconds.map(round),
            "taken_over": self.taken_over,
            "team_link_bytes": self.team_link_bytes,
            "intra_robot_bytes": self.intra_robot_bytes,
            "team_fraction_of_intra": (self.team_fraction() * 10_000.0).round() / 10_000.0,
            "team_report_fraction_of_intra": (self.team_report_fraction() * 10_000.0).round() / 10_000.0,
            "team_overhead_fraction": (self.team_overhead_fraction() * 10_000.0).round() / 10_000.0,
            "team_bytes_per_robot_minute": self.team_bytes_per_robot_minute().round(),
            "team_link_budget_bps": self.team_link_budget_bps,
            "team_link_peak_bps": round(self.team_link_peak_bps),
            "team_link_peak_radio": self.team_link_peak_radio,
            "team_channel_peak_bps": round(self.team_channel_peak_bps),
            "team_link_offered_peak_bps": round(self.team_link_offered_peak_bps),
            "team_link_max_backlog_seconds": round(self.team_link_max_backlog_seconds),
            "team_link_mean_bps": round(self.team_link_mean_bps),
            "team_bytes_by_kind": self.team_bytes_by_kind,
            "intra_bytes_by_kind": self.intra_bytes_by_kind,
            "consistency_lag_seconds": self.consistency_lag_seconds.map(round),
            "disagreement": self.disagreement,
            "propagation_changes": self.propagation_changes,
            "propagation_median_seconds": self.propagation_median_seconds.map(round),
            "propagation_p95_seconds": self.propagation_p95_seconds.map(round),
            "propagation_max_seconds": self.propagation_max_seconds.map(round),
            "plans_sent": self.plans_sent,
            "plans_accepted": self.plans_accepted,
            "plans_rejected": self.plans_rejected,
            "events": self.events,
        });
        if let Value::Object(map) = &mut summary {
            map.extend(self.channel_json());
            map.extend(self.deck_json());
            map.extend(self.team_protocol_json());
            if let Some(recording) = &self.recording {
                map.insert("recording".into(), recording.clone());
            }
        }
        summary
    }

    /// The deck phase, as JSON fields: none without one (a run without a deck reports
    /// what it always did).
    fn deck_json(&self) -> serde_json::Map<String, Value> {
        let mut map = serde_json::Map::new();
        if let Some(seconds) = self.deck_seconds {
            map.insert("deck_seconds".into(), json!(round(seconds)));
            map.insert("deck_bytes".into(), json!(self.deck_bytes));
            map.insert("deck_bytes_by_kind".into(), json!(self.deck_bytes_by_kind));
        }
        map
    }

    /// The team protocol's repair bytes and queue wait, as JSON fields, present in every
    /// run (0 without the team protocol) so that the summary's fields do not depend on
    /// the protocol or the network.
    fn team_protocol_json(&self) -> serde_json::Map<String, Value> {
        let mut map = serde_json::Map::new();
        map.insert("team_repair_bytes".into(), json!(self.team_repair_bytes));
        let wait = self.team_queue_max_seconds.map(round);
        map.insert("team_queue_max_seconds".into(), json!(wait));
        map
    }

    /// The team link's medium and air, as JSON fields.
    fn channel_json(&self) -> serde_json::Map<String, Value> {
        let c = self.team_channel.as_ref();
        let fields = json!({
            "team_link": self.team_medium(),
            "team_channel_utilisation": c.and_then(|c| c.utilisation).map(|u| (u * 10_000.0).round() / 10_000.0),
            "team_frames_sent": c.map(|c| c.frames_sent),
            "team_frames_lost": c.map(|c| c.frames_lost),
            "team_largest_frame_bytes": c.map(|c| c.largest_frame_bytes),
            "team_largest_message_bytes": c.map(|c| c.largest_message_bytes),
            "team_channel_max_queued_seconds": c.map(|c| round(c.max_queued_seconds)),
            "team_messages_dropped": c.map(|c| c.dropped_msgs),
        });
        match fields {
            Value::Object(map) => map,
            _ => serde_json::Map::new(),
        }
    }

    /// `radio` or `acoustic` (Zenoh runs radios only).
    pub fn team_medium(&self) -> &str {
        self.team_channel.as_ref().map_or("radio", |c| &c.medium)
    }

    /// The summary as text.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        let verdict = if self.mission_complete {
            "mission complete"
        } else {
            "mission NOT complete"
        };
        let _ = writeln!(
            s,
            "slate demo, seed {}, {} robots, {} network: {verdict} ({}) after {:.1} s of world time, {:.1} s wall\n",
            self.seed,
            self.robots,
            self.network,
            self.mission_phase,
            self.mission_seconds,
            self.wall_seconds
        );
        self.targets_text(&mut s);
        self.fault_text(&mut s);
        self.links_text(&mut s);
        let lag = self.consistency_lag_seconds.map_or_else(
            || {
                format!(
                    "did NOT agree: {}",
                    self.disagreement.as_deref().unwrap_or("?")
                )
            },
            |l| format!("agreed {l:.1} s after the last change"),
        );
        let _ = writeln!(
            s,
            "consistency  the team's boards (console + execution controllers) {lag}"
        );
        let secs = |x: Option<f64>| x.map_or("-".into(), |v| format!("{v:.1} s"));
        let _ = writeln!(
            s,
            "  during the run {} changes reached every board in {} (median), {} (95 %), {} (max)",
            self.propagation_changes,
            secs(self.propagation_median_seconds),
            secs(self.propagation_p95_seconds),
            secs(self.propagation_max_seconds)
        );
        let _ = writeln!(
            s,
            "plans        {} sent on circuits, {} accepted, {} rejected",
            self.plans_sent, self.plans_accepted, self.plans_rejected
        );
        s
    }

    fn targets_text(&self, s: &mut String) {
        let _ = writeln!(
            s,
            "targets      {}/{} found, {} duplicated investigations",
            self.targets_found, self.targets_total, self.duplicate_investigations
        );
        for t in &self.targets {
            let found = match (&t.found_by[..], t.found_at) {
                ("", _) => "not found".to_owned(),
                (by, Some(at)) => format!("found by {by} at {at:.1} s"),
                (by, None) => format!("found by {by}"),
            };
            let inv = if t.investigators.is_empty() {
                String::new()
            } else {
                format!("  (investigated by {})", t.investigators.join(", "))
            };
            let _ = writeln!(s, "  {:<4} {found}{inv}", t.name);
        }
    }

    fn fault_text(&self, s: &mut String) {
        let Some((robot, at)) = &self.fault else {
            let _ = writeln!(s, "fault        none");
            return;
        };
        let seconds = |x: Option<f64>| x.map_or("never".into(), |v| format!("{v:.1} s"));
        let _ = writeln!(
            s,
            "fault        {robot} died at {at:.1} s; every survivor held it dead after {}; recovery after {}",
            seconds(self.detection_seconds),
            seconds(self.recovery_seconds)
        );
        if !self.taken_over.is_empty() {
            let _ = writeln!(s, "  taken over: {}", self.taken_over.join(", "));
        }
    }

    fn links_text(&self, s: &mut String) {
        let budget = match self.team_medium() {
            "radio" => "per radio",
            _ => "on the one shared channel",
        };
        let _ = writeln!(
            s,
            "team link    {} bytes, {:.2} % of the {} bytes inside the robots; budget {} bit/s {budget}",
            self.team_link_bytes,
            100.0 * self.team_fraction(),
            self.intra_robot_bytes,
            self.team_link_budget_bps
        );
        if let Some(deck) = self.deck_seconds {
            let _ = writeln!(
                s,
                "  on deck    {} bytes in the {deck:.0} s before launch, on a fast clean radio (the mission's time, rates and backlogs count from launch)",
                self.deck_bytes
            );
        }
        self.channel_text(s);
        if self.team_medium() == "radio" {
            self.radios_text(s);
        }
        let kinds = |m: &BTreeMap<String, u64>| {
            let mut v: Vec<_> = m.iter().collect();
            v.sort_by(|a, b| b.1.cmp(a.1));
            v.iter()
                .map(|(k, b)| format!("{k} {b}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let _ = writeln!(
            s,
            "  reports alone (the world model, no protocol overhead): {:.1} % of the robots' own",
            100.0 * self.team_report_fraction()
        );
        let _ = writeln!(
            s,
            "  overhead (neither reports, plans nor plan acks): {:.1} % of the team bytes; {:.0} bytes per robot per minute",
            100.0 * self.team_overhead_fraction(),
            self.team_bytes_per_robot_minute()
        );
        if self.team_repair_bytes > 0 {
            let _ = writeln!(
                s,
                "  repairs: {} bytes (their reports count as reports above)",
                self.team_repair_bytes
            );
        }
        if let Some(wait) = self.team_queue_max_seconds.filter(|w| *w > 0.0) {
            let _ = writeln!(
                s,
                "  gateways' queues: a message waited at most {wait:.2} s for the radio"
            );
        }
        let _ = writeln!(s, "  team by kind:  {}", kinds(&self.team_bytes_by_kind));
        let _ = writeln!(s, "  robot by kind: {}", kinds(&self.intra_bytes_by_kind));
    }
}

/// The message kinds that carry the world model and the plans themselves: the rest of
/// the team link's bytes are the protocol's overhead.
const MODEL_KINDS: [&str; 3] = ["report", "plan", "plan_ack"];

impl Summary {
    /// The radios' lines: the busiest radio against the budget, and all together (the
    /// acoustic channel has its own line instead).
    fn radios_text(&self, s: &mut String) {
        let _ = writeln!(
            s,
            "  radio peak {:.0} bit/s ({}, {:.0} % of budget; bursts up to {:.0} bit/s queued at most {:.1} s)",
            self.team_link_peak_bps,
            self.team_link_peak_radio,
            100.0 * self.team_link_peak_bps / self.team_link_budget_bps as f64,
            self.team_link_offered_peak_bps,
            self.team_link_max_backlog_seconds,
        );
        let _ = writeln!(
            s,
            "  all radios together: mean {:.0} bit/s, peak {:.0} bit/s",
            self.team_link_mean_bps, self.team_channel_peak_bps
        );
    }

    /// The shared channel's line (acoustic only: radios are the lines after it).
    fn channel_text(&self, s: &mut String) {
        let Some(c) = &self.team_channel else { return };
        let Some(utilisation) = c.utilisation else {
            return;
        };
        let _ = writeln!(
            s,
            "  {} channel (shared by the whole team): on the air {:.1} % of the run; {} frames sent, {} lost; largest frame {} bytes (largest message {} bytes); a message waited up to {:.1} s, {} dropped as the queue was full",
            c.medium,
            100.0 * utilisation,
            c.frames_sent,
            c.frames_lost,
            c.largest_frame_bytes,
            c.largest_message_bytes,
            c.max_queued_seconds,
            c.dropped_msgs
        );
    }
}

fn round(x: f64) -> f64 {
    (x * 100.0).round() / 100.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn repair_bytes_are_in_every_json_summary_and_in_the_text_when_there_are_some() {
        let none = Summary::default();
        assert_eq!(none.to_json()["team_repair_bytes"], json!(0));
        assert_eq!(none.to_json()["team_queue_max_seconds"], Value::Null);
        assert!(!none.to_text().contains("repairs:"));
        let some = Summary {
            team_repair_bytes: 120,
            ..Summary::default()
        };
        assert_eq!(some.to_json()["team_repair_bytes"], json!(120));
        assert!(some.to_text().contains("repairs: 120 bytes"));
    }
}
