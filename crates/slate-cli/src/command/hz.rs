//! `slate hz OBJ.ATTR`: how often an attribute is written, printed once a second as
//! `ros2 topic hz` prints it.
//!
//! The figures are over the stamps of the last `--window` packets written (when their
//! source wrote them, not when they arrived), so a network's jitter does not show.

use std::collections::VecDeque;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use crossbeam_channel::Receiver;
use serde_json::json;
use slate_model::{ChangeItem, Filter};
use slate_node::Node;

use crate::cli::{Format, HzArgs};
use crate::command::live::{interrupted, join, known, print_line, split};

/// How often a report is printed.
const EVERY: Duration = Duration::from_secs(1);

/// Prints the rate once a second until Ctrl-C or `--count` reports (with a rate: one
/// update alone gives none).
pub fn run(args: &HzArgs, format: Format) -> anyhow::Result<ExitCode> {
    let (object, Some(attr)) = split(&args.target) else {
        anyhow::bail!(
            "{:?} is not OBJ.ATTR: name one attribute, like gsr.speed",
            args.target
        );
    };
    let signals = interrupted()?;
    let node = join(&args.live)?;
    let result = hz(&node, (object, attr), args, format, signals);
    node.close();
    result?;
    Ok(ExitCode::SUCCESS)
}

fn hz(
    node: &Node,
    (object, attr): (&str, &str),
    args: &HzArgs,
    format: Format,
    signals: &Receiver<()>,
) -> anyhow::Result<()> {
    known(node, object)?;
    let board = node.board();
    let filter = if board.class_def(object).is_some() {
        Filter::class(object)
    } else {
        Filter::object(object)
    };
    let watch = board.watch(filter.attr(attr))?;
    eprintln!("measuring {object}.{attr}; Ctrl-C to stop");
    let mut stamps = Window::new(args.window);
    let mut reports = 0;
    let mut next = Instant::now() + EVERY;
    while args.count.is_none_or(|n| reports < n) && signals.try_recv().is_err() {
        let left = next.saturating_duration_since(Instant::now());
        if let Some(change) = watch.recv_timeout(left.min(Duration::from_millis(100))) {
            for item in &change.items {
                if let ChangeItem::Write { packet, .. } = item {
                    stamps.push(packet.timestamp.as_secs_f64());
                }
            }
        }
        if Instant::now() >= next {
            next += EVERY;
            if stamps.fresh {
                let figures = stamps.figures();
                print(&figures, (object, attr), format)?;
                reports += u64::from(figures.rate_hz.is_some());
            } else if format == Format::Text {
                println!("no new messages");
            }
            stamps.fresh = false;
        }
    }
    Ok(())
}

/// The stamps of the last updates, oldest first.
struct Window {
    stamps: VecDeque<f64>,
    size: usize,
    /// An update came since the last report.
    fresh: bool,
}

/// What a report says: rate, intervals, how many updates they are over.
#[derive(Debug, PartialEq)]
struct Figures {
    rate_hz: Option<f64>,
    min_s: Option<f64>,
    max_s: Option<f64>,
    std_s: Option<f64>,
    window: usize,
}

impl Window {
    fn new(size: u64) -> Self {
        Window {
            stamps: VecDeque::new(),
            size: usize::try_from(size).unwrap_or(usize::MAX),
            fresh: false,
        }
    }

    /// Adds a stamp in its place (updates from several sources may arrive out of their
    /// stamps' order) and forgets the oldest past the window.
    fn push(&mut self, stamp: f64) {
        let at = self.stamps.partition_point(|s| *s <= stamp);
        self.stamps.insert(at, stamp);
        while self.stamps.len() > self.size {
            self.stamps.pop_front();
        }
        self.fresh = true;
    }

    fn intervals(&self) -> Vec<f64> {
        let s = &self.stamps;
        s.iter().zip(s.iter().skip(1)).map(|(a, b)| b - a).collect()
    }

    /// The figures over the window (none of them with fewer than two updates).
    fn figures(&self) -> Figures {
        let gaps = self.intervals();
        let n = gaps.len() as f64;
        let mean = gaps.iter().sum::<f64>() / n;
        let var = gaps.iter().map(|g| (g - mean).powi(2)).sum::<f64>() / n;
        let some = |v: f64| (!gaps.is_empty() && v.is_finite()).then_some(v);
        Figures {
            rate_hz: some(1.0 / mean),
            min_s: some(gaps.iter().copied().fold(f64::INFINITY, f64::min)),
            max_s: some(gaps.iter().copied().fold(f64::NEG_INFINITY, f64::max)),
            std_s: some(var.sqrt()),
            window: self.stamps.len(),
        }
    }
}

fn print(f: &Figures, (object, attr): (&str, &str), format: Format) -> anyhow::Result<()> {
    match format {
        Format::Json => print_line(&json!({
            "object": object, "attr": attr, "rate_hz": f.rate_hz, "min_s": f.min_s,
            "max_s": f.max_s, "std_s": f.std_s, "window": f.window,
        })),
        Format::Text => {
            let (Some(rate), Some(min), Some(max), Some(std)) =
                (f.rate_hz, f.min_s, f.max_s, f.std_s)
            else {
                println!("one update so far (window: {})", f.window);
                return Ok(());
            };
            println!("average rate: {rate:.3}");
            println!(
                "\tmin: {min:.3}s max: {max:.3}s std dev: {std:.5}s window: {}",
                f.window
            );
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_are_over_the_last_window_of_stamps_in_their_order() {
        let mut w = Window::new(4);
        for s in [0.0, 10.0, 10.1, 10.3, 10.2] {
            w.push(s);
        }
        let f = w.figures();
        assert_eq!(f.window, 4);
        assert!((f.rate_hz.unwrap() - 10.0).abs() < 1e-9, "{f:?}");
        assert!((f.min_s.unwrap() - 0.1).abs() < 1e-9);
        assert!((f.max_s.unwrap() - 0.1).abs() < 1e-9);
        assert!(f.std_s.unwrap() < 1e-9);
    }

    #[test]
    fn one_update_gives_no_rate() {
        let mut w = Window::new(10);
        w.push(1.0);
        assert_eq!(w.figures().rate_hz, None);
        assert_eq!(w.figures().window, 1);
    }
}
