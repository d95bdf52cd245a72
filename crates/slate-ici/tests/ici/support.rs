//! A team on a simulated network, and the convergence check.

use std::sync::Arc;
use std::time::Duration;

use slate_ici::{ClassSet, Ici, IciConfig, IciStats, MODULE_CLASS, Rng, SimConfig, SimNet};
use slate_model::{
    Address, AttrDecl, Board, ClassDef, Context, MergePolicy, NewObject, ObjectInfo, Packet,
    Update, Value, ValueType,
};

pub use slate_testing::addr;

pub fn secs(s: f64) -> Duration {
    Duration::from_secs_f64(s)
}

/// The classes every test board knows.
pub fn classes() -> Vec<ClassDef> {
    let real = |n| AttrDecl::new(n, ValueType::Real);
    vec![
        ClassDef::new("Tracked")
            .attr(real("x"))
            .attr(real("y"))
            .attr(AttrDecl::new("label", ValueType::Str))
            .attr(AttrDecl::new("hits", ValueType::Int))
            .attr(real("seen").merge(MergePolicy::Confident)),
        ClassDef::new("Rock").parent("Tracked"),
        ClassDef::new("Vehicle")
            .attr(real("speed"))
            .attr(real("heading").merge(MergePolicy::Owned))
            .attr(AttrDecl::new("mode", ValueType::Str)),
        ClassDef::new("Target").attr(real("range").merge(MergePolicy::Fused)),
        ClassDef::new("Raw").attr(real("sample")),
    ]
}

/// One module: its board, its ICI, and the config it runs.
pub struct Member {
    pub address: Address,
    pub board: Arc<Board>,
    pub ici: Ici,
    pub config: IciConfig,
}

/// Modules on one simulated network.
pub struct Team {
    pub net: SimNet,
    pub members: Vec<Member>,
}

impl Team {
    pub fn new(seed: u64) -> Self {
        Team::with(seed, SimConfig::default())
    }

    pub fn with(seed: u64, config: SimConfig) -> Self {
        Team {
            net: SimNet::with_config(seed, config),
            members: Vec::new(),
        }
    }

    /// A team of the modules `members` (address and config), with the test classes.
    pub fn of<'a>(seed: u64, members: impl IntoIterator<Item = (&'a str, IciConfig)>) -> Self {
        let mut team = Team::new(seed);
        for (address, config) in members {
            team.add(address, config);
        }
        team
    }

    /// A team of `robots` × `modules`, everyone interested in everything and exporting
    /// everything: `t/r{i}/m{j}`.
    pub fn grid(seed: u64, config: SimConfig, robots: usize, modules: usize) -> Self {
        let mut team = Team::with(seed, config);
        for r in 0..robots {
            for m in 0..modules {
                team.add(&format!("t/r{r}/m{m}"), open());
            }
        }
        team
    }

    /// Adds a module with the test classes defined.
    pub fn add(&mut self, address: &str, config: IciConfig) -> &Member {
        self.add_with(address, config, &classes())
    }

    pub fn add_with(&mut self, address: &str, config: IciConfig, defs: &[ClassDef]) -> &Member {
        let address = addr(address);
        let board = self.board_at(&address, defs);
        self.join(board, config)
    }

    /// Starts an ICI on `board` (made by [`board_at`](Self::board_at) and filled, as a
    /// node loads its files or restores its state before it joins) and makes it a member.
    pub fn join(&mut self, board: Arc<Board>, config: IciConfig) -> &Member {
        let address = board.address().clone();
        let transport = self.net.join(&address);
        let ici = Ici::new(board.clone(), transport, config.clone()).unwrap();
        self.put(Member {
            address,
            board,
            ici,
            config,
        })
    }

    /// A new board at `address` on the network's clock, with `defs` defined; not yet a
    /// member.
    pub fn board_at(&self, address: &Address, defs: &[ClassDef]) -> Arc<Board> {
        let board = Board::builder()
            .clock(self.net.clock())
            .address(address.clone())
            .build();
        for def in defs {
            board.define(def.clone()).unwrap();
        }
        Arc::new(board)
    }

    /// Makes `member` part of the team, in place of any member at its address.
    pub fn put(&mut self, member: Member) -> &Member {
        self.members.retain(|n| n.address != member.address);
        self.members.push(member);
        self.members.last().unwrap()
    }

    pub fn member(&self, address: &str) -> &Member {
        let a = addr(address);
        self.members
            .iter()
            .find(|n| n.address == a)
            .unwrap_or_else(|| panic!("no member {address}"))
    }

    pub fn board(&self, address: &str) -> &Arc<Board> {
        &self.member(address).board
    }

    pub fn run(&self, s: f64) {
        self.net.run_for(secs(s));
    }

    /// `figure` of every member's ICI statistics, summed over the team.
    pub fn total(&self, figure: impl Fn(&IciStats) -> u64) -> u64 {
        self.members.iter().map(|n| figure(&n.ici.stats())).sum()
    }

    /// Kills the module at `address` on the network and drops it from the team.
    pub fn kill(&mut self, address: &str) {
        let a = addr(address);
        self.net.kill(&a);
        self.members.retain(|n| n.address != a);
    }

    /// Writes each of `values` to `object.attr` on the board at `board`, running the team
    /// `dt` seconds after each write.
    pub fn write_series(
        &self,
        board: &str,
        object: &str,
        attr: &str,
        values: impl IntoIterator<Item = u32>,
        dt: f64,
    ) {
        let board = self.board(board);
        for v in values {
            board.write(object, attr, f64::from(v)).unwrap();
            self.run(dt);
        }
    }

    /// Runs in one-second steps until the boards agree or `max` seconds pass; returns
    /// the last disagreement.
    pub fn settle(&self, max: u32) -> Option<String> {
        for _ in 0..max {
            // `?`: nothing differs, the boards agree.
            divergence(&self.members)?;
            self.run(1.0);
        }
        divergence(&self.members)
    }

    /// Panics with the disagreement if the boards do not agree within `max` seconds.
    pub fn assert_converges(&self, max: u32) {
        if let Some(d) = self.settle(max) {
            panic!("boards did not converge in {max} s: {d}");
        }
    }
}

/// Interest in everything, export of everything.
pub fn open() -> IciConfig {
    IciConfig::default().export(ClassSet::all())
}

/// The chain of `class` on `board`, class first.
pub fn lineage(board: &Board, class: &str) -> Vec<Arc<str>> {
    let Some(info) = board.info(class) else {
        return Vec::new();
    };
    board
        .lineage(info.id)
        .into_iter()
        .filter_map(|id| board.name_of(id))
        .collect()
}

/// Does `b` model the object `info` that another board holds?
fn models(b: &Member, info: &ObjectInfo) -> bool {
    if info.is_class {
        return b.board.info(&info.name).is_some();
    }
    let context = match b.board.info(&info.name) {
        Some(mine) => mine.context,
        None if info.context == Context::Self_ && robot(&info.owner) != robot(&b.address) => {
            Context::System
        }
        None => info.context,
    };
    b.config
        .interest
        .contains(&lineage(&b.board, &info.class), context)
}

fn robot(a: &Address) -> (&str, &str) {
    (a.team(), a.robot())
}

/// The packets an object holds itself, by attribute.
pub fn own(board: &Board, name: &str) -> Vec<(Arc<str>, Packet)> {
    let snap = board.snapshot();
    let Some(id) = snap.id_of(name) else {
        return Vec::new();
    };
    snap.own_values(id)
        .into_iter()
        .map(|(a, p, _)| (a, p))
        .collect()
}

/// The first disagreement between the boards: an object one holds that another board
/// modelling it lacks, or holds with other packets. `Module` objects are local facts
/// and left out.
pub fn divergence(members: &[Member]) -> Option<String> {
    for a in members {
        let infos: Vec<ObjectInfo> = {
            let snap = a.board.snapshot();
            snap.objects()
                .into_iter()
                .filter_map(|id| snap.info(id))
                .collect()
        };
        for info in infos.iter().filter(|i| &*i.class != MODULE_CLASS) {
            let mine = own(&a.board, &info.name);
            for b in members
                .iter()
                .filter(|b| b.address != a.address && models(b, info))
            {
                if b.board.info(&info.name).is_none() {
                    return Some(format!(
                        "{} holds {} but {} does not",
                        a.address, info.name, b.address
                    ));
                }
                let theirs = own(&b.board, &info.name);
                if mine != theirs {
                    return Some(format!(
                        "{}: {} has {:?}\n  but {} has {:?}",
                        info.name, a.address, mine, b.address, theirs
                    ));
                }
            }
        }
    }
    None
}

/// Random work on random boards: creations, deletions of own objects, class-level
/// writes, and writes of every merge policy (owned only by the owner), `steps` times,
/// `dt` seconds apart.
pub fn workload(team: &Team, rng: &mut Rng, steps: usize, dt: f64) {
    for _ in 0..steps {
        let member = &team.members[rng.below(team.members.len() as u64) as usize];
        let roll = rng.below(100);
        match roll {
            0..10 => create(member, rng),
            10..13 => delete_own(member, rng),
            13..15 => {
                let label = format!("class{}", rng.below(5));
                let _ = member.board.write("Tracked", "label", label);
            }
            _ => write_some(member, rng),
        }
        team.run(dt);
    }
}

fn create(member: &Member, rng: &mut Rng) {
    let class = ["Rock", "Vehicle", "Target"][rng.below(3) as usize];
    let context = [Context::Self_, Context::Surroundings, Context::System][rng.below(3) as usize];
    let (robot, module) = (member.address.robot(), member.address.module());
    let name = format!(
        "{}_{robot}_{module}_{}",
        class.to_lowercase(),
        rng.below(1 << 20)
    );
    let _ = member
        .board
        .create_with(NewObject::new(class, &name).context(context));
}

fn objects(member: &Member) -> Vec<ObjectInfo> {
    let snap = member.board.snapshot();
    snap.objects()
        .into_iter()
        .filter_map(|id| snap.info(id))
        .filter(|i| !i.is_class && &*i.class != MODULE_CLASS)
        .collect()
}

fn delete_own(member: &Member, rng: &mut Rng) {
    let own: Vec<_> = objects(member)
        .into_iter()
        .filter(|i| i.owner == member.address)
        .collect();
    if !own.is_empty() {
        let victim = &own[rng.below(own.len() as u64) as usize];
        let _ = member.board.delete(&victim.name);
    }
}

fn write_some(member: &Member, rng: &mut Rng) {
    let all = objects(member);
    if all.is_empty() {
        return create(member, rng);
    }
    let o = &all[rng.below(all.len() as u64) as usize];
    let v = (rng.next_f64() * 1000.0).round() / 8.0;
    let b = &member.board;
    let _ = match (&*o.class, rng.below(4)) {
        ("Rock", 0) => b.write(&o.name, "x", v),
        ("Rock", 1) => b.write(&o.name, "hits", Value::Int(rng.below(100) as i64)),
        ("Rock", 2) => b.write(&o.name, "seen", Update::new(v).confidence(rng.next_f64())),
        ("Rock", _) => b.write(&o.name, "label", format!("l{}", rng.below(10))),
        ("Vehicle", 0) if o.owner == member.address => b.write(&o.name, "heading", v),
        ("Vehicle", 1) => b.write(&o.name, "mode", format!("m{}", rng.below(4))),
        ("Vehicle", _) => b.write(&o.name, "speed", v),
        (_, _) => b.write(
            &o.name,
            "range",
            Update::new(v).accuracy(0.5 + rng.next_f64() * 5.0),
        ),
    };
}

/// A transport that records what it publishes on the team link (how many of each kind,
/// the largest) and passes everything on unchanged.
pub struct Tap {
    inner: Arc<dyn slate_ici::Transport>,
    counts: parking_lot::Mutex<std::collections::BTreeMap<slate_ici::MsgKind, u64>>,
    largest: std::sync::atomic::AtomicUsize,
}

impl Tap {
    /// Team publications of `kind`.
    pub fn count(&self, kind: slate_ici::MsgKind) -> u64 {
        self.counts.lock().get(&kind).copied().unwrap_or(0)
    }

    /// Team publications by kind.
    pub fn counts(&self) -> std::collections::BTreeMap<slate_ici::MsgKind, u64> {
        self.counts.lock().clone()
    }

    /// The largest team publication, in bytes.
    pub fn largest(&self) -> usize {
        self.largest.load(std::sync::atomic::Ordering::Relaxed)
    }
}

impl slate_ici::Transport for Tap {
    fn address(&self) -> &Address {
        self.inner.address()
    }
    fn set_handler(&self, handler: Arc<dyn slate_ici::Handler>) {
        self.inner.set_handler(handler)
    }
    fn publish(
        &self,
        link: slate_ici::LinkKind,
        kind: slate_ici::MsgKind,
        payload: &[u8],
    ) -> Result<(), slate_ici::SendError> {
        if link == slate_ici::LinkKind::Team {
            *self.counts.lock().entry(kind).or_default() += 1;
            self.largest
                .fetch_max(payload.len(), std::sync::atomic::Ordering::Relaxed);
        }
        self.inner.publish(link, kind, payload)
    }
    fn send(
        &self,
        to: &Address,
        kind: slate_ici::MsgKind,
        payload: &[u8],
    ) -> Result<(), slate_ici::SendError> {
        self.inner.send(to, kind, payload)
    }
    fn listen(&self, link: slate_ici::LinkKind, on: bool) -> bool {
        self.inner.listen(link, on)
    }
    fn peers(&self) -> Vec<Address> {
        self.inner.peers()
    }
    fn stats(&self) -> slate_ici::LinkStats {
        self.inner.stats()
    }
    fn close(&self) {
        self.inner.close()
    }
}

impl Team {
    /// Adds module `address` (the test classes, `config`) whose transport is a [`Tap`].
    pub fn join_tapped(&mut self, address: &str, config: IciConfig) -> Arc<Tap> {
        let address = addr(address);
        let board = self.board_at(&address, &classes());
        let tap = Arc::new(Tap {
            inner: self.net.join(&address),
            counts: parking_lot::Mutex::default(),
            largest: std::sync::atomic::AtomicUsize::new(0),
        });
        let ici = Ici::new(board.clone(), tap.clone(), config.clone()).unwrap();
        self.put(Member {
            address,
            board,
            ici,
            config,
        });
        tap
    }
}
