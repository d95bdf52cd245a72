//! `slate demo --record`: the console's board recorded in MCAP while the mission runs
//! (docs/recording.md), and its board as the run ends written beside it, so that a replay
//! of the recording can be compared with what the console really held.

use std::path::Path;

use serde_json::{Value, json};
use slate_node::RecordConfig;
use slate_node::record::board_state;

use crate::config::DemoConfig;
use crate::error::DemoError;
use crate::team::Team;

/// Starts recording the console's board when the run asks for it: from the board it
/// holds now (its classes, objects and packets), then every change.
pub(crate) fn start(team: &Team, config: &DemoConfig) -> Result<(), DemoError> {
    let Some(path) = &config.record else {
        return Ok(());
    };
    team.console()
        .node
        .start_recording(RecordConfig::new(path))
        .map_err(|e| DemoError::Record(e.to_string()))
}

/// Finishes the recording (what waits is written, then the file's summary) and writes
/// the console's final board if asked: the summary's `recording` fields (`None` when the
/// run recorded nothing). What failed is in its `failed` field, never a panic.
pub(crate) fn finish(team: &Team, config: &DemoConfig) -> Option<Value> {
    let console = &team.console().node;
    let mut facts = match console.stop_recording() {
        Ok(Some(stats)) => stats_json(&stats),
        Ok(None) => json!({}),
        Err(e) => json!({ "failed": e.to_string() }),
    };
    if let Some(path) = &config.final_board {
        facts["final_board"] = json!(path.display().to_string());
        if let Err(e) = write_board(path, console.board()) {
            facts["failed"] = json!(e);
        }
    }
    (config.record.is_some() || config.final_board.is_some()).then_some(facts)
}

/// The recorder's counters as the summary reports them.
fn stats_json(stats: &slate_node::RecordStats) -> Value {
    json!({
        "messages": stats.messages, "bytes": stats.bytes, "dropped": stats.dropped,
        "files": stats.files, "by_topic": stats.by_topic, "failed": stats.failed,
    })
}

/// The board's objects and their own packets (`slate_node::record::board_state`, the
/// shape of `slate play --format json`'s `objects`), as one JSON file.
fn write_board(path: &Path, board: &slate_model::Board) -> Result<(), String> {
    let text = serde_json::to_string(&board_state(board)).map_err(|e| e.to_string())?;
    std::fs::write(path, text)
        .map_err(|e| format!("cannot write the final board {}: {e}", path.display()))
}
