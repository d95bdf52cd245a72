//! The team file `slate launch` reads (docs/launch.md): robots, the kinds of module
//! each runs, and from them one `slate node` config per module, in exactly the form
//! `slate node --config` reads (docs/config.md), checked by the same parser.

use std::path::{Path, PathBuf};
use std::time::Duration;

use slate_node::NodeConfig;
use slate_plans::{ROBOT_PLACEHOLDER, Substitution};
use toml::{Table, Value};

/// Keys of the team file's top table.
const TOP: &[&str] = &[
    "team",
    "base_port",
    "host",
    "placeholder",
    "restart",
    "kinds",
    "robots",
    "keys",
];
/// What the team file's `keys` holds.
const KEYS_EXPECTED: &str = "`keys` must be the team's keys folder made by `slate keys`, relative to the team file, like \"team-keys\"";
/// Keys of a `[[robots]]` entry.
const ROBOT: &[&str] = &["name", "host", "modules"];
/// Keys a kind may hold beside `slate node`'s own.
const PER_ROBOT: &str = "per_robot";
/// Longest wait between two restarts of a module.
pub const MAX_BACKOFF: Duration = Duration::from_secs(30);

/// A team file that cannot be used: where, and what to do about it. One line.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum TeamError {
    /// The file could not be read, or is not valid TOML (as for a node's config).
    #[error(transparent)]
    File(#[from] slate_node::ConfigError),
    /// A value is wrong: where (`FILE:LINE`), what, and what to do.
    #[error("{at}: {message}")]
    Invalid {
        /// `FILE:LINE` of the entry at fault (the file alone when no line applies).
        at: String,
        /// What is wrong and what to do.
        message: String,
    },
}

/// How a module that dies is started again.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Restart {
    /// Restarts of one module before launch gives up on it.
    pub limit: u32,
    /// The first wait before a restart; each restart doubles it, up to [`MAX_BACKOFF`].
    pub backoff: Duration,
}

impl Default for Restart {
    fn default() -> Self {
        Restart {
            limit: 5,
            backoff: Duration::from_millis(500),
        }
    }
}

/// One module of the team: its robot, its kind, and the config it runs with.
#[derive(Clone, Debug)]
pub struct ModulePlan {
    /// `ROBOT/KIND`, as `--only` names it.
    pub name: String,
    /// The robot it belongs to.
    pub robot: String,
    /// The config text written for `slate node --config`.
    pub config_text: String,
    /// That text as `slate node` reads it.
    pub config: NodeConfig,
    /// The host it listens on.
    pub host: String,
    /// Its Zenoh port.
    pub port: u16,
    /// `FILE:LINE` of its kind, for errors about it.
    pub at: String,
}

/// A team file, read and expanded into its modules.
#[derive(Clone, Debug)]
pub struct Team {
    /// The team's name: the first part of every address.
    pub name: String,
    /// Every module, robots in file order, each robot's modules in its order.
    pub modules: Vec<ModulePlan>,
    /// The restart policy.
    pub restart: Restart,
    /// The team file.
    pub file: PathBuf,
}

/// A `[[robots]]` entry, as read from the file.
struct Robot {
    name: String,
    host: String,
    modules: Vec<String>,
}

/// The file's text and name, for locating entries in errors.
struct Source<'a> {
    file: &'a str,
    text: &'a str,
}

impl Source<'_> {
    /// `FILE:LINE` of the first line holding every one of `needles` (ignoring spaces), or
    /// the file alone.
    fn at(&self, needles: &[&str]) -> String {
        let found = self.text.lines().position(|l| {
            let l = without_spaces(l);
            needles.iter().all(|n| l.contains(&without_spaces(n)))
        });
        match found {
            Some(i) => format!("{}:{}", self.file, i + 1),
            None => self.file.to_owned(),
        }
    }

    fn invalid(&self, needles: &[&str], message: impl Into<String>) -> TeamError {
        TeamError::Invalid {
            at: self.at(needles),
            message: message.into(),
        }
    }
}

impl Team {
    /// Reads and expands a team file; `base_port` and `keys`, if given, replace the
    /// file's.
    pub fn read(
        path: &Path,
        base_port: Option<u16>,
        keys: Option<&Path>,
    ) -> Result<Team, TeamError> {
        let (file, text) = slate_node::read_text(path)?;
        let base = path.parent().unwrap_or_else(|| Path::new("."));
        let base = std::path::absolute(base).unwrap_or_else(|_| base.to_path_buf());
        let source = Source {
            file: &file,
            text: &text,
        };
        let keys = keys.map(|k| std::path::absolute(k).unwrap_or_else(|_| k.to_path_buf()));
        let mut team = Team::parse(&source, &base, path, (base_port, keys))?;
        team.file = path.to_path_buf();
        Ok(team)
    }

    /// Parses the file; `port` and `keys`, if given, replace the file's.
    fn parse(
        src: &Source,
        base: &Path,
        path: &Path,
        (port, keys): (Option<u16>, Option<PathBuf>),
    ) -> Result<Team, TeamError> {
        let mut top: Table = slate_node::parse_toml(src.file, src.text)?;
        if let Some(key) = top.keys().find(|k| !TOP.contains(&k.as_str())) {
            let known = TOP.join(", ");
            return Err(src.invalid(
                &[&format!("{key}=")],
                format!("unknown key `{key}` (known keys: {known})"),
            ));
        }
        let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("team");
        let name = string_or(src, &mut top, "team", stem)?;
        let host = string_or(src, &mut top, "host", "127.0.0.1")?;
        let placeholder = string_or(src, &mut top, "placeholder", ROBOT_PLACEHOLDER)?;
        let base_port = match port {
            Some(p) => {
                top.remove("base_port");
                p
            }
            None => base_port(src, &mut top)?,
        };
        let file_keys = string_or(src, &mut top, "keys", "")
            .map_err(|_| src.invalid(&["keys="], KEYS_EXPECTED))?;
        let keys = keys.or_else(|| (!file_keys.is_empty()).then(|| base.join(file_keys)));
        let restart = restart(src, top.remove("restart"))?;
        let kinds = match top.remove("kinds") {
            Some(Value::Table(k)) if !k.is_empty() => k,
            _ => return Err(src.invalid(&["[kinds"], "expected `[kinds.NAME]` tables, one per kind of module, each with `slate node`'s config keys (docs/config.md)")),
        };
        let robots = robots(src, top.remove("robots"), &host, &kinds)?;
        let layout = Layout {
            team: &name,
            placeholder: &placeholder,
            base,
            base_port,
            robots: &robots,
            keys: keys.as_deref(),
        };
        let modules = layout.modules(src, &kinds)?;
        Ok(Team {
            name,
            modules,
            restart,
            file: PathBuf::new(),
        })
    }
}

fn without_spaces(text: &str) -> String {
    text.chars().filter(|c| !c.is_whitespace()).collect()
}

fn string_or(src: &Source, top: &mut Table, key: &str, default: &str) -> Result<String, TeamError> {
    match top.remove(key) {
        None => Ok(default.to_owned()),
        Some(Value::String(s)) if !s.is_empty() => Ok(s),
        Some(_) => Err(src.invalid(
            &[&format!("{key}=")],
            format!("`{key}` must be a non-empty string"),
        )),
    }
}

/// `base_port`: module n of the file listens on `base_port + n`.
fn base_port(src: &Source, top: &mut Table) -> Result<u16, TeamError> {
    let fix = "`base_port` must be a port number, 1 to 65535: module n of the file (robots in order, each robot's modules in order) listens on base_port + n";
    match top.remove("base_port") {
        Some(Value::Integer(n)) => u16::try_from(n)
            .ok()
            .filter(|p| *p > 0)
            .ok_or_else(|| src.invalid(&["base_port="], fix)),
        _ => Err(src.invalid(&["base_port="], fix)),
    }
}

fn restart(src: &Source, value: Option<Value>) -> Result<Restart, TeamError> {
    let mut r = Restart::default();
    let Some(value) = value else { return Ok(r) };
    let Value::Table(mut t) = value else {
        return Err(src.invalid(
            &["restart="],
            "`restart` must be a table: [restart] limit = 5, backoff = \"500ms\"",
        ));
    };
    match t.remove("limit") {
        None => {}
        Some(Value::Integer(n)) if n >= 0 => r.limit = u32::try_from(n).unwrap_or(u32::MAX),
        Some(_) => {
            return Err(src.invalid(
                &["limit="],
                "`restart.limit` must be a whole number of restarts, 0 or more",
            ));
        }
    }
    match t.remove("backoff") {
        None => {}
        Some(Value::String(s)) => {
            r.backoff = slate_node::parse_duration(&s)
                .filter(|d| !d.is_zero())
                .ok_or_else(|| {
                    src.invalid(
                        &["backoff="],
                        format!(
                            "`restart.backoff` {s:?}: expected a duration like \"500ms\" or \"2s\""
                        ),
                    )
                })?;
        }
        Some(_) => {
            return Err(src.invalid(
                &["backoff="],
                "`restart.backoff` must be a duration like \"500ms\"",
            ));
        }
    }
    if let Some(key) = t.keys().next() {
        return Err(src.invalid(
            &[&format!("{key}=")],
            format!("unknown key `restart.{key}` (known keys: restart.limit, restart.backoff)"),
        ));
    }
    Ok(r)
}

/// The `[[robots]]` entries, checked: names unique and usable in an address, modules
/// that are kinds of the file, hosts given or the team's.
fn robots(
    src: &Source,
    value: Option<Value>,
    host: &str,
    kinds: &Table,
) -> Result<Vec<Robot>, TeamError> {
    let usage = "expected `[[robots]]` entries: name = \"r1\", modules = [\"nav\", ...], and optionally host";
    let Some(Value::Array(items)) = value else {
        return Err(src.invalid(&["[[robots]]"], usage));
    };
    let mut out: Vec<Robot> = Vec::new();
    for item in items {
        let Value::Table(mut t) = item else {
            return Err(src.invalid(&["robots"], usage));
        };
        let Some(Value::String(name)) = t.remove("name") else {
            return Err(src.invalid(
                &["[[robots]]"],
                format!("a robot without a string `name`: {usage}"),
            ));
        };
        let at = [format!("name=\"{name}\"")];
        let at = [at[0].as_str()];
        if slate_model::Address::new(&format!("t/{name}/m")).is_err() {
            return Err(src.invalid(&at, format!("robot name {name:?}: use letters, digits, _ and - (it is part of every address of the robot)")));
        }
        if out.iter().any(|r| r.name == name) {
            return Err(src.invalid(
                &at,
                format!("robot {name:?} is listed twice: give each robot its own name"),
            ));
        }
        let host = match t.remove("host") {
            None => host.to_owned(),
            Some(Value::String(h)) if valid_host(&h) => h,
            Some(_) => return Err(src.invalid(
                &at,
                format!(
                    "robot {name:?}: `host` must be a host name or IP address, like \"10.0.0.2\""
                ),
            )),
        };
        let modules = robot_modules(src, &at, &name, t.remove("modules"), kinds)?;
        if let Some(key) = t.keys().next() {
            let known = ROBOT.join(", ");
            return Err(src.invalid(
                &at,
                format!("robot {name:?}: unknown key `{key}` (known keys: {known})"),
            ));
        }
        out.push(Robot {
            name,
            host,
            modules,
        });
    }
    Ok(out)
}

fn robot_modules(
    src: &Source,
    at: &[&str],
    name: &str,
    value: Option<Value>,
    kinds: &Table,
) -> Result<Vec<String>, TeamError> {
    let Some(Value::Array(items)) = value else {
        return Err(src.invalid(
            at,
            format!(
                "robot {name:?}: `modules` must list kinds of module, like [\"nav\", \"loco\"]"
            ),
        ));
    };
    let known: Vec<&str> = kinds.keys().map(String::as_str).collect();
    let mut out: Vec<String> = Vec::new();
    for item in items {
        let Value::String(kind) = item else {
            return Err(src.invalid(at, format!("robot {name:?}: `modules` must be strings")));
        };
        if !kinds.contains_key(&kind) {
            return Err(src.invalid(
                at,
                format!(
                    "robot {name:?}: no kind {kind:?}: define `[kinds.{kind}]` or use one of {}",
                    known.join(", ")
                ),
            ));
        }
        if out.contains(&kind) {
            return Err(src.invalid(
                at,
                format!("robot {name:?} runs {kind:?} twice: a robot has one module of each kind"),
            ));
        }
        out.push(kind);
    }
    Ok(out)
}

/// A host name or address: not empty, no `/`, `:` only as in IPv6.
fn valid_host(host: &str) -> bool {
    !host.is_empty()
        && !host.contains(['/', ' '])
        && (host.parse::<std::net::Ipv6Addr>().is_ok() || !host.contains(':'))
}

/// What every module's config is made from.
struct Layout<'a> {
    team: &'a str,
    placeholder: &'a str,
    base: &'a Path,
    base_port: u16,
    robots: &'a [Robot],
    /// The team's keys folder (`keys`, `--keys`): every module runs secured with it.
    keys: Option<&'a Path>,
}

impl Layout<'_> {
    /// Every module with its config, in file order.
    fn modules(&self, src: &Source, kinds: &Table) -> Result<Vec<ModulePlan>, TeamError> {
        let slots: Vec<(&Robot, &str)> = self
            .robots
            .iter()
            .flat_map(|r| r.modules.iter().map(move |k| (r, k.as_str())))
            .collect();
        let endpoints = self.endpoints(src, &slots)?;
        let mut out = Vec::new();
        for (n, (robot, kind)) in slots.iter().enumerate() {
            let at = src.at(&[&format!("[kinds.{kind}")]);
            let table = kinds.get(*kind).cloned();
            let Some(Value::Table(table)) = table else {
                return Err(TeamError::Invalid {
                    at,
                    message: format!(
                        "kind {kind:?} must be a table of `slate node` config keys (docs/config.md)"
                    ),
                });
            };
            let connect: Vec<&String> = endpoints
                .iter()
                .enumerate()
                .filter(|(i, _)| *i != n)
                .map(|(_, e)| e)
                .collect();
            let config = self.config(robot, kind, table, &endpoints[n], &connect, &at)?;
            let config_text = config.to_string();
            let label = format!("{at} (module {}/{}/{kind})", self.team, robot.name);
            let parsed = NodeConfig::parse(&label, &config_text, self.base).map_err(|e| {
                TeamError::Invalid {
                    at: at.clone(),
                    message: format!(
                        "module {}/{kind}: {}",
                        robot.name,
                        strip_label(&e.to_string(), &label)
                    ),
                }
            })?;
            out.push(ModulePlan {
                name: format!("{}/{kind}", robot.name),
                robot: robot.name.clone(),
                config_text,
                config: parsed,
                host: robot.host.clone(),
                port: port_of(self.base_port, n).unwrap_or(0),
                at,
            });
        }
        Ok(out)
    }

    /// Each slot's listen endpoint, `tcp/HOST:PORT`.
    fn endpoints(&self, src: &Source, slots: &[(&Robot, &str)]) -> Result<Vec<String>, TeamError> {
        slots
            .iter()
            .enumerate()
            .map(|(n, (robot, _))| {
                let port = port_of(self.base_port, n).ok_or_else(|| {
                    src.invalid(
                        &["base_port="],
                        format!(
                            "base_port {} + {n} modules passes 65535: choose a lower base_port",
                            self.base_port
                        ),
                    )
                })?;
                let protocol = if self.keys.is_some() { "tls" } else { "tcp" };
                Ok(match robot.host.contains(':') {
                    true => format!("{protocol}/[{}]:{port}", robot.host),
                    false => format!("{protocol}/{}:{port}", robot.host),
                })
            })
            .collect()
    }

    /// One module's `slate node` config: its kind's keys, its address, its files with
    /// the robot's name substituted, and where it listens and connects.
    fn config(
        &self,
        robot: &Robot,
        kind: &str,
        mut table: Table,
        listen: &str,
        connect: &[&String],
        at: &str,
    ) -> Result<Table, TeamError> {
        let invalid = |message: String| TeamError::Invalid {
            at: at.to_owned(),
            message,
        };
        for owned in ["address"] {
            if table.contains_key(owned) {
                return Err(invalid(format!(
                    "kind {kind:?}: remove `{owned}`: launch gives each module the address TEAM/ROBOT/KIND"
                )));
            }
        }
        if table.contains_key("security") {
            return Err(invalid(format!(
                "kind {kind:?}: remove `[security]`: a team is secured as a whole, with `keys = \"DIR\"` at the top of the team file or `slate launch --keys DIR` (every module then listens and connects over tls/)"
            )));
        }
        let own = self.files(kind, table.remove("files"), &[robot.name.as_str()], at)?;
        let others: Vec<&str> = self
            .robots
            .iter()
            .filter(|r| r.name != robot.name)
            .map(|r| r.name.as_str())
            .collect();
        let per_robot = self.files(kind, table.remove(PER_ROBOT), &others, at)?;
        let zenoh = zenoh_table(kind, table.remove("zenoh"), listen, connect).map_err(invalid)?;
        let mut config = Table::new();
        config.insert(
            "address".into(),
            Value::String(format!("{}/{}/{kind}", self.team, robot.name)),
        );
        config.insert(
            "files".into(),
            Value::Array(own.into_iter().chain(per_robot).collect()),
        );
        config.extend(table);
        config.insert("zenoh".into(), Value::Table(zenoh));
        if let Some(keys) = self.keys {
            let mut security = Table::new();
            security.insert("keys".into(), Value::String(keys.display().to_string()));
            config.insert("security".into(), Value::Table(security));
        }
        self.absolute(&mut config, "zenoh_config");
        self.own_state(&mut config, &robot.name, kind);
        Ok(config)
    }

    /// Makes a kind's `state = "DIR"` the module's own folder in it, `DIR/ROBOT/KIND`
    /// (DIR relative to the team file): a store holds one module's board and refuses
    /// another's, so the modules of a kind must not share one.
    fn own_state(&self, config: &mut Table, robot: &str, kind: &str) {
        if let Some(Value::String(dir)) = config.get_mut("state") {
            let own = self.base.join(&*dir).join(robot).join(kind);
            *dir = own.display().to_string();
        }
    }

    /// Makes a path-valued key absolute (relative to the team file): the config is
    /// written, and read by `slate node`, in the log folder.
    fn absolute(&self, config: &mut Table, key: &str) {
        if let Some(Value::String(path)) = config.get_mut(key) {
            *path = self.base.join(&*path).display().to_string();
        }
    }

    /// `files` (or `per_robot`) of a kind, once for each robot of `robots`, as the
    /// config's `{ path, substitute }` entries with absolute paths.
    fn files(
        &self,
        kind: &str,
        value: Option<Value>,
        robots: &[&str],
        at: &str,
    ) -> Result<Vec<Value>, TeamError> {
        let invalid = || TeamError::Invalid {
            at: at.to_owned(),
            message: format!(
                "kind {kind:?}: `files` and `per_robot` must list .slate file paths, relative to the team file"
            ),
        };
        let paths = match value {
            None => Vec::new(),
            Some(Value::Array(items)) => items
                .into_iter()
                .map(|i| match i {
                    Value::String(s) => Ok(s),
                    _ => Err(invalid()),
                })
                .collect::<Result<Vec<_>, _>>()?,
            Some(_) => return Err(invalid()),
        };
        let mut out = Vec::new();
        for path in &paths {
            for robot in robots {
                Substitution::new([(self.placeholder, *robot)]).map_err(|e| {
                    TeamError::Invalid {
                        at: at.to_owned(),
                        message: format!("robot {robot:?}: {e}"),
                    }
                })?;
                let mut substitute = Table::new();
                substitute.insert(
                    self.placeholder.to_owned(),
                    Value::String((*robot).to_owned()),
                );
                let mut entry = Table::new();
                entry.insert(
                    "path".into(),
                    Value::String(self.base.join(path).display().to_string()),
                );
                entry.insert("substitute".into(), Value::Table(substitute));
                out.push(Value::Table(entry));
            }
        }
        Ok(out)
    }
}

/// A kind's `[zenoh]` table with the module's `listen` and `connect`, which launch owns.
fn zenoh_table(
    kind: &str,
    value: Option<Value>,
    listen: &str,
    connect: &[&String],
) -> Result<Table, String> {
    let mut zenoh = match value {
        None => Table::new(),
        Some(Value::Table(t)) => t,
        Some(_) => return Err(format!("kind {kind:?}: `zenoh` must be a table")),
    };
    for owned in ["listen", "connect"] {
        if zenoh.contains_key(owned) {
            return Err(format!(
                "kind {kind:?}: remove `zenoh.{owned}`: launch gives each module its endpoint (base_port) and connects it to the others"
            ));
        }
    }
    let strings =
        |v: &[&String]| Value::Array(v.iter().map(|s| Value::String((*s).clone())).collect());
    zenoh.insert(
        "listen".into(),
        Value::Array(vec![Value::String(listen.to_owned())]),
    );
    zenoh.insert("connect".into(), strings(connect));
    Ok(zenoh)
}

fn port_of(base: u16, n: usize) -> Option<u16> {
    u16::try_from(n).ok().and_then(|n| base.checked_add(n))
}

/// `slate node`'s error without the label it starts with (the caller says where).
fn strip_label(message: &str, label: &str) -> String {
    message
        .strip_prefix(label)
        .map(|m| m.trim_start_matches(':').trim_start().to_owned())
        .unwrap_or_else(|| message.to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A team file in a fresh folder (removed when the guard is dropped); its path.
    fn team_file(name: &str, text: &str) -> (slate_testing::TempDir, PathBuf) {
        let dir = slate_testing::temp_dir(&format!("team-{name}"));
        let path = dir.join("team.toml");
        std::fs::write(&path, text).unwrap();
        (dir, path)
    }

    const TWO_ROBOTS: &str = "base_port = 7000\n[kinds.nav]\nfiles = [\"robot.slate\"]\nzenoh_config = \"zenoh.json5\"\n[kinds.console]\nper_robot = [\"robot.slate\"]\n[[robots]]\nname = \"r1\"\nmodules = [\"nav\"]\n[[robots]]\nname = \"base\"\nhost = \"10.0.0.9\"\nmodules = [\"console\"]\n";

    #[test]
    fn each_module_gets_its_address_port_files_and_the_others_endpoints() {
        let (_dir, path) = team_file("layout", TWO_ROBOTS);
        let team = Team::read(&path, None, None).unwrap();
        let dir = path.parent().unwrap();
        let [nav, console] = &team.modules[..] else {
            panic!("{:?}", team.modules)
        };
        assert_eq!(nav.config.address.as_str(), "team/r1/nav");
        assert_eq!(nav.config.zenoh.listen, ["tcp/127.0.0.1:7000"]);
        assert_eq!(nav.config.zenoh.connect, ["tcp/10.0.0.9:7001"]);
        assert_eq!(console.config.zenoh.listen, ["tcp/10.0.0.9:7001"]);
        let robots = |m: &ModulePlan| -> Vec<String> {
            let f = &m.config.files;
            f.iter().map(|f| f.substitute.apply("ROBOT")).collect()
        };
        assert_eq!(robots(nav), ["r1"]);
        assert_eq!(robots(console), ["r1"]);
        assert_eq!(nav.config.files[0].path, dir.join("robot.slate"));
        let moved = Team::read(&path, Some(8000), None).unwrap();
        assert_eq!(moved.modules[1].config.zenoh.listen, ["tcp/10.0.0.9:8001"]);
    }

    #[test]
    fn a_kinds_zenoh_config_is_found_from_the_team_files_folder() {
        let (_dir, path) = team_file("zenoh", TWO_ROBOTS);
        let team = Team::read(&path, None, None).unwrap();
        let dir = path.parent().unwrap();
        // The written config is read from the log folder, elsewhere.
        let written = NodeConfig::parse("x", &team.modules[0].config_text, Path::new("/logs"));
        let expected = dir.join("zenoh.json5");
        assert_eq!(
            written.unwrap().zenoh.file.as_deref(),
            Some(expected.as_path())
        );
    }

    #[test]
    fn a_kinds_state_folder_gives_each_module_a_folder_of_its_own() {
        let text = "base_port = 7000\n[kinds.nav]\nstate = \"kept\"\n[[robots]]\nname = \"r1\"\nmodules = [\"nav\"]\n[[robots]]\nname = \"r2\"\nmodules = [\"nav\"]\n";
        let (_dir, path) = team_file("state", text);
        let team = Team::read(&path, None, None).unwrap();
        let dir = path.parent().unwrap();
        let state = |m: &ModulePlan| m.config.state.as_ref().map(|s| s.dir.clone());
        assert_eq!(state(&team.modules[0]), Some(dir.join("kept/r1/nav")));
        assert_eq!(state(&team.modules[1]), Some(dir.join("kept/r2/nav")));
        // The written config names the same folder, from wherever it is read.
        let written = NodeConfig::parse("x", &team.modules[1].config_text, Path::new("/logs"));
        let written = written.unwrap().state.map(|s| s.dir);
        assert_eq!(written, Some(dir.join("kept/r2/nav")));
    }

    #[test]
    fn a_team_with_keys_runs_every_module_over_tls_with_them() {
        let (_dir, path) = team_file("keys", &format!("keys = \"team-keys\"\n{TWO_ROBOTS}"));
        let dir = path.parent().unwrap();
        let team = Team::read(&path, None, None).unwrap();
        let [nav, console] = &team.modules[..] else {
            panic!("{:?}", team.modules)
        };
        assert_eq!(nav.config.zenoh.listen, ["tls/127.0.0.1:7000"]);
        assert_eq!(nav.config.zenoh.connect, ["tls/10.0.0.9:7001"]);
        assert_eq!(console.config.security, Some(dir.join("team-keys")));
        let given = Team::read(&path, None, Some(Path::new("/srv/keys"))).unwrap();
        assert_eq!(
            given.modules[0].config.security,
            Some(PathBuf::from("/srv/keys")),
            "--keys wins over the file's"
        );
    }

    #[test]
    fn a_kind_with_its_own_security_is_refused_and_told_to_use_the_teams_keys() {
        let text = TWO_ROBOTS.replace(
            "[kinds.console]",
            "[kinds.nav.security]\nkeys = \"k\"\n[kinds.console]",
        );
        let (_dir, path) = team_file("kind-keys", &text);
        let err = Team::read(&path, None, None).unwrap_err().to_string();
        assert!(err.contains("remove `[security]`"), "{err}");
        assert!(err.contains("`keys = \"DIR\"`"), "{err}");
    }
}
