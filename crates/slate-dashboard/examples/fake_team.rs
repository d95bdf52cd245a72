//! Serves the dashboard for a fake moving team, for looking at the page by hand.
//!
//! ```text
//! cargo run -p slate-dashboard --example fake_team            # http://127.0.0.1:8080/
//! cargo run -p slate-dashboard --example fake_team -- 127.0.0.1:0 --for 5
//! ```
//! `ADDR` defaults to 127.0.0.1:8080; `--for SECONDS` stops after that long (else runs until
//! interrupted). The first line on stdout is the page's URL.

use std::io::Write;
use std::net::SocketAddr;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use slate_dashboard::SampleTeam;

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .init();
    let (addr, seconds) = match parse(std::env::args().skip(1)) {
        Ok(parsed) => parsed,
        Err(message) => {
            eprintln!("fake_team: {message}\nusage: fake_team [ADDR] [--for SECONDS]");
            return ExitCode::from(2);
        }
    };
    let dashboard = match slate_dashboard::serve(addr, Arc::new(SampleTeam::new())) {
        Ok(dashboard) => dashboard,
        Err(error) => {
            eprintln!("fake_team: {error}");
            return ExitCode::FAILURE;
        }
    };
    println!("{}", dashboard.url());
    let _ = std::io::stdout().flush();
    match seconds {
        Some(seconds) => std::thread::sleep(Duration::from_secs_f64(seconds)),
        None => loop {
            std::thread::park();
        },
    }
    dashboard.stop();
    ExitCode::SUCCESS
}

fn parse(mut args: impl Iterator<Item = String>) -> Result<(SocketAddr, Option<f64>), String> {
    let mut addr = SocketAddr::from(([127, 0, 0, 1], 8080));
    let mut seconds = None;
    while let Some(arg) = args.next() {
        if arg == "--for" {
            let value = args.next().ok_or("--for needs a number of seconds")?;
            let value: f64 = value
                .parse()
                .map_err(|_| format!("bad duration {value:?}"))?;
            if !(value.is_finite() && value >= 0.0) {
                return Err(format!("bad duration {value}"));
            }
            seconds = Some(value);
        } else {
            addr = arg.parse().map_err(|_| format!("bad address {arg:?}"))?;
        }
    }
    Ok((addr, seconds))
}
