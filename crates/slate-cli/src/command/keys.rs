//! `slate keys init DIR` and `slate keys issue DIR IDENTITY...`: a team's certificate
//! authority and its members' keys and certificates (docs/security.md).

use std::path::PathBuf;
use std::process::ExitCode;

use serde_json::json;
use slate_node::team_keys::{self, Identity};

use crate::cli::{Format, KeysInitArgs, KeysIssueArgs};

/// Makes the team's certificate authority.
pub fn init(args: &KeysInitArgs, format: Format) -> anyhow::Result<ExitCode> {
    let written = team_keys::init(&args.dir, args.force)?;
    print(&written, format);
    Ok(ExitCode::SUCCESS)
}

/// Issues each identity's key and certificate; all identities are read before any is
/// issued, so a typo issues nothing.
pub fn issue(args: &KeysIssueArgs, format: Format) -> anyhow::Result<ExitCode> {
    let identities = args
        .identities
        .iter()
        .map(|text| Identity::parse(text))
        .collect::<Result<Vec<_>, _>>()?;
    let mut written = Vec::new();
    for identity in &identities {
        written.extend(team_keys::issue(&args.dir, identity, args.force)?);
    }
    print(&written, format);
    Ok(ExitCode::SUCCESS)
}

/// The files written: one per line, or `{"written": [...]}`.
fn print(written: &[PathBuf], format: Format) {
    let names: Vec<String> = written.iter().map(|p| p.display().to_string()).collect();
    match format {
        Format::Text => names.iter().for_each(|n| println!("wrote {n}")),
        Format::Json => println!("{}", json!({ "written": names })),
    }
}
