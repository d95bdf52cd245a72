//! Command-line definitions (clap). `main.rs` dispatches; each verb lives in `command/`.

use clap::{Parser, Subcommand, ValueEnum};

/// slate: a distributed blackboard world model for robot modules and teams of robots.
#[derive(Debug, Parser)]
#[command(name = "slate", version, about, long_about = None)]
pub struct Cli {
    /// Output format: readable text, or one JSON object for scripts (one per line for
    /// `watch`, `plan send` and `node`).
    #[arg(long, global = true, value_enum, default_value_t = Format::Text)]
    pub format: Format,

    /// Log filter for stderr, like `info` or `warn,slate_ici=debug` (default: `RUST_LOG`,
    /// else slate's news and Zenoh's warnings for `slate node`, errors for the other verbs).
    #[arg(long, global = true, value_name = "FILTER")]
    pub log: Option<String>,

    /// How log lines on stderr are written: readable text, or one JSON object per line
    /// (tracing-subscriber's JSON: timestamp, level, target, fields with the message).
    #[arg(long, global = true, value_enum, default_value_t = LogFormat::Text)]
    pub log_format: LogFormat,

    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Output format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Format {
    /// Human-readable text.
    Text,
    /// JSON: one object (one per line for the verbs that stream).
    Json,
}

/// How log lines are written.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum LogFormat {
    /// Human-readable lines.
    Text,
    /// One JSON object per line.
    Json,
}

/// The verbs.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Measure slate's hot paths against a baseline measured in the same run.
    ///
    /// Prints the median time per operation and its ratio to the baseline. Build with
    /// `--release`; debug builds are 10-50x slower and say so.
    ///
    /// Example: slate bench core --format json
    /// Example: slate bench net --secure
    Bench(BenchArgs),

    /// Check .slate files: syntax, names, types. Prints every error with its line and
    /// column; exits 0 when every file is valid and 1 otherwise.
    ///
    /// Files are loaded in order into one scratch board, so a file may use the classes of
    /// the files before it.
    ///
    /// Example: slate check examples/gsr.slate
    Check(CheckArgs),

    /// Run the multi-robot demo: three robots (five boards each) and an operator console
    /// on a simulated world, coordinated through slate; prints a summary.
    ///
    /// Example: slate demo --seed 3 --dashboard 127.0.0.1:8080
    Demo(crate::command::demo::DemoArgs),

    /// One module of `slate demo --network processes`, started by it (docs/demo.md, "As
    /// processes"): not meant to be typed.
    #[command(hide = true)]
    DemoModule(crate::command::demo::DemoModuleArgs),

    /// Make a team's keys: a certificate authority, then a key and certificate for each
    /// module and operator, for a secured team (TLS with mutual authentication, and
    /// each identity allowed to speak only in its own name; docs/security.md).
    ///
    /// Example: slate keys init team-keys
    ///
    /// Example: slate keys issue team-keys team/r1/nav team/r2/loco team/alice
    #[command(subcommand)]
    Keys(KeysCommand),

    /// Run a team of modules from one file: one `slate node` process each, supervised.
    ///
    /// The team file lists robots and the kinds of module each runs; launch writes each
    /// module's `slate node` config (address TEAM/ROBOT/KIND, its port, its .slate files
    /// with the robot's name in place of ROBOT) into the log folder, starts the modules,
    /// writes each one's output to ROBOT-KIND.log and to the console prefixed with its
    /// address, starts a module that dies again after a back-off that doubles (up to the
    /// file's limit, then gives up on it and says so), and stops them all on Ctrl-C or
    /// SIGTERM. Exits 2 if a module cannot start, 1 once it has given up on every module.
    /// The format is in docs/launch.md.
    ///
    /// Example: slate launch examples/teams/small.toml --check
    ///
    /// Example: slate launch examples/teams/small.toml --robot r2
    Launch(crate::command::launch::LaunchArgs),

    /// Run one module: its board, plan engine and ICI over Zenoh, from a TOML config.
    ///
    /// The config names the module's address, its Zenoh endpoints, the .slate files it
    /// loads, its interest, export policy and optional dashboard (every key is in
    /// docs/config.md). The node logs where it listens and every peer that comes up or goes
    /// down, and runs until SIGINT (Ctrl-C) or SIGTERM; then it flushes what is in flight,
    /// leaves the network and exits 0. It prints one line when it is ready (with `--format
    /// json`, one JSON object) and one when it stops.
    ///
    /// With `state = "DIR"` in the config, the node keeps its board in DIR and restores it
    /// when it starts again, before it joins the team; a kill -9 loses at most the last
    /// `storage.commit_every` (100 ms) of changes. A damaged store stops the start with an
    /// error; --reset-state moves it aside.
    ///
    /// Example: slate node --config nav.toml --log info,slate_ici=debug
    ///
    /// Example: slate node --config nav.toml --foxglove 127.0.0.1:8765
    Node(NodeArgs),

    /// Print the class tree of a live team, or of .slate files.
    ///
    /// With files, they are loaded in order into a scratch board (no network). Without,
    /// the command joins the team as a short-lived observer and prints the classes its
    /// modules have, with their attributes and how many objects each has.
    ///
    /// Example: slate tree examples/gsr.slate
    ///
    /// Example: slate tree --connect tcp/127.0.0.1:7447
    Tree(TreeArgs),

    /// List the objects of a class (and of its subclasses) on a live team.
    ///
    /// Prints each object's name, class, context and owner. `slate ls Module` lists the
    /// modules seen, `slate ls Plan` the plans; `slate ls Thing` everything.
    ///
    /// Example: slate ls Obstacle
    Ls(LsArgs),

    /// Read an object's packets on a live team: value, accuracy, confidence, age, source.
    ///
    /// `OBJ` prints every attribute that has a value; `OBJ.ATTR` one attribute. A class
    /// name reads its class-level values.
    ///
    /// Example: slate get gsr
    ///
    /// Example: slate get gsr.position --format json
    Get(GetArgs),

    /// Write one attribute on a live team: the packet goes to every module interested.
    ///
    /// VALUE is read as the attribute's declared type: `2.5`, `3`, `true`, `auto`, `&gsr`
    /// (a reference), `[10.0, 20.5]` (a vector). The writer (the packet's source) is the
    /// observer, `TEAM/ROBOT/cli-PID`. An `owned` attribute is refused: only its owner may
    /// write it.
    ///
    /// Example: slate put gsr.mode manual --confidence 0.9
    Put(PutArgs),

    /// Watch a live team's changes, one line each, until Ctrl-C or `--count` lines.
    ///
    /// PATTERN is `*` (everything but the Module objects), a class (its instances and
    /// subclasses), an object, or either with `.ATTR`; `*.ATTR` watches one attribute on
    /// every object. Creations and deletions always show.
    ///
    /// Example: slate watch Vehicle
    ///
    /// Example: slate watch gsr.speed --count 5 --format json
    Watch(WatchArgs),

    /// Send plans to modules of a live team, list them, cancel them.
    ///
    /// Example: slate plan send patrol.slate --to team/r2/loco
    #[command(subcommand)]
    Plan(PlanCommand),

    /// Record a live team's world model to an MCAP file, as an observer, until Ctrl-C.
    ///
    /// The file starts with the team's current state (classes, objects and their
    /// packets), then holds every packet written, objects created and deleted, plan
    /// events, circuit steps, modules going up and down, and link counters each second:
    /// one channel per class with a JSON schema, readable by Foxglove or any MCAP reader
    /// (docs/recording.md). PATTERNs (classes or objects) keep only those; default:
    /// everything. Progress (messages and bytes) goes to stderr; Ctrl-C or `--for`
    /// finishes the file cleanly. A node records its own board with `record = "FILE"` in
    /// its config instead.
    ///
    /// Example: slate record -o field-day.mcap
    ///
    /// Example: slate record -o vehicles.mcap Vehicle Obstacle --max-size-mb 512
    Record(RecordArgs),

    /// Show each module's counters: messages and bytes per second per link and message
    /// kind, drops, catch-ups, peers.
    ///
    /// Asks every module reachable through `--connect` (or only ADDR: TEAM, TEAM/ROBOT or
    /// TEAM/ROBOT/MODULE) for its ICI's counters twice, `--interval` apart, and prints the
    /// rates between the two answers (measured by each module's own clock) beside the
    /// totals. `--watch` goes on asking every interval until Ctrl-C. It joins no team: a
    /// bare Zenoh client asks, and nothing is left on any board.
    ///
    /// Example: slate stats
    ///
    /// Example: slate stats team/r1/nav --watch --format json
    Stats(StatsArgs),

    /// Show each module's bytes per second on each link (robot and team), out and in.
    ///
    /// What `slate stats` measures, all message kinds together, one line per module and
    /// link, like `ros2 topic bw`.
    ///
    /// Example: slate bw --watch
    Bw(StatsArgs),

    /// Show how often an attribute is written: rate, min/max/std of the intervals.
    ///
    /// Joins the team as an observer, watches OBJ.ATTR, and prints once a second, as
    /// `ros2 topic hz` does, the rate over the last `--window` updates. Intervals are
    /// those between the packets' stamps (when their source wrote them), so the network's
    /// jitter does not show. Runs until Ctrl-C or `--count` reports.
    ///
    /// Example: slate hz gsr.position --window 50
    Hz(HzArgs),

    /// Replay a recording: rebuild the recorded board on a manual clock, message by
    /// message, at the recorded pace (`--speed`), and print the board it ends with.
    ///
    /// The board starts from the file's first state (classes, objects, packets) and takes
    /// every packet with its recorded stamp and source, so it reads as it did live; with
    /// `--dashboard` the dashboard shows it as it goes, and stays up until Ctrl-C once the
    /// recording has been played. A file cut off by a crash plays up to its last chunk.
    /// Nothing is sent to any network.
    ///
    /// Example: slate play field-day.mcap --speed 10 --dashboard 127.0.0.1:8080
    ///
    /// Example: slate play field-day.mcap --speed max --until 120 --format json
    Play(PlayArgs),
}

/// Arguments of `slate check`.
#[derive(Debug, clap::Args)]
pub struct CheckArgs {
    /// The .slate files.
    #[arg(required = true)]
    pub files: Vec<std::path::PathBuf>,
}

/// Arguments of `slate bench`.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Which benchmark suite to run.
    #[arg(value_enum)]
    pub suite: slate_bench::Suite,

    /// Samples per measurement; the median is reported.
    #[arg(long, default_value_t = 21, allow_negative_numbers = true, value_parser = clap::value_parser!(u32).range(3..=1001))]
    pub samples: u32,

    /// Target duration of one sample, in milliseconds.
    #[arg(long, default_value_t = 5, allow_negative_numbers = true, value_parser = clap::value_parser!(u64).range(1..=1000))]
    pub sample_ms: u64,

    /// With `net` only: slate over TLS with mutual authentication and a secured team's
    /// access control (keys made in a temporary directory) against the same two nodes
    /// over plain TCP, in the same run.
    #[arg(long)]
    pub secure: bool,
}

/// How every live verb reaches the team: the endpoints, how long to wait, and on a
/// secured team the operator's keys. One struct, flattened into each verb's arguments,
/// so that no verb lacks a way in that another has.
///
/// Numeric options take negative numbers as values (`--wait -1`), so that the value's
/// own check says what is wrong instead of a usage error.
#[derive(Clone, Debug, clap::Args)]
pub struct ConnectArgs {
    /// Zenoh endpoint of a node to connect to (repeatable).
    #[arg(long, value_name = "ENDPOINT", default_value = "tcp/127.0.0.1:7447")]
    pub connect: Vec<String>,

    /// Seconds to wait for the team to answer (and an observer to catch up); it goes on
    /// as soon as every module has.
    #[arg(
        long,
        value_name = "SECONDS",
        default_value_t = 5.0,
        allow_negative_numbers = true
    )]
    pub wait: f64,

    /// The team's keys folder, to reach a secured team over tls/ endpoints as an operator
    /// (with --operator; docs/security.md).
    #[arg(long, value_name = "DIR", requires = "operator")]
    pub keys: Option<std::path::PathBuf>,

    /// The operator whose key and certificate in --keys to use, TEAM/NAME (made by `slate
    /// keys issue DIR TEAM/NAME`); an observer joins as TEAM/ROBOT/cli-NAME-PID.
    #[arg(long, value_name = "TEAM/NAME", requires = "keys")]
    pub operator: Option<String>,
}

/// Where the live verbs that join the team as an observer join it.
#[derive(Debug, clap::Args)]
pub struct LiveArgs {
    #[command(flatten)]
    pub connection: ConnectArgs,

    /// The observer's own address (default: TEAM/ROBOT/cli-PID on the robot of the first
    /// module found, by address; an observer on another robot sees only what is exported).
    #[arg(long = "as", value_name = "ADDRESS")]
    pub address: Option<String>,
}

/// Arguments of `slate stats` and `slate bw`.
#[derive(Debug, clap::Args)]
pub struct StatsArgs {
    /// The modules to show: TEAM, TEAM/ROBOT or TEAM/ROBOT/MODULE (default: all).
    #[arg(value_name = "ADDR")]
    pub address: Option<String>,

    /// Keep asking every interval until Ctrl-C (one JSON object per line with `--format json`).
    #[arg(long)]
    pub watch: bool,

    /// Seconds between the two answers a rate is measured over.
    #[arg(
        long,
        value_name = "SECONDS",
        default_value_t = 1.0,
        allow_negative_numbers = true
    )]
    pub interval: f64,

    #[command(flatten)]
    pub connection: ConnectArgs,
}

/// Arguments of `slate hz`.
#[derive(Debug, clap::Args)]
pub struct HzArgs {
    /// The attribute, `OBJ.ATTR`.
    #[arg(value_name = "OBJ.ATTR")]
    pub target: String,

    /// How many of the last updates the figures are over.
    #[arg(long, value_name = "N", default_value_t = 100, value_parser = clap::value_parser!(u64).range(2..=100_000))]
    pub window: u64,

    /// Stop after this many reports (default: at Ctrl-C).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..))]
    pub count: Option<u64>,

    #[command(flatten)]
    pub live: LiveArgs,
}

/// Arguments of `slate node`.
#[derive(Debug, clap::Args)]
pub struct NodeArgs {
    /// The module's TOML config.
    #[arg(long, short, value_name = "FILE")]
    pub config: std::path::PathBuf,

    /// Move the store of the config's `state` directory aside (to
    /// board.redb.SECONDS.old beside it) and start with an empty board: the way out of a
    /// damaged or unwanted state.
    #[arg(long)]
    pub reset_state: bool,
    /// Serve the Foxglove WebSocket protocol here, like 127.0.0.1:8765 (overrides the
    /// config's `foxglove`): one channel per class, objects with a position on /slate/scene.
    #[arg(long, value_name = "ADDR")]
    pub foxglove: Option<std::net::SocketAddr>,
}

/// Arguments of `slate tree`.
#[derive(Debug, clap::Args)]
pub struct TreeArgs {
    /// .slate files (none: the live team's classes).
    pub files: Vec<std::path::PathBuf>,

    #[command(flatten)]
    pub live: LiveArgs,
}

/// Arguments of `slate ls`.
#[derive(Debug, clap::Args)]
pub struct LsArgs {
    /// The class.
    pub class: String,

    #[command(flatten)]
    pub live: LiveArgs,
}

/// Arguments of `slate get`.
#[derive(Debug, clap::Args)]
pub struct GetArgs {
    /// `OBJ` or `OBJ.ATTR`.
    #[arg(value_name = "OBJ[.ATTR]")]
    pub target: String,

    #[command(flatten)]
    pub live: LiveArgs,
}

/// Arguments of `slate put`.
#[derive(Debug, clap::Args)]
pub struct PutArgs {
    /// The attribute, `OBJ.ATTR`.
    #[arg(value_name = "OBJ.ATTR")]
    pub target: String,

    /// The value, read as the attribute's declared type.
    #[arg(allow_hyphen_values = true)]
    pub value: String,

    /// Accuracy, in the attribute's unit (default: the declared default).
    #[arg(long, value_name = "A", allow_negative_numbers = true)]
    pub accuracy: Option<f64>,

    /// Confidence in [0, 1] (default: the declared default).
    #[arg(long, value_name = "C", allow_negative_numbers = true)]
    pub confidence: Option<f64>,

    #[command(flatten)]
    pub live: LiveArgs,
}

/// Arguments of `slate watch`.
#[derive(Debug, clap::Args)]
pub struct WatchArgs {
    /// `*`, `CLASS`, `OBJ`, `CLASS.ATTR`, `OBJ.ATTR` or `*.ATTR`.
    pub pattern: String,

    /// Stop after this many lines.
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    pub count: Option<u64>,

    #[command(flatten)]
    pub live: LiveArgs,
}

/// Arguments of `slate record`.
#[derive(Debug, clap::Args)]
pub struct RecordArgs {
    /// The file to write (rotated files go beside it: NAME.1.mcap, NAME.2.mcap...).
    #[arg(short, long, value_name = "FILE.mcap")]
    pub output: std::path::PathBuf,

    /// Classes (with their subclasses) or objects to record; none: everything.
    #[arg(value_name = "PATTERN")]
    pub patterns: Vec<String>,

    /// Start the next file once this many MiB are written (0: never).
    #[arg(long, value_name = "MIB", default_value_t = 1024)]
    pub max_size_mb: u64,

    /// Start the next file once the open one is this many seconds old (default: never).
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub max_age: Option<f64>,

    /// Stop after this many seconds (default: at Ctrl-C).
    #[arg(long = "for", value_name = "SECONDS", allow_negative_numbers = true)]
    pub duration: Option<f64>,

    #[command(flatten)]
    pub live: LiveArgs,
}

/// Arguments of `slate play`.
#[derive(Debug, clap::Args)]
pub struct PlayArgs {
    /// The recording (one file; a rotated recording's files play one at a time).
    #[arg(value_name = "FILE.mcap")]
    pub file: std::path::PathBuf,

    /// Times the recorded pace (2: twice as fast), or `max`: as fast as it goes.
    #[arg(long, value_name = "X|max", default_value = "1")]
    pub speed: String,

    /// Stop this many seconds after the recording's start.
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub until: Option<f64>,

    /// Serve the dashboard of the replayed board there (like "127.0.0.1:8080").
    #[arg(long, value_name = "ADDR", conflicts_with = "onto")]
    pub dashboard: Option<std::net::SocketAddr>,

    /// Publish the replay onto the live team TEAM (reached with --connect) as a module of
    /// its own, TEAM/replay/MODULE (MODULE: the recorded board's; with --operator NAME,
    /// TEAM/replay/cli-NAME-MODULE, which a secured team lets the operator speak as): it
    /// creates the recorded objects and writes the recorded values again, stamped as it
    /// writes them, itself their source. For software-in-the-loop tests.
    #[arg(long, value_name = "TEAM")]
    pub onto: Option<String>,

    #[command(flatten)]
    pub connection: ConnectArgs,
}

/// `slate keys` verbs.
#[derive(Debug, Subcommand)]
pub enum KeysCommand {
    /// Make the team's certificate authority in DIR: ca.pem (give it to every member)
    /// and ca.key (keep it where keys are issued; it is written readable by you only).
    ///
    /// Example: slate keys init team-keys
    Init(KeysInitArgs),

    /// Issue keys and certificates signed by DIR's authority: for a module address
    /// TEAM/ROBOT/MODULE (DIR/TEAM/ROBOT/MODULE.pem and .key), or for an operator TEAM/NAME
    /// (DIR/TEAM/NAME.pem and .key), who runs the CLI with `--keys DIR --operator
    /// TEAM/NAME`. The certificate's common name is the identity; private keys are
    /// written readable by you only (0600).
    ///
    /// Example: slate keys issue team-keys team/r1/nav team/alice
    Issue(KeysIssueArgs),
}

/// Arguments of `slate keys init`.
#[derive(Debug, clap::Args)]
pub struct KeysInitArgs {
    /// The team's keys folder (made if missing).
    pub dir: std::path::PathBuf,

    /// Replace an existing authority (every certificate it signed stops being accepted).
    #[arg(long)]
    pub force: bool,
}

/// Arguments of `slate keys issue`.
#[derive(Debug, clap::Args)]
pub struct KeysIssueArgs {
    /// The team's keys folder, with its authority (`slate keys init`).
    pub dir: std::path::PathBuf,

    /// Module addresses TEAM/ROBOT/MODULE and operators TEAM/NAME.
    #[arg(required = true, value_name = "IDENTITY")]
    pub identities: Vec<String>,

    /// Replace existing keys and certificates of these identities.
    #[arg(long)]
    pub force: bool,
}

/// `slate plan` verbs.
#[derive(Debug, Subcommand)]
pub enum PlanCommand {
    /// Send a plan to a module and print each acknowledgement as it arrives.
    ///
    /// FILE holds one `plan NAME { ... }`. The acknowledgements are: received, accepted
    /// (or rejected, with the reason), initiated, triggered (ok or failed) each time the
    /// action runs, terminated, cancelled. The command exits when the plan is terminated,
    /// rejected or cancelled (exit 0 for terminated, 1 otherwise), or after `--timeout`
    /// (exit 0; the plan keeps running). A destination that goes down is waited for (a
    /// note on stderr): the circuit sends the plan again when it comes back, and the
    /// acknowledgements resume. Only if it is still down when `--timeout` ends (30 s after
    /// the loss without `--timeout`) does the command print `destination lost` and fail
    /// (exit 1). On Ctrl-C it cancels the plan and waits briefly for the `cancelled`
    /// acknowledgement.
    ///
    /// Example: slate plan send patrol.slate --to team/r2/loco --timeout 30
    Send(PlanSendArgs),

    /// List the plans on a live team's boards: state, times fired, where they run, who
    /// sent them, the last error.
    ///
    /// Example: slate plan ls --format json
    Ls(PlanLsArgs),

    /// Cancel a plan running on a module: it never acts again.
    ///
    /// Example: slate plan cancel patrol --on team/r2/loco
    Cancel(PlanCancelArgs),

    /// Test plans against a recording, sending nothing: replays FILE.mcap into a board of
    /// its own (on the recording's clock, no network) with the plans installed once the
    /// recording's initial state is on it, and prints when each would have been
    /// initiated, triggered (with what its action wrote and would have sent) and
    /// terminated, beside what the plans of the same names did in the recorded run
    /// (docs/recording.md).
    ///
    /// Example: slate plan test call_return.slate --against field-day.mcap
    Test(PlanTestArgs),
}

/// Arguments of `slate plan test`.
#[derive(Debug, clap::Args)]
pub struct PlanTestArgs {
    /// The .slate file with the plans to test (it may declare what they need, too).
    pub file: std::path::PathBuf,

    /// The recording to replay (`slate record`, `record = ...` in a node's config, `slate
    /// demo --record`).
    #[arg(long, value_name = "FILE.mcap")]
    pub against: std::path::PathBuf,

    /// Load this .slate file first, on the empty board (repeatable): a recording holds
    /// packets and class definitions, not the functions behind derived attributes and
    /// rules, so plans that read a derived attribute need the file that declares it
    /// (for the demo's console: examples/demo/classes.slate).
    #[arg(long, value_name = "FILE")]
    pub with: Vec<std::path::PathBuf>,
}

/// Arguments of `slate plan send`.
#[derive(Debug, clap::Args)]
pub struct PlanSendArgs {
    /// The .slate file with one plan.
    pub file: std::path::PathBuf,

    /// The module that is to run it, `team/robot/module`.
    #[arg(long, value_name = "ADDRESS")]
    pub to: String,

    /// Stop waiting for acknowledgements after this many seconds (also for a lost
    /// destination to come back).
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    pub timeout: Option<f64>,

    #[command(flatten)]
    pub live: LiveArgs,
}

/// Arguments of `slate plan ls`.
#[derive(Debug, clap::Args)]
pub struct PlanLsArgs {
    #[command(flatten)]
    pub live: LiveArgs,
}

/// Arguments of `slate plan cancel`.
#[derive(Debug, clap::Args)]
pub struct PlanCancelArgs {
    /// The plan's name.
    pub name: String,

    /// The module running it (default: the one module whose board has a plan of that
    /// name).
    #[arg(long, value_name = "ADDRESS")]
    pub on: Option<String>,

    #[command(flatten)]
    pub live: LiveArgs,
}
