//! `slate demo`: the multi-robot mission of `slate-demo` — three Ground Surveillance
//! Robots and an operator console on a simulated world — headless or with the live
//! dashboard. Progress goes to stderr, the summary to stdout.

use std::io::Write as _;
use std::net::SocketAddr;
use std::process::ExitCode;
use std::time::Duration;

use clap::ValueEnum;
use slate_demo::{DemoConfig, NetworkKind, Progress, Speakers, TeamLink, TeamMedium};

use crate::cli::Format;

/// Arguments of `slate demo`.
#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// Seeds the world, the sensors' noise and the simulated network (same seed, same run).
    #[arg(long, default_value_t = 7)]
    pub seed: u64,

    /// Robots in the team, 1 to 32 (each five modules: five boards, five ICIs; the world
    /// grows a strip with a route and targets per robot).
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u8).range(1..=32))]
    pub robots: u8,

    /// The network: the deterministic simulator (team link 9600 bit/s, 5 % loss), or Zenoh
    /// on 127.0.0.1 with one session per module, all in this process (real time).
    #[arg(long, value_enum, default_value_t = Network::Sim)]
    pub network: Network,

    /// With --network zenoh: run a secured team (docs/security.md): keys made for the run
    /// in a temporary folder (as `slate keys` makes them), TLS links with mutual
    /// authentication, and the access control generated from the keys.
    #[arg(long)]
    pub secure: bool,

    /// What carries the team link on the simulator: a radio per robot, or one shared
    /// half-duplex acoustic channel for the whole team (32-byte frames, 20 % frame loss,
    /// 1-2 s latency).
    #[arg(long, value_enum, default_value_t = TeamLinkArg::Radio)]
    pub team_link: TeamLinkArg,

    /// The team link's rate in bit/s: per radio (default 9600), or of the one acoustic
    /// channel (default 80, the WHOI Micro-Modem's lowest rate).
    #[arg(long, value_name = "BPS")]
    pub team_rate: Option<u64>,

    /// A deck phase of this many seconds before launch (at least 5): the team link is a
    /// fast clean radio (1 Mbit/s, no loss) while the console sends the mission plans;
    /// at launch it becomes the --team-link and the mission runs. The mission's time,
    /// deadline, fault and rates count from launch; the summary reports deck_bytes.
    #[arg(long, value_name = "SECONDS")]
    pub deck: Option<f64>,

    /// Who speaks on the team link: one gateway per robot relaying its modules' exports
    /// as one stream repaired by NACK (docs/team-protocol.md), or every module (the
    /// per-module protocol of docs/ici.md, whose cost grows with the square of the
    /// number of modules).
    #[arg(long, value_enum, default_value_t = SpeakersArg::from(Speakers::default()))]
    pub speakers: SpeakersArg,

    /// Serve the live dashboard at this address, like 127.0.0.1:8080 (the simulator then
    /// runs at real time so people can watch).
    #[arg(long, value_name = "ADDR")]
    pub dashboard: Option<SocketAddr>,

    /// The longest the mission may run, in seconds of world time (the console calls the
    /// robots home at 80 % of it).
    #[arg(long, default_value_t = 240.0, value_name = "S")]
    pub duration: f64,

    /// When the last robot dies, in seconds into the run.
    #[arg(long, default_value_t = 30.0, value_name = "S")]
    pub fault_at: f64,

    /// Nobody dies.
    #[arg(long)]
    pub no_fault: bool,

    /// Simulator only: world seconds per real second (default: as fast as it goes, or 1
    /// with --dashboard).
    #[arg(long, value_name = "X")]
    pub speed: Option<f64>,

    /// With --dashboard: how long the page stays up after the run, in seconds.
    #[arg(long, default_value_t = 30.0, value_name = "S")]
    pub linger: f64,

    /// With --network processes: run robot NAME's modules (the console's: `base`) in
    /// network namespace NETNS, listening on IP there, as on a machine of their own
    /// (repeatable; the real-link harness's `mission.py` places every robot so). Robots
    /// not placed run on 127.0.0.1 here.
    #[arg(long, value_name = "NAME=NETNS@IP", value_parser = parse_place)]
    pub place: Vec<(String, (String, String))>,

    /// With --network processes: the IP address this process's world module listens on
    /// (where the placed robots' drivers reach it; default 127.0.0.1).
    #[arg(long, value_name = "IP")]
    pub world_address: Option<String>,
    /// Record the operator console's board in MCAP to this file while the mission runs
    /// (its classes, objects, packets, plan events, circuits, liveliness, counters;
    /// docs/recording.md); the summary's `recording` gives the messages per channel.
    /// Replay it with `slate play FILE.mcap`.
    #[arg(long, value_name = "FILE.mcap")]
    pub record: Option<std::path::PathBuf>,

    /// Write the console's board as the run ends to this JSON file (objects with their
    /// class, context, owner and own packets: the shape of `slate play --format json`'s
    /// `objects`), to compare with a replay of --record's file.
    #[arg(long, value_name = "FILE.json")]
    pub final_board: Option<std::path::PathBuf>,

    /// Print no progress, only the summary.
    #[arg(long)]
    pub quiet: bool,
}

/// The network to run on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Network {
    /// The deterministic in-process simulator.
    Sim,
    /// Zenoh on 127.0.0.1, every module in this process.
    Zenoh,
    /// Zenoh on 127.0.0.1, every module its own OS process; this one runs the world
    /// (served as a module) and referees.
    Processes,
}

/// What carries the team link.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum TeamLinkArg {
    /// A radio per robot, messages whole.
    Radio,
    /// One shared half-duplex acoustic channel, 32-byte frames.
    Acoustic,
}

/// Who speaks on the team link.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SpeakersArg {
    /// Every module (the per-module protocol).
    Modules,
    /// One gateway per robot (the team protocol).
    Robots,
}

impl From<Speakers> for SpeakersArg {
    fn from(speakers: Speakers) -> Self {
        match speakers {
            Speakers::Modules => SpeakersArg::Modules,
            Speakers::Robots => SpeakersArg::Robots,
        }
    }
}

/// Runs the demo; exits 0 when the mission completes, 1 when it does not.
pub fn run(args: &DemoArgs, format: Format) -> anyhow::Result<ExitCode> {
    let config = config(args)?;
    let quiet = args.quiet;
    let summary = slate_demo::run(config, &mut |p| {
        if !quiet {
            show(&p);
        }
    })?;
    match format {
        Format::Text => print!("{}", summary.to_text()),
        Format::Json => println!("{}", serde_json::to_string_pretty(&summary.to_json())?),
    }
    std::io::stdout().flush()?;
    if let Some(failed) = summary
        .recording
        .as_ref()
        .and_then(|r| r["failed"].as_str())
    {
        anyhow::bail!("the recording failed: {failed}");
    }
    Ok(if summary.mission_complete {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

fn config(args: &DemoArgs) -> anyhow::Result<DemoConfig> {
    anyhow::ensure!(
        args.duration.is_finite() && args.duration >= 10.0,
        "--duration must be at least 10 seconds"
    );
    anyhow::ensure!(
        args.linger.is_finite() && args.linger >= 0.0,
        "--linger must be >= 0"
    );
    anyhow::ensure!(
        args.deck.is_none_or(|d| d.is_finite() && d >= 0.0),
        "--deck must be a number of seconds"
    );
    let mut config = DemoConfig::default()
        .seed(args.seed)
        .robots(usize::from(args.robots))
        .network(match args.network {
            Network::Sim => NetworkKind::Sim,
            Network::Zenoh => NetworkKind::Zenoh,
            Network::Processes => NetworkKind::Processes,
        })
        .secure(args.secure)
        .duration(Duration::from_secs_f64(args.duration))
        .fault_at((!args.no_fault).then_some(args.fault_at))
        .deck(args.deck.map(Duration::from_secs_f64))
        .speakers(args.speakers.into())
        .team_link(TeamLink::of(
            match args.team_link {
                TeamLinkArg::Radio => TeamMedium::Radio,
                TeamLinkArg::Acoustic => TeamMedium::Acoustic,
            },
            args.team_rate,
        ));
    config.placement = slate_demo::Placement {
        world: args.world_address.clone(),
        robots: args.place.iter().cloned().collect(),
    };
    anyhow::ensure!(
        args.network == Network::Processes
            || (args.place.is_empty() && args.world_address.is_none()),
        "--place and --world-address place module processes: use them with --network processes"
    );
    config.record.clone_from(&args.record);
    config.final_board.clone_from(&args.final_board);
    if let Some(addr) = args.dashboard {
        config = config.dashboard(addr);
        config.linger = Duration::from_secs_f64(args.linger);
    }
    if args.speed.is_some() {
        config = config.pace(args.speed);
    }
    Ok(config)
}

/// Arguments of `slate demo-module` (as `slate demo --network processes` passes them).
#[derive(Debug, clap::Args)]
pub struct DemoModuleArgs {
    /// The robot it belongs to: r1, r2, ... (`base` for the console).
    #[arg(long, value_name = "NAME")]
    pub robot: String,

    /// What it does: console, exec, nav, prox, vision or loco.
    #[arg(long, value_name = "ROLE")]
    pub role: String,

    /// The world's seed (the layout, the drivers' noise).
    #[arg(long)]
    pub seed: u64,

    /// Robots in the team.
    #[arg(long)]
    pub robots: u8,

    /// Who speaks on the team link, as `slate demo --speakers` says.
    #[arg(long, value_enum)]
    pub speakers: SpeakersArg,

    /// When the console calls the robots home, seconds of world time.
    #[arg(long, value_name = "S")]
    pub return_after: f64,

    /// The Zenoh endpoint it listens on, like tcp/127.0.0.1:7601.
    #[arg(long, value_name = "ENDPOINT")]
    pub listen: String,

    /// The world module's endpoint.
    #[arg(long, value_name = "ENDPOINT")]
    pub world: String,

    /// An endpoint of a module started before it (once per endpoint).
    #[arg(long, value_name = "ENDPOINT")]
    pub connect: Vec<String>,
}

impl DemoModuleArgs {
    /// The module these flags describe, or why there is none.
    fn spec(&self) -> anyhow::Result<slate_demo::process::ModuleSpec> {
        Ok(slate_demo::process::ModuleSpec {
            address: slate_demo::process::ModuleSpec::address_of(&self.robot, &self.role)?,
            seed: self.seed,
            robots: self.robots,
            speakers: self.speakers.into(),
            return_after: self.return_after,
            listen: self.listen.clone(),
            world: self.world.clone(),
            connect: self.connect.clone(),
        })
    }
}

impl From<SpeakersArg> for Speakers {
    fn from(arg: SpeakersArg) -> Self {
        match arg {
            SpeakersArg::Modules => Speakers::Modules,
            SpeakersArg::Robots => Speakers::Robots,
        }
    }
}

/// `slate demo-module`: one module of the demo as its own process. It says `ready` on
/// stdout once started, and leaves when its input closes (its parent stopped or died)
/// or at SIGTERM.
pub fn module(args: &DemoModuleArgs) -> anyhow::Result<ExitCode> {
    let spec = args.spec()?;
    let process = slate_demo::process::ModuleProcess::start(&spec)?;
    let (tx, stop) = crossbeam_channel::bounded(1);
    let on_eof = tx.clone();
    std::thread::spawn(move || {
        let _ = std::io::copy(&mut std::io::stdin().lock(), &mut std::io::sink());
        let _ = on_eof.try_send(());
    });
    ctrlc::set_handler(move || {
        let _ = tx.try_send(());
    })?;
    println!("ready");
    std::io::stdout().flush()?;
    process.run(&stop);
    Ok(ExitCode::SUCCESS)
}

/// `NAME=NETNS@IP`, as `--place` takes it.
fn parse_place(text: &str) -> Result<(String, (String, String)), String> {
    let bad = || format!("{text:?}: expected NAME=NETNS@IP, like r1=robot1@10.77.0.2");
    let (name, rest) = text.split_once('=').ok_or_else(bad)?;
    let (netns, ip) = rest.split_once('@').ok_or_else(bad)?;
    if [name, netns, ip].iter().any(|s| s.is_empty()) {
        return Err(bad());
    }
    Ok((name.to_owned(), (netns.to_owned(), ip.to_owned())))
}

fn show(p: &Progress) {
    match p {
        Progress::Started(what) => eprintln!("{what}"),
        Progress::Dashboard(url) => eprintln!("dashboard: {url}"),
        Progress::Event(e) => eprintln!("[{:6.1} s] {}{}", e.t, level(e.level), e.text),
        Progress::Status(s) => eprintln!("  ── {s}"),
    }
}

fn level(l: slate_demo::Level) -> &'static str {
    match l {
        slate_demo::Level::Warn => "! ",
        slate_demo::Level::Error => "!! ",
        _ => "",
    }
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::*;

    /// `slate demo-module` alone, as clap parses it.
    #[derive(Parser)]
    struct DemoModuleCli {
        #[command(flatten)]
        args: DemoModuleArgs,
    }

    fn parsed(args: &[String]) -> Result<DemoModuleArgs, clap::Error> {
        let argv = std::iter::once("demo-module".to_owned()).chain(args.iter().cloned());
        DemoModuleCli::try_parse_from(argv).map(|c| c.args)
    }

    #[test]
    fn a_module_spec_reads_back_from_the_flags_slate_demo_passes() {
        let spec = slate_demo::process::ModuleSpec {
            address: slate_demo::process::ModuleSpec::address_of("r2", "exec").unwrap(),
            seed: 7,
            robots: 3,
            speakers: Speakers::Robots,
            return_after: 192.0,
            listen: "tcp/10.77.0.4:7601".into(),
            world: "tcp/10.77.0.1:7600".into(),
            connect: vec!["tcp/10.77.0.2:7602".into(), "tcp/10.77.0.3:7603".into()],
        };
        let args = spec.to_args();
        assert!(args.contains(&"--role".to_owned()), "{args:?}");
        assert_eq!(parsed(&args).unwrap().spec().unwrap(), spec);
    }

    #[test]
    fn a_module_of_no_role_is_refused_naming_the_roles() {
        let args = [
            "--robot", "r1", "--role", "pilot", "--seed", "7", "--robots", "3",
        ]
        .into_iter()
        .chain(["--speakers", "robots", "--return-after", "192"])
        .chain([
            "--listen",
            "tcp/127.0.0.1:7601",
            "--world",
            "tcp/127.0.0.1:7600",
        ])
        .map(str::to_owned)
        .collect::<Vec<_>>();
        let error = parsed(&args).unwrap().spec().unwrap_err().to_string();
        assert!(error.contains("pilot") && error.contains("exec"), "{error}");
    }
}
