//! Writes the fuzz targets' seed corpora into `fuzz/seeds/TARGET/` from real material:
//! the traffic a small team on the simulator sends to the module under test (captured
//! by a raw endpoint at its address), slate-wire's golden vectors, the repository's
//! `.slate` examples, and the node configs of `examples/` and `docs/`. The committed
//! corpora (`fuzz/corpus/`) are these, minimised: see docs/security.md, "Fuzzing".
//!
//!     cd fuzz && cargo run --example seeds

use std::fs;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;

use slate_fuzz::{ME, PEERS, address, board, config, write_record};
use slate_ici::{Handler, Ici, SimNet, Transport};
use slate_model::{Address, Board, Context, NewObject, Value};

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// Records every message that reaches the module's address.
#[derive(Default)]
struct Tap(Mutex<Vec<(Address, Vec<u8>)>>);

impl Handler for Tap {
    fn message(&self, from: &Address, payload: &[u8]) {
        self.0
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .push((from.clone(), payload.to_vec()));
    }

    fn peer(&self, _: &Address, _: bool) {}
}

fn main() -> Result<()> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let repo = root.parent().ok_or("fuzz/ has no parent")?;
    let seeds = root.join("seeds");
    let traffic = capture()?;
    write_ici_seeds(&seeds.join("ici_receive"), &traffic)?;
    write_wire_seeds(&seeds.join("wire_decode"), repo, &traffic)?;
    let slate = files_ending(&repo.join("examples"), "slate")?;
    for target in ["slate_parse", "slate_check"] {
        copy_all(&seeds.join(target), &slate)?;
    }
    write_config_seeds(&seeds.join("node_config"), repo)?;
    println!("seeds written under {}", seeds.display());
    Ok(())
}

/// The traffic the four peers send the module's address while they create, write and
/// delete objects for a few simulated seconds: (sender's index in `PEERS`, bytes).
fn capture() -> Result<Vec<(usize, Vec<u8>)>> {
    let net = SimNet::new(7);
    let tap = Arc::new(Tap::default());
    net.join(&address(ME).ok_or("ME")?).set_handler(tap.clone());
    let mut icis = Vec::new();
    for peer in PEERS {
        let at = address(peer).ok_or("peer")?;
        let b = board(&net, &at).ok_or("board")?;
        icis.push(Ici::new(b, net.join(&at), config())?);
    }
    let boards: Vec<Arc<Board>> = icis.iter().map(|i| i.board().clone()).collect();
    create_objects(&boards)?;
    for step in 0..40 {
        write_step(&boards, step)?;
        net.run_for(Duration::from_millis(150));
    }
    boards[3].delete("rock2")?;
    net.run_for(Duration::from_secs(3));
    let heard = std::mem::take(&mut *tap.0.lock().unwrap_or_else(PoisonError::into_inner));
    Ok(heard
        .into_iter()
        .filter_map(|(from, bytes)| {
            PEERS
                .iter()
                .position(|p| *p == from.as_str())
                .map(|i| (i, bytes))
        })
        .collect())
}

fn create_objects(boards: &[Arc<Board>]) -> Result<()> {
    let objects = [
        ("Vehicle", "gsr1", Context::Self_),
        ("Obstacle", "rock1", Context::Surroundings),
    ];
    let more = [
        ("Gsr", "gsr2", Context::Self_),
        ("Obstacle", "rock2", Context::Surroundings),
    ];
    for (board, (class, name, context)) in boards.iter().zip(objects.into_iter().chain(more)) {
        board.create_with(NewObject::new(class, name).context(context))?;
    }
    Ok(())
}

/// Step `i` of the writes: every value type of the fuzz classes, changing.
fn write_step(boards: &[Arc<Board>], i: u32) -> Result<()> {
    let f = f64::from(i);
    boards[0].write("gsr1", "x", 10.0 + f)?;
    boards[0].write("gsr1", "speed", f % 20.0)?;
    boards[0].write("gsr1", "goal", vec![f, -f])?;
    boards[0].write(
        "gsr1",
        "mode",
        if i.is_multiple_of(2) {
            "auto"
        } else {
            "manual"
        },
    )?;
    boards[1].write("rock1", "size", f % 50.0)?;
    boards[1].write("rock1", "hits", i64::from(i))?;
    boards[1].write("rock1", "shape", vec![f, 1.0, 2.0])?;
    boards[1].write("rock1", "observer", Value::Ref("gsr1".into()))?;
    boards[2].write("gsr2", "battery", i64::from(100 - i))?;
    boards[2].write("gsr2", "alive", !i.is_multiple_of(3))?;
    boards[3].write("rock2", "note", -f)?;
    Ok(())
}

/// Each message alone, and the whole capture in runs of 16 (records keep their sender).
fn write_ici_seeds(dir: &Path, traffic: &[(usize, Vec<u8>)]) -> Result<()> {
    fs::create_dir_all(dir)?;
    for (n, (peer, bytes)) in traffic.iter().enumerate() {
        let mut input = Vec::new();
        write_record(&mut input, *peer, false, 1, bytes);
        fs::write(dir.join(format!("one-{n:04}")), input)?;
    }
    for (n, run) in traffic.chunks(16).enumerate() {
        let mut input = Vec::new();
        run.iter()
            .for_each(|(peer, bytes)| write_record(&mut input, *peer, false, 1, bytes));
        fs::write(dir.join(format!("run-{n:04}")), input)?;
    }
    Ok(())
}

/// The captured slate-wire messages (header version 1) and the golden vectors.
fn write_wire_seeds(dir: &Path, repo: &Path, traffic: &[(usize, Vec<u8>)]) -> Result<()> {
    fs::create_dir_all(dir)?;
    let wire = traffic
        .iter()
        .filter(|(_, b)| b.first().is_some_and(|h| h >> 4 == 1));
    for (n, (_, bytes)) in wire.enumerate() {
        fs::write(dir.join(format!("heard-{n:04}")), bytes)?;
    }
    for hex in files_ending(&repo.join("crates/slate-wire/tests/golden"), "hex")? {
        let name = hex.file_stem().ok_or("a file without a name")?;
        fs::write(dir.join(name), from_hex(&fs::read_to_string(&hex)?)?)?;
    }
    Ok(())
}

/// A golden vector's bytes: hex pairs, `#` comment lines skipped.
fn from_hex(text: &str) -> Result<Vec<u8>> {
    text.lines()
        .filter(|l| !l.starts_with('#'))
        .flat_map(str::split_whitespace)
        .map(|pair| Ok(u8::from_str_radix(pair, 16)?))
        .collect()
}

/// The TOML files of `examples/` and every fenced `toml` block of `docs/` that sets an
/// `address` (a node config).
fn write_config_seeds(dir: &Path, repo: &Path) -> Result<()> {
    copy_all(dir, &files_ending(&repo.join("examples"), "toml")?)?;
    let mut n = 0;
    for doc in files_ending(&repo.join("docs"), "md")? {
        for block in toml_blocks(&fs::read_to_string(&doc)?) {
            if block.contains("address") {
                fs::write(dir.join(format!("doc-{n:03}.toml")), block)?;
                n += 1;
            }
        }
    }
    Ok(())
}

/// The fenced ```toml blocks of a Markdown text.
fn toml_blocks(markdown: &str) -> Vec<String> {
    let mut blocks = Vec::new();
    let mut open: Option<String> = None;
    for line in markdown.lines() {
        match (&mut open, line.trim_start()) {
            (None, l) if l.starts_with("```toml") => open = Some(String::new()),
            (Some(_), l) if l.starts_with("```") => blocks.extend(open.take()),
            (Some(block), _) => {
                block.push_str(line);
                block.push('\n');
            }
            (None, _) => {}
        }
    }
    blocks
}

/// The files under `dir` (recursively) whose name ends in `.ext`, sorted.
fn files_ending(dir: &Path, ext: &str) -> Result<Vec<PathBuf>> {
    let mut found = Vec::new();
    for entry in fs::read_dir(dir)? {
        let path = entry?.path();
        if path.is_dir() {
            found.extend(files_ending(&path, ext)?);
        } else if path.extension().is_some_and(|e| e == ext) {
            found.push(path);
        }
    }
    found.sort();
    Ok(found)
}

/// Copies `files` into `dir`, named by their index and file name.
fn copy_all(dir: &Path, files: &[PathBuf]) -> Result<()> {
    fs::create_dir_all(dir)?;
    for (n, file) in files.iter().enumerate() {
        let name = file
            .file_name()
            .ok_or("a file without a name")?
            .to_string_lossy();
        fs::copy(file, dir.join(format!("{n:02}-{name}")))?;
    }
    Ok(())
}
