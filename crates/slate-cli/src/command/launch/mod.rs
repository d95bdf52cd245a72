//! `slate launch TEAM.toml`: a team of `slate node` processes from one file, started,
//! supervised and stopped together (docs/launch.md). `team.rs` reads the file into one
//! node config per module, `check.rs` is `--check`, `supervise.rs` runs the processes.

mod check;
mod supervise;
mod team;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use serde_json::json;

use crate::cli::Format;
use crate::command::live::interrupted;
pub use supervise::ModuleLogs;
use team::{ModulePlan, Team};

/// Arguments of `slate launch`.
#[derive(Debug, clap::Args)]
pub struct LaunchArgs {
    /// The team file: robots, the kinds of module they run, ports (docs/launch.md).
    #[arg(value_name = "TEAM.toml")]
    pub team: PathBuf,

    /// Check the whole team (every module's config, its .slate files with the robot's name
    /// substituted, hosts and ports) and exit: 0 if it can start, 1 if not, 2 if the team
    /// file itself is malformed. Starts nothing.
    #[arg(long)]
    pub check: bool,

    /// Run only this robot's modules on this host (repeatable); the others are expected
    /// to run elsewhere, on their robots' hosts.
    #[arg(long, value_name = "ROBOT")]
    pub robot: Vec<String>,

    /// Run only this module, ROBOT/KIND like `r1/nav` (repeatable; with `--robot`, the
    /// modules of either).
    #[arg(long, value_name = "ROBOT/KIND")]
    pub only: Vec<String>,

    /// Listen from this port on instead of the file's `base_port` (module n of the file
    /// on BASE_PORT + n), to run a second copy of a team beside the first.
    #[arg(long, value_name = "PORT", value_parser = clap::value_parser!(u16).range(1..))]
    pub base_port: Option<u16>,

    /// Secure the team with this keys folder (made by `slate keys`; instead of the team
    /// file's `keys`): every module listens and connects over TLS with mutual
    /// authentication and the access control generated from the keys (docs/security.md).
    #[arg(long, value_name = "DIR")]
    pub keys: Option<PathBuf>,

    /// Folder for each module's config and log (ROBOT-KIND.toml, ROBOT-KIND.log); default
    /// `slate-logs/TEAM` in the current folder.
    #[arg(long, value_name = "DIR")]
    pub logs: Option<PathBuf>,
}

/// Reads the team, then checks it or runs the modules chosen for this host.
pub fn run(args: &LaunchArgs, format: Format, logs: ModuleLogs) -> anyhow::Result<ExitCode> {
    let team = Team::read(&args.team, args.base_port, args.keys.as_deref())?;
    if args.check {
        return Ok(report_check(&team, format));
    }
    let chosen = choose(&team, args)?;
    let problems = check::problems(&Team {
        modules: chosen.clone(),
        ..team.clone()
    });
    if !problems.is_empty() {
        problems.iter().for_each(|p| eprintln!("{p}"));
        return Ok(ExitCode::from(2));
    }
    let dir = args
        .logs
        .clone()
        .unwrap_or_else(|| PathBuf::from("slate-logs").join(&team.name));
    let console = supervise::Console { format };
    let signals = interrupted()?;
    let mut modules = supervise::Supervisor::new(chosen, &dir, team.restart, (console, logs))?;
    let started = modules.start_all(signals);
    let outcome = match started {
        Ok(true) => {
            let (text, connect) = ready_news(&team.name, &dir, modules.first_module());
            console.event(
                "ready",
                &team.name,
                &text,
                json!({"logs": dir, "connect": connect}),
            );
            Ok(modules.run(signals))
        }
        Ok(false) => Ok(true),
        Err(e) => Err(e),
    };
    modules.stop_all();
    match outcome? {
        true => Ok(ExitCode::SUCCESS),
        false => Ok(ExitCode::from(1)),
    }
}

/// Launch's news once every module is up: where the logs are, and the endpoint (the
/// first module's) through which `slate stats` and the other live verbs reach the team.
fn ready_news(team: &str, logs: &Path, first: Option<&ModulePlan>) -> (String, Option<String>) {
    let mut text = format!("every module is up; logs in {}", logs.display());
    let connect = first.and_then(|m| m.config.zenoh.listen.first().cloned());
    if let (Some(m), Some(endpoint)) = (first, &connect) {
        text += &format!("; watch it with `slate stats --connect {endpoint}");
        if let Some(keys) = &m.config.security {
            text += &format!(" --keys {} --operator {team}/OPERATOR", keys.display());
        }
        text += "`";
    }
    (text, connect)
}

/// The modules chosen by `--robot` and `--only` (all without either); an error naming
/// what the team does not have.
fn choose(team: &Team, args: &LaunchArgs) -> anyhow::Result<Vec<ModulePlan>> {
    let robots: Vec<&str> = team.modules.iter().map(|m| m.robot.as_str()).collect();
    let names: Vec<&str> = team.modules.iter().map(|m| m.name.as_str()).collect();
    let file = args.team.display();
    if let Some(r) = args.robot.iter().find(|r| !robots.contains(&r.as_str())) {
        anyhow::bail!(
            "--robot {r}: {file} has no robot {r:?} (robots: {})",
            dedup(&robots).join(", ")
        );
    }
    if let Some(o) = args.only.iter().find(|o| !names.contains(&o.as_str())) {
        anyhow::bail!(
            "--only {o}: {file} has no module {o:?}: name one as ROBOT/KIND ({})",
            names.join(", ")
        );
    }
    let all = args.robot.is_empty() && args.only.is_empty();
    Ok(team
        .modules
        .iter()
        .filter(|m| all || args.robot.contains(&m.robot) || args.only.contains(&m.name))
        .cloned()
        .collect())
}

fn dedup<'a>(names: &[&'a str]) -> Vec<&'a str> {
    let mut out: Vec<&str> = Vec::new();
    for n in names {
        if !out.contains(n) {
            out.push(n);
        }
    }
    out
}

/// Prints `--check`'s verdict: every problem (stderr), or what would run (stdout).
fn report_check(team: &Team, format: Format) -> ExitCode {
    let problems = check::problems(team);
    let file = team.file.display().to_string();
    match format {
        Format::Json => println!(
            "{}",
            json!({"team": team.name, "file": file, "ok": problems.is_empty(), "problems": problems.iter().map(ToString::to_string).collect::<Vec<_>>(),
                "modules": team.modules.iter().map(|m| json!({"address": m.config.address.as_str(), "listen": m.config.zenoh.listen})).collect::<Vec<_>>()})
        ),
        Format::Text if problems.is_empty() => {
            println!(
                "{file}: ok, team {} of {} modules",
                team.name,
                team.modules.len()
            );
            for m in &team.modules {
                println!(
                    "  {} on {}",
                    m.config.address,
                    m.config.zenoh.listen.join(", ")
                );
            }
        }
        Format::Text => {
            for p in &problems {
                eprintln!("{p}");
            }
        }
    }
    if problems.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}
