//! A node's configuration: the TOML file `slate node --config` reads (every key is in
//! `docs/config.md`), as a struct Rust and Python code can also build directly.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::time::Duration;

use slate_ici::{ClassSet, IciConfig, LinkKind, TeamProtocol};
use slate_model::{Address, Context};
use slate_plans::Substitution;
use slate_zenoh::{Mode, ZenohConfig};

use crate::authority::{PlanSender, WritesFrom, default_plans_from};
use crate::error::ConfigError;
use crate::fields::{Fields, describe};
use crate::record::RecordConfig;
use crate::state::{Durability, StateConfig};

/// Everything a node needs to start.
///
/// ```
/// use slate_node::NodeConfig;
/// let config = NodeConfig::parse(
///     "nav.toml",
///     r#"
///     address = "team/r1/nav"
///     interest = ["Vehicle", "Obstacle:surroundings"]
///     export = ["Vehicle:self"]
///     [zenoh]
///     listen = ["tcp/127.0.0.1:7447"]
///     "#,
///     std::path::Path::new("."),
/// )?;
/// assert_eq!(config.address.as_str(), "team/r1/nav");
/// assert_eq!(config.zenoh.listen, ["tcp/127.0.0.1:7447"]);
///
/// let err = NodeConfig::parse("nav.toml", "address = \"team/r1/nav\"\nlisten = []", std::path::Path::new("."))
///     .unwrap_err();
/// assert!(err.to_string().starts_with("nav.toml: unknown key `listen`"));
/// # Ok::<(), slate_node::ConfigError>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct NodeConfig {
    /// The module's address, `team/robot/module`.
    pub address: Address,
    /// How to join the Zenoh network (peer mode, explicit endpoints, no multicast
    /// scouting by default).
    pub zenoh: ZenohConfig,
    /// `.slate` files loaded in order at start (relative paths are resolved against the
    /// config file's folder), each with its placeholders.
    pub files: Vec<SourceFile>,
    /// The ICI's settings: interest, export policy, liveliness and timing.
    pub ici: IciConfig,
    /// Where to serve the dashboard, if anywhere (a bare port is on 127.0.0.1).
    pub dashboard: Option<SocketAddr>,
    /// The token the dashboard's clients must show (`?token=` or `Authorization: Bearer`);
    /// without one, a dashboard on an address other than loopback generates one.
    pub dashboard_token: Option<String>,
    /// Where to serve the Foxglove WebSocket protocol, if anywhere (docs/foxglove.md).
    pub foxglove: Option<SocketAddr>,
    /// Where to record the board, if anywhere (`record`, and `[recording]` for rotation).
    pub record: Option<RecordConfig>,
    /// Where to keep the board across restarts, if anywhere (`state`, and `[storage]`
    /// for when it commits).
    pub state: Option<StateConfig>,
    /// The team's keys folder (`[security] keys`, made by `slate keys`): the node then
    /// runs over TLS with mutual authentication as its address, under the team's access
    /// control (docs/security.md). `None`: links neither authenticated nor encrypted.
    pub security: Option<PathBuf>,
    /// Who may send this module plans (`[authority] plans_from`): by default its robot's
    /// modules and the team's operators.
    pub plans_from: Vec<PlanSender>,
    /// Who may write which classes and attributes on this module's board besides itself
    /// (`[authority.writes]`): by default no rule, any module.
    pub writes_from: Vec<WritesFrom>,
}

/// A `.slate` file a node loads at start, and the placeholders replaced in its text
/// first (`files = [{ path = "robot.slate", substitute = { ROBOT = "r1" } }]`).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SourceFile {
    /// Where the file is.
    pub path: PathBuf,
    /// Placeholders replaced in its text before it is loaded (none by default).
    pub substitute: Substitution,
}

impl<P: Into<PathBuf>> From<P> for SourceFile {
    fn from(path: P) -> Self {
        SourceFile {
            path: path.into(),
            substitute: Substitution::default(),
        }
    }
}

/// Keys of the top table.
const TOP: &[&str] = &[
    "address",
    "files",
    "interest",
    "export",
    "lossless",
    "dashboard",
    "dashboard_token",
    "foxglove",
    "zenoh",
    "zenoh_config",
    "ici",
    "record",
    "recording",
    "state",
    "storage",
    "security",
    "authority",
];
/// Keys of `[authority]`.
const AUTHORITY: &[&str] = &["plans_from", "writes"];
/// Keys of `[storage]`.
const STORAGE: &[&str] = &["commit_every", "commit_changes", "queue", "durability"];
/// Keys of `[security]`.
const SECURITY: &[&str] = &["keys"];
/// Keys of `[recording]`.
const RECORDING: &[&str] = &["max_bytes", "max_duration", "flush", "stats", "queue"];
/// Keys of `[zenoh]`.
const ZENOH: &[&str] = &[
    "mode",
    "listen",
    "connect",
    "multicast_scouting",
    "udp_reports",
];
/// Keys of `[ici]`.
const ICI: &[&str] = &[
    "robot_heartbeat",
    "robot_timeout",
    "team_heartbeat",
    "team_timeout",
    "quiet",
    "gap_grace",
    "linger",
    "team_report_every",
    "catch_up_retry",
    "max_report_items",
    "max_tombstones",
    "max_sources",
    "forget_dead",
    "speakers",
    "team_preset",
    "gateway_priority",
    "gateway",
    "team_rate",
    "max_objects_per_source",
    "max_objects",
    "max_modules",
    "max_names_per_source",
    "max_names",
    "max_answer_bytes_per_requester",
];

/// A node's team link sends one attribute at most every 200 ms (`[ici]
/// team_report_every`, `"0s"` for every value at once): each report on a radio costs a
/// frame's headers, several times the value's own bytes (docs/performance.md, *Bytes on
/// the radio*), and the last value still arrives, at most this much later.
pub const TEAM_REPORT_EVERY: Duration = Duration::from_millis(200);

/// A node's team link finds a module of another robot dead after 20 s of silence
/// (`[ici] team_timeout`), not the library's 5 s: a node's team link is Zenoh over TCP by
/// default, and at 30 % loss TCP's retransmission back-off silenced healthy robots for 5
/// to 18 s (4 false dead marks in 5 runs of the real-link harness; 1, of 0.05 s, with
/// 20 s; docs/real-links.md, *No false marks at 30 % loss*). A robot that dies is still
/// seen dead sooner, by its transport's down (Zenoh's lease, or at once when its
/// connection closes), believed after 2.25 heartbeat periods of silence. An idle peer
/// (heartbeats 4 s apart) is given eight of its gaps, 32 s (docs/ici.md, *Liveliness*).
pub const TEAM_TIMEOUT: Duration = Duration::from_secs(20);

/// The ICI settings a node starts from, whether configured by a file or by a Python
/// `slate.Node`'s arguments: the library's defaults, the team link's report interval
/// ([`TEAM_REPORT_EVERY`]) and its timeout ([`TEAM_TIMEOUT`]). (The library's own
/// defaults send every value at once and time out after 5 s, so the simulator's runs
/// stay as they were.)
pub fn default_ici() -> IciConfig {
    let config = IciConfig::default().team_report_every(Some(TEAM_REPORT_EVERY));
    let heartbeat = config.team.heartbeat;
    config.liveliness(LinkKind::Team, heartbeat, TEAM_TIMEOUT)
}

const CLASSES: &str =
    "a list of class names, each optionally with contexts (\"Obstacle:surroundings,system\")";

impl NodeConfig {
    /// A config with defaults: peer mode, no endpoints, no files, interest in everything,
    /// nothing exported, no dashboard.
    pub fn new(address: Address) -> Self {
        NodeConfig {
            address,
            zenoh: node_zenoh(),
            files: Vec::new(),
            ici: default_ici(),
            dashboard: None,
            dashboard_token: None,
            foxglove: None,
            record: None,
            state: None,
            security: None,
            plans_from: default_plans_from(),
            writes_from: Vec::new(),
        }
    }

    /// Reads a config file.
    pub fn read(path: &Path) -> Result<Self, ConfigError> {
        let (file, text) = read_text(path)?;
        let base = path.parent().unwrap_or_else(|| Path::new("."));
        NodeConfig::parse(&file, &text, base)
    }

    /// Parses config text; `file` names it in errors, `base` resolves relative paths.
    pub fn parse(file: &str, text: &str, base: &Path) -> Result<Self, ConfigError> {
        let table = parse_toml(file, text)?;
        let mut top = Fields::new(file, table, TOP);
        let address = top.required_str("address", "a module address \"team/robot/module\"")?;
        let address = Address::new(&address).map_err(|e| {
            top.invalid(
                "address",
                "a module address \"team/robot/module\"",
                &e.to_string(),
            )
        })?;
        let mut config = NodeConfig::new(address);
        config.files = source_files(&mut top, base)?;
        if let Some(list) = top.strings("interest", CLASSES)? {
            config.ici.interest = read_class_set(&top, "interest", &list)?;
        }
        if let Some(list) = top.strings("export", CLASSES)? {
            config.ici.export = read_class_set(&top, "export", &list)?;
        }
        if let Some(list) = top.strings("lossless", CLASSES)? {
            config.ici.lossless = read_class_set(&top, "lossless", &list)?;
        }
        config.dashboard = dashboard(&mut top)?;
        config.dashboard_token = dashboard_token(&mut top)?;
        config.foxglove = foxglove(&mut top)?;
        if let Some(zenoh) = top.table("zenoh", ZENOH)? {
            config.zenoh = zenoh_section(zenoh)?;
        }
        config.zenoh.file = zenoh_file(&mut top, base)?;
        if let Some(ici) = top.table("ici", ICI)? {
            ici_section(ici, &mut config.ici)?;
        }
        config.record = record(&mut top, base)?;
        config.state = state(&mut top, base)?;
        if let Some(security) = top.table("security", SECURITY)? {
            config.security = Some(security_section(security, base)?);
        }
        if let Some(authority) = top.table("authority", AUTHORITY)? {
            (config.plans_from, config.writes_from) = authority_section(authority)?;
        }
        top.finish()?;
        Ok(config)
    }
}

/// A TOML file's name (as errors show it) and text: [`ConfigError::Read`] if it cannot
/// be read. With [`parse_toml`], how every TOML file slate reads is read.
pub fn read_text(path: &Path) -> Result<(String, String), ConfigError> {
    let file = path.display().to_string();
    match std::fs::read_to_string(path) {
        Ok(text) => Ok((file, text)),
        Err(error) => Err(ConfigError::Read { file, error }),
    }
}

/// TOML text as a table: [`ConfigError::Syntax`], with the line and column, if it is not
/// valid TOML; `file` names it in the error.
pub fn parse_toml(file: &str, text: &str) -> Result<toml::Table, ConfigError> {
    text.parse().map_err(|e| syntax(file, text, &e))
}

/// A TOML syntax error as one line with its position.
fn syntax(file: &str, text: &str, e: &toml::de::Error) -> ConfigError {
    let offset = e.span().map_or(0, |s| s.start).min(text.len());
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    ConfigError::Syntax {
        file: file.to_owned(),
        line,
        column,
        message: e.message().trim().replace('\n', " "),
    }
}

const FILES: &str = "a list of .slate file paths, each a string or \
    { path = \"robot.slate\", substitute = { ROBOT = \"r1\" } }";

/// `files`: paths resolved against `base`, each plain or with its placeholders.
fn source_files(top: &mut Fields, base: &Path) -> Result<Vec<SourceFile>, ConfigError> {
    let items = top.list("files", FILES)?.unwrap_or_default();
    items
        .into_iter()
        .map(|item| source_file(top, item, base))
        .collect()
}

fn source_file(top: &Fields, item: toml::Value, base: &Path) -> Result<SourceFile, ConfigError> {
    let bad = |found: &str| top.invalid("files", FILES, found);
    let mut table = match item {
        toml::Value::String(path) => return Ok(SourceFile::from(base.join(path))),
        toml::Value::Table(t) => t,
        other => return Err(bad(&describe(&other))),
    };
    let Some(toml::Value::String(path)) = table.remove("path") else {
        return Err(bad("an entry without a string `path`"));
    };
    let substitute = match table.remove("substitute") {
        None => Substitution::default(),
        Some(toml::Value::Table(pairs)) => substitution(pairs).map_err(|e| bad(&e))?,
        Some(other) => return Err(bad(&format!("`substitute` {}", describe(&other)))),
    };
    if let Some(key) = table.keys().next() {
        return Err(bad(&format!("unknown key `{key}` in an entry")));
    }
    Ok(SourceFile {
        path: base.join(path),
        substitute,
    })
}

/// `{ ROBOT = "r1" }` as a [`Substitution`], or what is wrong with it.
fn substitution(pairs: toml::Table) -> Result<Substitution, String> {
    let pairs = pairs
        .into_iter()
        .map(|(k, v)| match v {
            toml::Value::String(v) => Ok((k, v)),
            other => Err(format!("`substitute.{k}` {}", describe(&other))),
        })
        .collect::<Result<Vec<_>, _>>()?;
    Substitution::new(pairs).map_err(|e| e.to_string())
}

/// `dashboard = "HOST:PORT"`, or a bare port (on 127.0.0.1: the dashboard is served on
/// loopback unless told otherwise).
fn dashboard(top: &mut Fields) -> Result<Option<SocketAddr>, ConfigError> {
    const EXPECTED: &str =
        "an address to serve the dashboard on, like \"127.0.0.1:8080\" (or a port, on 127.0.0.1)";
    let Some(text) = top.str("dashboard", EXPECTED)? else {
        return Ok(None);
    };
    let loopback = |port: u16| SocketAddr::from(([127, 0, 0, 1], port));
    text.parse()
        .or_else(|_| text.parse().map(loopback))
        .map(Some)
        .map_err(|_| top.invalid("dashboard", EXPECTED, &format!("{text:?}")))
}

/// `dashboard_token = "TOKEN"`: at least 16 printable characters, none of them space, `&`,
/// `#`, `%` or `+` (it travels in a URL's query and a header, unescaped).
fn dashboard_token(top: &mut Fields) -> Result<Option<String>, ConfigError> {
    const EXPECTED: &str =
        "a token of at least 16 letters, digits or punctuation (no spaces, &, #, % or +)";
    let Some(token) = top.str("dashboard_token", EXPECTED)? else {
        return Ok(None);
    };
    let usable = token.len() >= 16
        && token
            .chars()
            .all(|c| c.is_ascii_graphic() && !matches!(c, '&' | '#' | '%' | '+'));
    if !usable {
        let found = format!("a token of {} characters that cannot be used", token.len());
        return Err(top.invalid("dashboard_token", EXPECTED, &found));
    }
    Ok(Some(token))
}

/// `foxglove = "ADDR"`: where to serve Foxglove's WebSocket protocol.
fn foxglove(top: &mut Fields) -> Result<Option<SocketAddr>, ConfigError> {
    const EXPECTED: &str =
        "an address to serve Foxglove's WebSocket protocol on, like \"127.0.0.1:8765\"";
    let Some(text) = top.str("foxglove", EXPECTED)? else {
        return Ok(None);
    };
    text.parse()
        .map(Some)
        .map_err(|_| top.invalid("foxglove", EXPECTED, &format!("{text:?}")))
}

/// `record = "FILE.mcap"`, with its `[recording]` settings.
fn record(top: &mut Fields, base: &Path) -> Result<Option<RecordConfig>, ConfigError> {
    let path = top.str("record", "a file to record to, like \"run.mcap\"")?;
    let settings = top.table("recording", RECORDING)?;
    let Some(path) = path else {
        return match settings {
            Some(_) => Err(top.invalid(
                "recording",
                "`record = \"FILE.mcap\"` beside it",
                "[recording] without record",
            )),
            None => Ok(None),
        };
    };
    let mut config = RecordConfig::new(base.join(path));
    if let Some(t) = settings {
        recording_section(t, &mut config)?;
    }
    Ok(Some(config))
}

fn recording_section(mut t: Fields, r: &mut RecordConfig) -> Result<(), ConfigError> {
    if let Some(n) = t.count("max_bytes")? {
        r.max_bytes = Some(n as u64);
    }
    r.max_duration = t.duration("max_duration")?.or(r.max_duration);
    r.flush_every = t.duration("flush")?.unwrap_or(r.flush_every);
    r.stats_every = t.duration("stats")?.unwrap_or(r.stats_every);
    r.queue = t.count("queue")?.unwrap_or(r.queue);
    t.finish()
}

/// `state = "DIR"`, with its `[storage]` settings.
fn state(top: &mut Fields, base: &Path) -> Result<Option<StateConfig>, ConfigError> {
    let dir = top.str(
        "state",
        "a directory to keep the board in, like \"state/nav\"",
    )?;
    let settings = top.table("storage", STORAGE)?;
    let Some(dir) = dir else {
        return match settings {
            Some(_) => Err(top.invalid(
                "storage",
                "`state = \"DIR\"` beside it",
                "[storage] without state",
            )),
            None => Ok(None),
        };
    };
    let mut config = StateConfig::new(base.join(dir));
    if let Some(t) = settings {
        storage_section(t, &mut config)?;
    }
    Ok(Some(config))
}

fn storage_section(mut t: Fields, s: &mut StateConfig) -> Result<(), ConfigError> {
    const DURABILITY: &str = "\"immediate\" or \"eventual\"";
    s.commit_every = t.duration("commit_every")?.unwrap_or(s.commit_every);
    s.commit_changes = t.count("commit_changes")?.unwrap_or(s.commit_changes);
    s.queue = t.count("queue")?.unwrap_or(s.queue);
    if let Some(name) = t.str("durability", DURABILITY)? {
        s.durability = Durability::from_name(&name)
            .ok_or_else(|| t.invalid("durability", DURABILITY, &format!("{name:?}")))?;
    }
    t.finish()
}

/// A node's Zenoh settings by default: a UDP link beside each TCP one carries the team
/// link's reports and heartbeats (`ZenohConfig::udp_reports`; docs/performance.md,
/// *Bytes on the radio*).
fn node_zenoh() -> ZenohConfig {
    ZenohConfig {
        udp_reports: true,
        ..ZenohConfig::default()
    }
}

fn zenoh_section(mut t: Fields) -> Result<ZenohConfig, ConfigError> {
    const ENDPOINTS: &str = "a list of Zenoh endpoints like \"tcp/127.0.0.1:7447\"";
    let mut z = node_zenoh();
    if let Some(mode) = t.str("mode", "\"peer\", \"router\" or \"client\"")? {
        z.mode = match mode.as_str() {
            "peer" => Mode::Peer,
            "router" => Mode::Router,
            "client" => Mode::Client,
            _ => {
                let found = format!("{mode:?}");
                return Err(t.invalid("mode", "\"peer\", \"router\" or \"client\"", &found));
            }
        };
    }
    for key in ["listen", "connect"] {
        let list = t.strings(key, ENDPOINTS)?.unwrap_or_default();
        if let Some(bad) = list.iter().find(|e| !is_endpoint(e)) {
            return Err(t.invalid(key, ENDPOINTS, &format!("{bad:?}")));
        }
        match key {
            "listen" => z.listen = list,
            _ => z.connect = list,
        }
    }
    z.multicast_scouting = t.bool("multicast_scouting")?.unwrap_or(false);
    z.udp_reports = t.bool("udp_reports")?.unwrap_or(z.udp_reports);
    t.finish()?;
    Ok(z)
}

/// `zenoh_config`: a Zenoh config file (JSON5), relative to the config's folder. Zenoh
/// reads it when the node starts and names what it refuses then.
fn zenoh_file(top: &mut Fields, base: &Path) -> Result<Option<PathBuf>, ConfigError> {
    let file = top.str(
        "zenoh_config",
        "the path of a Zenoh config file, like \"zenoh.json5\"",
    )?;
    Ok(file.map(|f| base.join(f)))
}

/// `[security] keys = "DIR"`: the team's keys folder, relative to the config's folder.
/// Its files are read and checked when the node starts.
fn security_section(mut t: Fields, base: &Path) -> Result<PathBuf, ConfigError> {
    const EXPECTED: &str = "the team's keys folder made by `slate keys`, like \"team-keys\"";
    let Some(dir) = t.str("keys", EXPECTED)? else {
        return Err(t.invalid("keys", EXPECTED, "nothing"));
    };
    t.finish()?;
    Ok(base.join(dir))
}

/// `[authority] plans_from = ["robot", "operators", "team/base/console"]`: who may send
/// this module plans (each entry a word or an address pattern; docs/security.md); and
/// `[authority.writes]`, `"Class.attr" = [...]` with the same entries: who may write it.
fn authority_section(mut t: Fields) -> Result<(Vec<PlanSender>, Vec<WritesFrom>), ConfigError> {
    const EXPECTED: &str =
        "a list of \"robot\", \"operators\" and address patterns like \"team/*/planner\"";
    let senders = |t: &mut Fields, key: &str| -> Result<Option<Vec<PlanSender>>, ConfigError> {
        let Some(list) = t.strings(key, EXPECTED)? else {
            return Ok(None);
        };
        list.iter()
            .map(|entry| entry.parse::<PlanSender>())
            .collect::<Result<Vec<_>, _>>()
            .map(Some)
            .map_err(|e| t.invalid(key, EXPECTED, &e.to_string()))
    };
    let plans_from = senders(&mut t, "plans_from")?.unwrap_or_default();
    let mut writes_from = Vec::new();
    if let Some(mut writes) = t.free_table("writes")? {
        for target in writes.keys() {
            if !valid_target(&target) {
                return Err(writes.invalid(
                    &target,
                    "a class or an attribute of one, like \"Vehicle\" or \"Vehicle.mode\"",
                    &format!("{target:?}"),
                ));
            }
            let writers = senders(&mut writes, &target)?.unwrap_or_default();
            writes_from.push(WritesFrom::new(&target, writers));
        }
        writes.finish()?;
    }
    t.finish()?;
    Ok((plans_from, writes_from))
}

/// `Class` or `Class.attr`: names (letters, digits, `_`, not starting with a digit).
fn valid_target(target: &str) -> bool {
    let name = |s: &str| {
        s.chars()
            .next()
            .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
            && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
    };
    match target.split_once('.') {
        Some((class, attr)) => name(class) && name(attr),
        None => name(target),
    }
}

/// `proto/address`, like `tcp/127.0.0.1:7447` (Zenoh checks the rest when it opens).
fn is_endpoint(text: &str) -> bool {
    text.split_once('/')
        .is_some_and(|(proto, rest)| !proto.is_empty() && !rest.is_empty())
}

/// The bounds per source and in total (docs/security.md, *Limits*).
fn ici_limits(t: &mut Fields, ici: &mut IciConfig) -> Result<(), ConfigError> {
    if let Some(n) = t.count("max_objects_per_source")? {
        ici.max_objects_per_source = n;
    }
    if let Some(n) = t.count("max_objects")? {
        ici.max_objects = n;
    }
    if let Some(n) = t.count("max_modules")? {
        ici.max_modules = n;
    }
    if let Some(n) = t.count("max_names_per_source")? {
        ici.max_names_per_source = n;
    }
    if let Some(n) = t.count("max_names")? {
        ici.max_names = n;
    }
    if let Some(n) = t.count("max_answer_bytes_per_requester")? {
        ici.max_answer_bytes_per_requester = n as u64;
    }
    Ok(())
}

fn ici_section(mut t: Fields, ici: &mut IciConfig) -> Result<(), ConfigError> {
    for (link, beat, timeout) in [
        (LinkKind::Robot, "robot_heartbeat", "robot_timeout"),
        (LinkKind::Team, "team_heartbeat", "team_timeout"),
    ] {
        let current = ici.link(link);
        let heartbeat = t.duration(beat)?.unwrap_or(current.heartbeat);
        let dead_after = t.duration(timeout)?.unwrap_or(current.timeout);
        if dead_after <= heartbeat {
            let found = format!("{dead_after:?}, not longer than {beat} {heartbeat:?}");
            return Err(t.invalid(timeout, &format!("a duration longer than {beat}"), &found));
        }
        *ici = ici.clone().liveliness(link, heartbeat, dead_after);
    }
    if let Some(d) = t.duration("quiet")? {
        ici.quiet = d;
    }
    if let Some(d) = t.duration("team_report_every")? {
        ici.team_report_every = (!d.is_zero()).then_some(d);
    }
    if let Some(d) = t.duration("gap_grace")? {
        ici.gap_grace = d;
    }
    if let Some(d) = t.duration("linger")? {
        ici.linger = d;
    }
    if let Some(d) = t.duration("catch_up_retry")? {
        ici.catch_up_retry = d;
    }
    if let Some(n) = t.count("max_report_items")? {
        ici.max_report_items = n;
    }
    if let Some(n) = t.count("max_tombstones")? {
        ici.max_tombstones = n;
    }
    if let Some(n) = t.count("max_sources")? {
        ici.max_sources = n;
    }
    if let Some(d) = t.duration("forget_dead")? {
        ici.forget_dead = d;
    }
    ici.team_protocol = team_protocol(&mut t)?;
    ici_limits(&mut t, ici)?;
    t.finish()
}

/// `speakers = "robots"` and its settings (`team_preset`, `gateway_priority`, `gateway`,
/// `team_rate`): one gateway per robot speaks on the team link (docs/team-protocol.md);
/// `None` with `"modules"`, the default, where every module speaks (docs/ici.md). The
/// settings alone are refused: without robots speaking they would do nothing.
fn team_protocol(t: &mut Fields) -> Result<Option<TeamProtocol>, ConfigError> {
    const SPEAKERS: &str = "\"modules\" or \"robots\"";
    let robots = match t.str("speakers", SPEAKERS)?.as_deref() {
        None | Some("modules") => false,
        Some("robots") => true,
        Some(other) => return Err(t.invalid("speakers", SPEAKERS, &format!("{other:?}"))),
    };
    let protocol = team_preset(t)?;
    let priority = t.integer_in("gateway_priority", 0, 255)?;
    let gateway = t.bool("gateway")?;
    let rate = t.count("team_rate")?;
    if !robots {
        let given = ["team_preset", "gateway_priority", "gateway", "team_rate"];
        let set = [
            protocol.is_some(),
            priority.is_some(),
            gateway.is_some(),
            rate.is_some(),
        ];
        return match given.iter().zip(set).find(|(_, s)| *s) {
            Some((key, _)) => Err(t.invalid(key, "speakers = \"robots\" beside it", "nothing")),
            None => Ok(None),
        };
    }
    let mut protocol = protocol.unwrap_or_else(TeamProtocol::radio);
    protocol.priority = priority
        .and_then(|p| u8::try_from(p).ok())
        .or(protocol.priority);
    if gateway == Some(false) {
        protocol.priority = None;
    }
    if let Some(bps) = rate {
        protocol.rate_bps = u32::try_from(bps).unwrap_or(u32::MAX);
    }
    Ok(Some(protocol))
}

/// `team_preset = "radio"` or `"acoustic"`: the team protocol's timings and frame size
/// for that medium ([`TeamProtocol::radio`], [`TeamProtocol::acoustic`]).
fn team_preset(t: &mut Fields) -> Result<Option<TeamProtocol>, ConfigError> {
    const PRESETS: &str = "\"radio\" or \"acoustic\"";
    match t.str("team_preset", PRESETS)?.as_deref() {
        None => Ok(None),
        Some("radio") => Ok(Some(TeamProtocol::radio())),
        Some("acoustic") => Ok(Some(TeamProtocol::acoustic())),
        Some(other) => Err(t.invalid("team_preset", PRESETS, &format!("{other:?}"))),
    }
}

/// A class set from `["Vehicle", "Obstacle:surroundings,system"]`.
fn read_class_set(t: &Fields, key: &str, list: &[String]) -> Result<ClassSet, ConfigError> {
    let mut set = ClassSet::none();
    for entry in list {
        set = add_class(set, entry)
            .map_err(|why| t.invalid(key, CLASSES, &format!("{entry:?} ({why})")))?;
    }
    Ok(set)
}

/// A class set from entries like `"Vehicle"` or `"Obstacle:surroundings,system"` (the
/// form of the config's `interest` and `export` keys).
///
/// ```
/// let set = slate_node::class_set(["Vehicle", "Obstacle:surroundings"])?;
/// assert!(!set.is_empty());
/// assert!(slate_node::class_set(["Obstacle:nearby"]).is_err());
/// # Ok::<(), String>(())
/// ```
pub fn class_set<S: AsRef<str>>(entries: impl IntoIterator<Item = S>) -> Result<ClassSet, String> {
    entries
        .into_iter()
        .try_fold(ClassSet::none(), |set, e| add_class(set, e.as_ref()))
}

/// Adds one `Class` or `Class:context,context` entry to a set.
fn add_class(set: ClassSet, entry: &str) -> Result<ClassSet, String> {
    let (class, contexts) = match entry.split_once(':') {
        Some((c, ctx)) => (c.trim(), Some(ctx)),
        None => (entry.trim(), None),
    };
    let ident = class
        .chars()
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && class.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    if !ident {
        return Err(format!("{class:?} is not a class name"));
    }
    let Some(contexts) = contexts else {
        return Ok(set.class(class));
    };
    let contexts = contexts
        .split(',')
        .map(|c| {
            Context::from_str(c.trim())
                .map_err(|_| format!("{:?} is not self, surroundings or system", c.trim()))
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(set.class_in(class, &contexts))
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;

    fn parse(text: &str) -> Result<NodeConfig, ConfigError> {
        NodeConfig::parse("m.toml", text, Path::new("/etc/slate"))
    }

    #[test]
    fn a_nodes_team_timeout_outlasts_tcps_retransmission_stalls_at_loss() {
        let ici = default_ici();
        assert_eq!(ici.team.timeout, Duration::from_secs(20));
        assert_eq!(ici.team.heartbeat, Duration::from_secs(1));
        let set = parse("address = \"t/r1/a\"\n[ici]\nteam_timeout = \"5s\"\n").unwrap();
        assert_eq!(set.ici.team.timeout, Duration::from_secs(5));
    }

    #[test]
    fn authority_says_who_may_send_plans_and_defaults_to_the_robot_and_operators() {
        let plain = parse("address = \"t/r1/nav\"").unwrap();
        assert_eq!(plain.plans_from, [PlanSender::Robot, PlanSender::Operators]);
        let c = parse(
            "address = \"t/r1/nav\"\n[authority]\nplans_from = [\"robot\", \"t/base/console\"]",
        )
        .unwrap();
        let console = "t/base/console".parse().unwrap();
        assert_eq!(c.plans_from, [PlanSender::Robot, console]);
        let err = parse("address = \"t/r1/nav\"\n[authority]\nplans_from = [\"everyone\"]")
            .unwrap_err()
            .to_string();
        assert!(err.contains("authority.plans_from"), "{err}");
        assert!(err.contains("\"robot\", \"operators\""), "{err}");
    }

    #[test]
    fn authority_writes_says_who_may_write_a_class_or_an_attribute() {
        assert!(
            parse("address = \"t/r1/nav\"")
                .unwrap()
                .writes_from
                .is_empty()
        );
        let c = parse(
            "address = \"t/r1/nav\"\n[authority.writes]\n\"Vehicle.mode\" = [\"robot\", \"operators\"]\nObstacle = [\"t/*/nav\"]",
        )
        .unwrap();
        let nav = "t/*/nav".parse().unwrap();
        assert_eq!(
            c.writes_from,
            [
                WritesFrom::new("Obstacle", vec![nav]),
                WritesFrom::new(
                    "Vehicle.mode",
                    vec![PlanSender::Robot, PlanSender::Operators]
                ),
            ]
        );
        assert_eq!(c.writes_from[1].attr.as_deref(), Some("mode"));
        for (bad, says) in [
            (
                "\"Vehicle.mode\" = [\"everyone\"]",
                "authority.writes.Vehicle.mode",
            ),
            (
                "\"Vehicle.mode.x\" = [\"robot\"]",
                "like \"Vehicle\" or \"Vehicle.mode\"",
            ),
            ("Vehicle = \"robot\"", "authority.writes.Vehicle"),
        ] {
            let text = format!("address = \"t/r1/nav\"\n[authority.writes]\n{bad}");
            let err = parse(&text).unwrap_err().to_string();
            assert!(err.contains(says), "{bad}: {err}");
        }
    }

    #[test]
    fn every_key_is_read() {
        let c = parse(
            r#"
            address = "t/r1/nav"
            files = ["world.slate", "/abs/plans.slate"]
            interest = ["Vehicle", "Obstacle:surroundings,system"]
            export = ["Vehicle:self"]
            lossless = ["Event"]
            dashboard = "127.0.0.1:8080"
            dashboard_token = "0123456789abcdef0123"
            zenoh_config = "zenoh.json5"
            [security]
            keys = "team-keys"
            [zenoh]
            mode = "router"
            listen = ["tcp/127.0.0.1:7447"]
            connect = ["tcp/127.0.0.1:7448"]
            multicast_scouting = true
            udp_reports = false
            [ici]
            robot_heartbeat = "100ms"
            robot_timeout = "500ms"
            team_heartbeat = "2s"
            team_timeout = "10s"
            quiet = "250ms"
            gap_grace = "50ms"
            linger = "0s"
            catch_up_retry = "1s"
            team_report_every = "0s"
            max_report_items = 64
            max_tombstones = 100
            max_objects_per_source = 50
            max_objects = 500
            max_modules = 20
            max_names_per_source = 300
            max_names = 9000
            max_answer_bytes_per_requester = 5000
            "#,
        )
        .unwrap();
        assert_eq!(
            c.files,
            [
                SourceFile::from("/etc/slate/world.slate"),
                SourceFile::from("/abs/plans.slate")
            ]
        );
        assert_eq!(
            c.ici.interest,
            ClassSet::none()
                .class("Vehicle")
                .class_in("Obstacle", &[Context::Surroundings, Context::System])
        );
        assert_eq!(
            c.ici.export,
            ClassSet::none().class_in("Vehicle", &[Context::Self_])
        );
        assert_eq!(c.ici.lossless, ClassSet::none().class("Event"));
        assert_eq!(c.dashboard, Some("127.0.0.1:8080".parse().unwrap()));
        assert_eq!(c.dashboard_token.as_deref(), Some("0123456789abcdef0123"));
        assert_eq!(c.security, Some(PathBuf::from("/etc/slate/team-keys")));
        assert_eq!(c.zenoh.mode, Mode::Router);
        assert_eq!(c.zenoh.file, Some(PathBuf::from("/etc/slate/zenoh.json5")));
        assert!(c.zenoh.multicast_scouting);
        assert!(!c.zenoh.udp_reports);
        assert_eq!(c.zenoh.connect, ["tcp/127.0.0.1:7448"]);
        assert_eq!(c.ici.robot.timeout, Duration::from_millis(500));
        assert_eq!(c.ici.team.heartbeat, Duration::from_secs(2));
        assert_eq!(c.ici.quiet, Duration::from_millis(250));
        assert_eq!(c.ici.gap_grace, Duration::from_millis(50));
        assert_eq!(c.ici.linger, Duration::ZERO);
        assert_eq!(
            (
                c.ici.max_objects_per_source,
                c.ici.max_objects,
                c.ici.max_modules,
                c.ici.max_names_per_source,
                c.ici.max_names
            ),
            (50, 500, 20, 300, 9000)
        );
        assert_eq!(c.ici.max_answer_bytes_per_requester, 5000);
        assert_eq!(c.ici.catch_up_retry, Duration::from_secs(1));
        assert_eq!(c.ici.team_report_every, None, "0s: every value at once");
        assert_eq!((c.ici.max_report_items, c.ici.max_tombstones), (64, 100));
    }

    #[test]
    fn robots_speak_on_the_team_link_when_ici_speakers_is_robots() {
        let plain = parse("address = \"t/r1/nav\"").unwrap();
        assert_eq!(
            plain.ici.team_protocol, None,
            "every module speaks by default"
        );
        let c = parse("address = \"t/r1/nav\"\n[ici]\nspeakers = \"robots\"").unwrap();
        assert_eq!(c.ici.team_protocol, Some(TeamProtocol::radio()));
        let c = parse(
            r#"
            address = "t/r1/nav"
            [ici]
            speakers = "robots"
            team_preset = "acoustic"
            gateway_priority = 3
            team_rate = 200
            "#,
        )
        .unwrap();
        let mut expected = TeamProtocol::acoustic().priority(Some(3));
        expected.rate_bps = 200;
        assert_eq!(c.ici.team_protocol, Some(expected));
        let c =
            parse("address = \"t/r1/nav\"\n[ici]\nspeakers = \"robots\"\ngateway = false").unwrap();
        assert_eq!(c.ici.team_protocol.and_then(|p| p.priority), None);
    }

    #[test]
    fn team_protocol_keys_without_robots_speaking_or_out_of_range_are_refused() {
        let cases = [
            (
                "speakers = \"gateways\"",
                "key `ici.speakers`: expected \"modules\" or \"robots\", found \"gateways\"",
            ),
            (
                "team_preset = \"acoustic\"",
                "key `ici.team_preset`: expected speakers = \"robots\" beside it",
            ),
            (
                "speakers = \"robots\"\ngateway_priority = 256",
                "key `ici.gateway_priority`: expected an integer from 0 to 255, found integer 256",
            ),
            (
                "speakers = \"robots\"\nteam_rate = 0",
                "key `ici.team_rate`: expected a positive integer",
            ),
        ];
        for (ici, expected) in cases {
            let err = parse(&format!("address = \"t/r1/nav\"\n[ici]\n{ici}"))
                .unwrap_err()
                .to_string();
            assert!(err.contains(expected), "{ici}: {err}");
        }
    }

    #[test]
    fn defaults_are_peer_mode_everything_in_nothing_out() {
        let c = parse("address = \"t/r1/nav\"").unwrap();
        assert_eq!(c, NodeConfig::new(Address::new("t/r1/nav").unwrap()));
        assert!(!c.zenoh.multicast_scouting);
        assert!(
            c.zenoh.udp_reports,
            "a node's team reports go over UDP beside TCP"
        );
        let set = parse("address = \"t/r1/nav\"\n[zenoh]\nlisten = []").unwrap();
        assert!(set.zenoh.udp_reports, "a [zenoh] table keeps the default");
        assert_eq!(c.ici.team_report_every, Some(TEAM_REPORT_EVERY));
        assert!(c.ici.interest.is_all());
        assert!(c.ici.export.is_empty());
        assert!(c.ici.lossless.is_empty());
    }

    #[test]
    fn errors_name_the_file_the_key_and_what_is_expected() {
        let cases = [
            (
                "",
                "m.toml: missing key `address`: expected a module address",
            ),
            (
                "address = 3",
                "m.toml: key `address`: expected a module address \"team/robot/module\", found integer 3",
            ),
            (
                "address = \"nav\"",
                "m.toml: key `address`: expected a module address",
            ),
            (
                "address = \"t/r/m\"\nlisen = 1",
                "m.toml: unknown key `lisen` (known keys: address, files",
            ),
            (
                "address = \"t/r/m\"\n[zenoh]\nmode = \"mesh\"",
                "m.toml: key `zenoh.mode`: expected \"peer\", \"router\" or \"client\", found \"mesh\"",
            ),
            (
                "address = \"t/r/m\"\n[zenoh]\nlisten = [\"7447\"]",
                "m.toml: key `zenoh.listen`: expected a list of Zenoh endpoints",
            ),
            (
                "address = \"t/r/m\"\n[zenoh]\nport = 1",
                "m.toml: unknown key `zenoh.port` (known keys: zenoh.mode, zenoh.listen",
            ),
            (
                "address = \"t/r/m\"\nzenoh = 1",
                "m.toml: key `zenoh`: expected a table, found integer 1",
            ),
            (
                "address = \"t/r/m\"\ninterest = [\"Obstacle:nearby\"]",
                "m.toml: key `interest`: expected a list of class names",
            ),
            (
                "address = \"t/r/m\"\nexport = \"Vehicle\"",
                "m.toml: key `export`: expected a list of class names",
            ),
            (
                "address = \"t/r/m\"\ndashboard = \"localhost\"",
                "m.toml: key `dashboard`: expected an address to serve the dashboard on",
            ),
            (
                "address = \"t/r/m\"\ndashboard_token = \"short\"",
                "m.toml: key `dashboard_token`: expected a token of at least 16",
            ),
            (
                "address = \"t/r/m\"\nfoxglove = \"localhost\"",
                "m.toml: key `foxglove`: expected an address to serve Foxglove's WebSocket protocol on",
            ),
            (
                "address = \"t/r/m\"\n[ici]\nquiet = 5",
                "m.toml: key `ici.quiet`: expected a duration like \"250ms\"",
            ),
            (
                "address = \"t/r/m\"\n[ici]\nrobot_timeout = \"100ms\"",
                "m.toml: key `ici.robot_timeout`: expected a duration longer than robot_heartbeat",
            ),
            (
                "address = \"t/r/m\"\n[ici]\nmax_report_items = 0",
                "m.toml: key `ici.max_report_items`: expected a positive integer, found integer 0",
            ),
            (
                "address = \"t/r/m\"\nfiles = [1]",
                "m.toml: key `files`: expected a list of .slate file paths, each a string or",
            ),
            ("address = \"t/r/m\"\n\nfiles = [", "m.toml:3:"),
        ];
        for (text, expected) in cases {
            let err = parse(text).unwrap_err().to_string();
            assert!(
                err.starts_with(expected),
                "{text:?}\n  gave {err}\n  want {expected}"
            );
            assert!(!err.contains('\n'), "one line: {err}");
        }
    }

    #[test]
    fn a_dashboard_given_a_port_only_is_served_on_loopback() {
        let c = parse("address = \"t/r/m\"\ndashboard = \"8080\"").unwrap();
        assert_eq!(c.dashboard, Some("127.0.0.1:8080".parse().unwrap()));
    }

    #[test]
    fn record_names_the_file_and_recording_its_rotation() {
        let c = parse(
            r#"
            address = "t/r1/nav"
            record = "runs/nav.mcap"
            [recording]
            max_bytes = 1000000
            max_duration = "10min"
            flush = "250ms"
            stats = "2s"
            queue = 1024
            "#,
        )
        .unwrap();
        let r = c.record.unwrap();
        assert_eq!(r.path, PathBuf::from("/etc/slate/runs/nav.mcap"));
        assert_eq!(r.max_bytes, Some(1_000_000));
        assert_eq!(r.max_duration, Some(Duration::from_secs(600)));
        assert_eq!(r.flush_every, Duration::from_millis(250));
        assert_eq!(r.stats_every, Duration::from_secs(2));
        assert_eq!(r.queue, 1024);
        let plain = parse("address = \"t/r/m\"\nrecord = \"/abs/x.mcap\"").unwrap();
        assert_eq!(plain.record, Some(RecordConfig::new("/abs/x.mcap")));
    }

    #[test]
    fn state_names_the_directory_and_storage_when_it_commits() {
        let c = parse(
            r#"
            address = "t/r1/nav"
            state = "state/nav"
            [storage]
            commit_every = "250ms"
            commit_changes = 100
            queue = 512
            durability = "eventual"
            "#,
        )
        .unwrap();
        let s = c.state.unwrap();
        assert_eq!(s.dir, PathBuf::from("/etc/slate/state/nav"));
        assert_eq!(s.commit_every, Duration::from_millis(250));
        assert_eq!(s.commit_changes, 100);
        assert_eq!(s.queue, 512);
        assert_eq!(s.durability, crate::state::Durability::Eventual);
        let plain = parse("address = \"t/r/m\"\nstate = \"/var/s\"").unwrap();
        assert_eq!(plain.state, Some(StateConfig::new("/var/s")));
    }

    #[test]
    fn storage_without_state_or_with_an_unknown_durability_is_refused() {
        let err = parse("address = \"t/r/m\"\n[storage]\nqueue = 5")
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with("m.toml: key `storage`: expected `state = \"DIR\"` beside it"),
            "{err}"
        );
        let err = parse("address = \"t/r/m\"\nstate = \"s\"\n[storage]\ndurability = \"always\"")
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with(
                "m.toml: key `storage.durability`: expected \"immediate\" or \"eventual\""
            ),
            "{err}"
        );
    }

    #[test]
    fn recording_settings_without_record_are_refused() {
        let err = parse("address = \"t/r/m\"\n[recording]\nqueue = 5")
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with("m.toml: key `recording`: expected `record = \"FILE.mcap\"` beside it"),
            "{err}"
        );
        let err = parse("address = \"t/r/m\"\nrecord = 3")
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with("m.toml: key `record`: expected a file to record to"),
            "{err}"
        );
    }

    #[test]
    fn a_missing_file_is_named() {
        let err = NodeConfig::read(Path::new("/nonexistent/m.toml")).unwrap_err();
        assert!(
            err.to_string()
                .starts_with("/nonexistent/m.toml: cannot read"),
            "{err}"
        );
    }
}
