//! What the live verbs share: joining the team as a short-lived observer, Ctrl-C and
//! SIGTERM, and showing packets.

use std::sync::OnceLock;
use std::time::Duration;

use anyhow::Context as _;
use crossbeam_channel::Receiver;
use serde_json::{Value as Json, json};
use slate_model::{Address, Board, Packet, Value};
use slate_node::team_keys::Identity;
use slate_node::{
    Node, ObserveError, ObserverOptions, OperatorKeys, inspect::Classes, is_observer, observe,
};
use slate_zenoh::OpenError;

use crate::cli::{ConnectArgs, LiveArgs};
use crate::command::failed;

/// Joins the team as an observer and waits for its catch-up. A malformed endpoint is
/// named as the `--connect` it came from, not reported as unreachable.
pub fn join(live: &LiveArgs) -> anyhow::Result<Node> {
    join_as(live, "--as")
}

/// [`join`], where `flag` is the option the address came from (`--as`, or `--onto TEAM`
/// for a replay): an address the operator may not speak as is named as that option.
pub fn join_as(live: &LiveArgs, flag: &str) -> anyhow::Result<Node> {
    let address = optional_address(live.address.as_deref(), "--as")?;
    let connection = &live.connection;
    let options = ObserverOptions {
        connect: connection.connect.clone(),
        address,
        wait: wait(connection)?,
        operator: operator_keys(connection)?,
    };
    observe(&options).map_err(|e| match e {
        ObserveError::Open(OpenError::Endpoint(bad)) => {
            anyhow::Error::new(bad).context("--connect")
        }
        e @ ObserveError::NotOperator { .. } => anyhow::Error::new(e).context(flag.to_owned()),
        other => other.into(),
    })
}

/// `--wait`, checked: a positive number of seconds.
pub fn wait(connection: &ConnectArgs) -> anyhow::Result<Duration> {
    let value = connection.wait;
    Duration::try_from_secs_f64(value)
        .ok()
        .filter(|w| !w.is_zero())
        .with_context(|| format!("--wait {value}: expected a positive number of seconds"))
}

/// `--keys DIR --operator TEAM/NAME`, if given (clap requires both or neither).
pub fn operator_keys(connection: &ConnectArgs) -> anyhow::Result<Option<OperatorKeys>> {
    let (Some(dir), Some(operator)) = (&connection.keys, &connection.operator) else {
        return Ok(None);
    };
    let identity = Identity::parse(operator)
        .ok()
        .filter(|i| matches!(i, Identity::Operator { .. }))
        .with_context(|| {
            format!("--operator {operator:?}: expected an operator TEAM/NAME, as issued by `slate keys issue DIR TEAM/NAME`")
        })?;
    Ok(Some(OperatorKeys {
        dir: dir.clone(),
        identity,
    }))
}

/// Fires once on SIGINT (Ctrl-C) or SIGTERM. The handler is installed on first use.
pub fn interrupted() -> anyhow::Result<&'static Receiver<()>> {
    static SIGNALS: OnceLock<Result<Receiver<()>, String>> = OnceLock::new();
    let installed = SIGNALS.get_or_init(|| {
        let (tx, rx) = crossbeam_channel::bounded(1);
        ctrlc::set_handler(move || {
            let _ = tx.try_send(());
        })
        .map(|()| rx)
        .map_err(|e| e.to_string())
    });
    installed
        .as_ref()
        .map_err(|e| anyhow::anyhow!("cannot handle Ctrl-C: {e}"))
}

/// `OBJ.ATTR` or `OBJ` split at the first dot.
pub fn split(target: &str) -> (&str, Option<&str>) {
    match target.split_once('.') {
        Some((o, a)) => (o, Some(a)),
        None => (target, None),
    }
}

/// Fails (exit 1) unless `object` is an object or class on the observer's board; the
/// message says which modules it sees only through their export.
pub fn known(node: &Node, object: &str) -> anyhow::Result<()> {
    let board = node.board();
    if board.info(object).is_some() {
        return Ok(());
    }
    let notes = [export_note(node), conflict_note(node)];
    let hint: String = notes
        .into_iter()
        .flatten()
        .map(|n| format!("; {n}"))
        .collect();
    failed(format!(
        "no object or class named {object:?} on the boards of {} (see `slate ls Thing`){hint}",
        team_of(board)
    ))
}

/// The classes this observer's board and another module define differently, whose
/// objects it therefore does not hold; `None` when there are none:
/// `classes defined differently on this team, whose objects are not merged: Sonar (t/r2/loco); see slate tree`.
pub fn conflict_note(node: &Node) -> Option<String> {
    let conflicts = node.ici().class_conflicts();
    if conflicts.is_empty() {
        return None;
    }
    let list: Vec<String> = conflicts
        .iter()
        .map(|(class, peer)| format!("{class} ({peer})"))
        .collect();
    Some(format!(
        "classes defined differently on this team, whose objects are not merged: {}; see `slate tree`",
        list.join(", ")
    ))
}

/// The modules whose boards this observer sees only through their export policy: those
/// on another robot (observers own nothing and are left out), sorted.
pub fn seen_through_export(node: &Node) -> Vec<Address> {
    let me = node.address();
    let mut modules: Vec<Address> = node
        .peers()
        .into_iter()
        .filter(|p| !is_observer(p) && (p.team(), p.robot()) != (me.team(), me.robot()))
        .collect();
    modules.sort();
    modules
}

/// What this observer cannot see and how to see it; `None` when it sees everything:
/// `modules on other robots show this observer (on t/r1) only what they export: t/r2/loco;
/// to see all of a robot, add --as TEAM/ROBOT/cli, like --as t/r2/cli`.
pub fn export_note(node: &Node) -> Option<String> {
    let modules = seen_through_export(node);
    let first = modules.first()?;
    let me = node.address();
    let names: Vec<&str> = modules.iter().map(Address::as_str).collect();
    Some(format!(
        "modules on other robots show this observer (on {}/{}) only what they export: {}; to see all of a robot, add --as TEAM/ROBOT/cli, like --as {}/{}/cli",
        me.team(),
        me.robot(),
        names.join(", "),
        first.team(),
        first.robot()
    ))
}

/// The JSON list of [`seen_through_export`].
pub fn seen_through_export_json(node: &Node) -> Json {
    let modules = seen_through_export(node);
    json!(modules.iter().map(Address::as_str).collect::<Vec<_>>())
}

/// Prints [`export_note`] on stderr (text output), if there is one.
pub fn print_export_note(node: &Node) {
    if let Some(note) = export_note(node) {
        eprintln!("note: {note}");
    }
}

/// `team t` of an observer's board.
pub fn team_of(board: &Board) -> String {
    format!("team {}", board.address().team())
}

/// Seconds since the packet was written; `None` for a packet that claims no time (a
/// declared default, an initial value from a file: an age of 0 would read as fresh).
fn age(board: &Board, p: &Packet) -> Option<f64> {
    p.age(board.clock()).map(|d| d.as_secs_f64())
}

/// A value as JSON: numbers, booleans, strings, arrays; a reference as `{"ref": name}`;
/// `none` as null.
pub fn value_json(v: &Value) -> Json {
    match v {
        Value::None => Json::Null,
        Value::Int(i) => json!(i),
        Value::Real(x) => json!(x),
        Value::Bool(b) => json!(b),
        Value::Str(s) => json!(&**s),
        Value::Ref(r) => json!({"ref": &**r}),
        Value::Vector(xs) => json!(&**xs),
    }
}

/// A packet as JSON, with its attribute's name and unit. A declared default says
/// `"default": true` and has no source; a packet that claims no time (a default, an
/// initial value from a file) has no age or timestamp (null).
pub fn packet_json(board: &Board, attr: &str, unit: Option<&str>, p: &Packet) -> Json {
    let timed = p.has_time();
    json!({
        "attr": attr, "value": value_json(&p.value), "unit": unit, "accuracy": p.accuracy,
        "confidence": p.confidence, "default": p.is_default(), "age": age(board, p),
        "timestamp": timed.then(|| p.timestamp.as_secs_f64()),
        "source": (!p.is_default()).then(|| p.source.to_string()),
    })
}

/// `2.5 ± 0.1 m/s  confidence 0.90  age 1.2 s  from team/r1/nav`; for a declared default
/// `0.0 m/s  confidence 1.00  default, never written`; for an initial value from a file
/// `1.0 m/s  confidence 1.00  initial value from team/r1/nav, no time`.
pub fn packet_text(board: &Board, unit: Option<&str>, p: &Packet) -> String {
    let unit = unit.map_or(String::new(), |u| format!(" {u}"));
    let accuracy = if p.accuracy > 0.0 {
        format!(" ± {}", short(p.accuracy))
    } else {
        String::new()
    };
    let written = match age(board, p) {
        Some(seconds) => format!("age {}  from {}", age_text(seconds), p.source),
        None if p.is_default() => "default, never written".to_owned(),
        None => format!("initial value from {}, no time", p.source),
    };
    format!(
        "{}{accuracy}{unit}  confidence {:.2}  {written}",
        p.value.plain_text(),
        p.confidence,
    )
}

/// A number with four significant digits at most (accuracies are quantised on a log
/// scale: 0.10511205 reads better as 0.1051).
pub fn short(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let digits = (3 - x.abs().log10().floor() as i32).clamp(0, 12) as usize;
    let text = format!("{x:.digits$}");
    if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.').to_owned()
    } else {
        text
    }
}

fn age_text(seconds: f64) -> String {
    if seconds < 10.0 {
        format!("{seconds:.1} s")
    } else {
        format!("{seconds:.0} s")
    }
}

/// The unit declared for `object.attr`.
pub fn unit<'a>(board: &Board, classes: &'a Classes, object: &str, attr: &str) -> Option<&'a str> {
    let info = board.info(object)?;
    let class = if info.is_class { object } else { &*info.class };
    classes.decl(class, attr)?.unit.as_deref()
}

/// Prints the one JSON object of a verb's answer.
pub fn print_json(j: &Json) -> anyhow::Result<()> {
    println!("{}", serde_json::to_string_pretty(j)?);
    Ok(())
}

/// Prints one JSON object on one line (the verbs that stream).
pub fn print_line(j: &Json) -> anyhow::Result<()> {
    use std::io::Write as _;
    let mut out = std::io::stdout().lock();
    writeln!(out, "{}", serde_json::to_string(j)?)?;
    out.flush()?;
    Ok(())
}

/// The address an optional flag gives, if it was given; a bad one is an error that names
/// the flag.
pub fn optional_address(text: Option<&str>, flag: &'static str) -> anyhow::Result<Option<Address>> {
    text.map(Address::new).transpose().context(flag)
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use slate_model::{Board, Clock};

    use super::*;

    /// A board holding `o : V` with `speed` written once, `mode` left at its default and
    /// `goal` given an initial value by the file.
    fn board() -> Arc<Board> {
        let board = Arc::new(Board::builder().clock(Clock::manual()).build());
        let text = "class V { speed: real = 0.0; mode: string = \"auto\"; goal: real; }\n\
                    object o : V { goal = 4.0; }";
        slate_plans::Engine::new(&board)
            .load("v.slate", text)
            .unwrap();
        board.write("o", "speed", 2.5).unwrap();
        board
    }

    /// How `o.attr` of [`board`] shows: as text, and as JSON.
    fn shown(attr: &str) -> (String, serde_json::Value) {
        let board = board();
        let packet = board.read("o", attr).unwrap();
        let text = packet_text(&board, None, &packet);
        (text, packet_json(&board, attr, None, &packet))
    }

    #[test]
    fn a_never_written_default_shows_as_a_default_not_as_fresh() {
        let (text, j) = shown("mode");
        assert_eq!(text, "auto  confidence 1.00  default, never written");
        assert_eq!(j["default"], true);
        assert!(j["age"].is_null() && j["timestamp"].is_null(), "{j}");
        assert!(j["source"].is_null(), "{j}");
    }

    #[test]
    fn a_written_packet_shows_its_age_and_source() {
        let (text, j) = shown("speed");
        assert!(text.contains("age 0.0 s  from "), "{text}");
        assert_eq!(j["default"], false);
        assert!(j["age"].is_f64() && j["timestamp"].is_f64(), "{j}");
        assert!(j["source"].is_string(), "{j}");
    }

    #[test]
    fn an_initial_value_from_a_file_shows_its_source_and_no_age() {
        let (text, j) = shown("goal");
        assert!(
            text.ends_with("initial value from local/robot/module, no time"),
            "{text}"
        );
        assert_eq!(j["default"], false);
        assert!(j["age"].is_null() && j["timestamp"].is_null(), "{j}");
        assert_eq!(j["source"], "local/robot/module", "{j}");
    }
}
