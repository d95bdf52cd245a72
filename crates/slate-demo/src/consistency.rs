//! Do the boards agree? The team's view — the console and every surviving robot's
//! execution controller — must hold the same objects of the team classes with the same
//! values. What a dead module wrote last may have reached only some boards (nobody can
//! repeat it for it: docs/ici.md, "Limits"), so its packets, and objects it owned, are
//! left out of the comparison.
//!
//! Two measures: [`disagreement`] (do they agree now?) and [`Propagation`] (how long did
//! each change take to reach every board?).

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::sync::Arc;

use parking_lot::Mutex;
use slate_model::{Address, Board, ChangeHook, ObjectId, Snapshot, Touched, Value};

use crate::module::{Module, Role};
use crate::team::Team;

/// The classes every board of the team view models.
pub const TEAM_CLASSES: [&str; 4] = ["Robot", "Target", "Waypoint", "Mission"];

/// (object, attribute): an object itself is `(name, "")`.
type Key = (Arc<str>, Arc<str>);

/// Key → (value, source), on one board.
type View = BTreeMap<Key, (Value, Address)>;

/// The modules whose boards make the team view (the console, then every surviving
/// robot's execution controller), and the addresses of the dead modules.
fn team_view(team: &Team) -> (Vec<&Module>, BTreeSet<Address>) {
    let robot_dead = |m: &&Module| {
        let robot = team.robots.iter().position(|r| *r == m.robot);
        robot.is_some_and(|i| team.dead[i])
    };
    let dead: BTreeSet<Address> = team
        .modules
        .iter()
        .filter(robot_dead)
        .map(Module::stands_for)
        .collect();
    let mut boards = vec![team.console()];
    for i in (0..team.robots.len()).filter(|i| !team.dead[*i]) {
        boards.push(team.module(i, Role::Exec));
    }
    (boards, dead)
}

/// The boards of the team view and what each holds.
fn views(team: &Team) -> (Vec<(String, View)>, BTreeSet<Address>) {
    let (boards, dead) = team_view(team);
    let views = boards
        .iter()
        .map(|m| (m.address().to_string(), view(m.node.board())))
        .collect();
    (views, dead)
}

/// Stored values of the team classes; an object shows as `(name, "")` with its owner.
fn view(board: &Board) -> View {
    let snap = board.snapshot();
    let mut out = View::new();
    for class in TEAM_CLASSES {
        for id in snap.instances(class).unwrap_or_default() {
            insert_object(&snap, id, &mut out);
        }
    }
    out
}

/// Puts object `id`'s entries in `view` (it must be an object of a team class); returns
/// its name.
fn insert_object(snap: &Snapshot<'_>, id: ObjectId, view: &mut View) -> Option<Arc<str>> {
    let info = snap.info(id)?;
    let itself: Arc<str> = Arc::from("");
    view.insert((info.name.clone(), itself), (Value::Bool(true), info.owner));
    for (attr, p, _) in snap.own_values(id) {
        view.insert((info.name.clone(), attr), (p.value, p.source));
    }
    Some(info.name)
}

/// One board's [`view`], kept up to date between comparisons: a change hook notes the
/// objects of the team classes each revision touched (written, created, deleted), and
/// the next comparison reads those again, and only those. Every change of an object's
/// own values or existence touches it, so the view is the one [`view`] would build.
struct LiveView {
    touches: Arc<Touches>,
    view: Option<View>,
    /// The objects in the view, by handle (a deleted one's name is no longer on the
    /// board).
    names: HashMap<ObjectId, Arc<str>>,
}

/// The change hook of a [`LiveView`].
#[derive(Default)]
struct Touches {
    /// Objects touched since the view last looked.
    objects: Mutex<Vec<ObjectId>>,
    /// Per class seen, is it a team class or below one?
    team_class: Mutex<HashMap<ObjectId, bool>>,
}

impl ChangeHook for Touches {
    fn changed(&self, board: &Board, _revision: u64, touched: &[Touched]) {
        let mut classes = self.team_class.lock();
        let mut objects = self.objects.lock();
        for t in touched {
            let team = *classes.entry(t.class).or_insert_with(|| {
                (board.lineage(t.class).iter()).any(|c| {
                    board
                        .name_of(*c)
                        .is_some_and(|n| TEAM_CLASSES.contains(&&*n))
                })
            });
            if team && t.object != t.class {
                objects.push(t.object);
            }
        }
    }
}

impl LiveView {
    fn new(board: &Board) -> LiveView {
        let touches = Arc::new(Touches::default());
        board.add_hook(touches.clone());
        LiveView {
            touches,
            view: None,
            names: HashMap::new(),
        }
    }

    /// The view as the board holds it now.
    fn refresh(&mut self, board: &Board) -> &View {
        let touched = std::mem::take(&mut *self.touches.objects.lock());
        let snap = board.snapshot();
        let mut view = match self.view.take() {
            Some(view) => view,
            None => {
                let mut view = View::new();
                for class in TEAM_CLASSES {
                    for id in snap.instances(class).unwrap_or_default() {
                        if let Some(name) = insert_object(&snap, id, &mut view) {
                            self.names.insert(id, name);
                        }
                    }
                }
                return self.view.insert(view);
            }
        };
        // By name: an object deleted and another of the same name created both touch it.
        let mut stale: BTreeSet<Arc<str>> = BTreeSet::new();
        for id in touched {
            if let Some(name) = self.names.remove(&id).or_else(|| snap.name_of(id)) {
                stale.insert(name);
            }
        }
        let classes = self.touches.team_class.lock();
        for name in stale {
            let first = (name.clone(), Arc::<str>::from(""));
            let keys: Vec<Key> = (view.range(first..))
                .take_while(|(k, _)| k.0 == name)
                .map(|(k, _)| k.clone())
                .collect();
            for k in keys {
                view.remove(&k);
            }
            let team_object = snap.id_of(&name).filter(|id| {
                (snap.info(*id))
                    .filter(|i| !i.is_class)
                    .and_then(|i| snap.id_of(&i.class))
                    .is_some_and(|c| classes.get(&c).copied().unwrap_or(false))
            });
            if let Some(id) = team_object
                && let Some(name) = insert_object(&snap, id, &mut view)
            {
                self.names.insert(id, name);
            }
        }
        self.view.insert(view)
    }
}

/// The keys on which the views differ. Skipped: a key a dead module wrote (or, for an
/// object, owns) on any board, and every key of an object some board lacks while another
/// holds it from a dead owner (the dead module's last word reached only some boards).
///
/// Each view is walked once beside the first (both sorted): the team view has a board
/// per robot and its objects grow with the team too, and a lookup of every key on every
/// board for every other board was the demo's largest cost at 16 robots.
fn differing(views: &[(String, &View)], dead: &BTreeSet<Address>) -> BTreeMap<Key, String> {
    let Some(((first, base), _)) = views.split_first() else {
        return BTreeMap::new();
    };
    // Per key, the first board whose value differs from the first board's.
    let mut differs: BTreeMap<&Key, usize> = BTreeMap::new();
    for (k, (_, view)) in views.iter().enumerate().skip(1) {
        for key in unequal(base, view) {
            differs.entry(key).or_insert(k);
        }
    }
    let from_dead: BTreeSet<&Key> = match dead.is_empty() {
        true => BTreeSet::new(),
        false => (views.iter().flat_map(|(_, v)| v.iter()))
            .filter(|(_, (_, source))| dead.contains(source))
            .map(|(key, _)| key)
            .collect(),
    };
    // An object's key differs only where some board lacks it (its value is `true`).
    let orphans: BTreeSet<&Arc<str>> = (differs.keys())
        .filter(|key| key.1.is_empty() && from_dead.contains(*key))
        .map(|key| &key.0)
        .collect();
    let mut out = BTreeMap::new();
    for (key, k) in differs {
        if orphans.contains(&key.0) || from_dead.contains(key) {
            continue;
        }
        let show = |v: &View| v.get(key).map_or("nothing".to_owned(), |h| h.0.to_string());
        let what = if key.1.is_empty() {
            key.0.to_string()
        } else {
            format!("{}.{}", key.0, key.1)
        };
        let (other, view) = (&views[k].0, views[k].1);
        let text = format!(
            "{what}: {first} holds {}, {other} holds {}",
            show(base),
            show(view)
        );
        out.insert(key.clone(), text);
    }
    out
}

/// The keys `a` and `b` do not hold alike (one lacks it, or their values differ), in
/// order: one walk of both.
fn unequal<'a>(a: &'a View, b: &'a View) -> Vec<&'a Key> {
    let (mut a, mut b) = (a.iter().peekable(), b.iter().peekable());
    let mut out = Vec::new();
    loop {
        match (a.peek(), b.peek()) {
            (None, None) => return out,
            (Some((ka, _)), None) => {
                out.push(*ka);
                a.next();
            }
            (None, Some((kb, _))) => {
                out.push(*kb);
                b.next();
            }
            (Some((ka, va)), Some((kb, vb))) => match ka.cmp(kb) {
                std::cmp::Ordering::Less => {
                    out.push(*ka);
                    a.next();
                }
                std::cmp::Ordering::Greater => {
                    out.push(*kb);
                    b.next();
                }
                std::cmp::Ordering::Equal => {
                    if va.0 != vb.0 {
                        out.push(*ka);
                    }
                    a.next();
                    b.next();
                }
            },
        }
    }
}

/// The first disagreement between the team-view boards, or `None` if they agree.
pub fn disagreement(team: &Team) -> Option<String> {
    let (views, dead) = views(team);
    let views: Vec<(String, &View)> = views.iter().map(|(a, v)| (a.clone(), v)).collect();
    differing(&views, &dead).into_values().next()
}

/// How long each change took to reach every board of the team view: a key opens when
/// the boards start to differ on it and closes when they agree again.
#[derive(Default)]
pub struct Propagation {
    open: BTreeMap<Key, f64>,
    /// Seconds each closed difference lasted.
    pub delays: Vec<f64>,
    /// Per module address, the view of its board, kept up to date.
    live: HashMap<Address, LiveView>,
}

impl Propagation {
    /// Compares the boards at world time `t`.
    pub fn observe(&mut self, team: &Team, t: f64) {
        let now = self.differing(team);
        let closed: Vec<Key> = self
            .open
            .keys()
            .filter(|k| !now.contains_key(*k))
            .cloned()
            .collect();
        for key in closed {
            if let Some(since) = self.open.remove(&key) {
                self.delays.push(t - since);
            }
        }
        for key in now.into_keys() {
            self.open.entry(key).or_insert(t);
        }
    }

    /// What [`disagreement`] says, from the views kept up to date (each board's touched
    /// objects read again, not every object of every board at each call: the end of a
    /// run asks at every step until the boards agree). Opens and closes nothing.
    pub fn disagreement(&mut self, team: &Team) -> Option<String> {
        self.differing(team).into_values().next()
    }

    /// The boards' differences now, as [`differing`] finds them in the live views.
    fn differing(&mut self, team: &Team) -> BTreeMap<Key, String> {
        let (boards, dead) = team_view(team);
        for m in &boards {
            let board = m.node.board();
            let live =
                (self.live.entry(m.address().clone())).or_insert_with(|| LiveView::new(board));
            live.refresh(board);
        }
        let views: Vec<(String, &View)> = (boards.iter())
            .filter_map(|m| {
                let view = self.live.get(m.address())?.view.as_ref()?;
                Some((m.address().to_string(), view))
            })
            .collect();
        differing(&views, &dead)
    }

    /// The `q` quantile (0..=1) of the delays.
    pub fn quantile(&self, q: f64) -> Option<f64> {
        let mut d = self.delays.clone();
        d.sort_by(f64::total_cmp);
        let i = ((d.len() as f64 - 1.0) * q.clamp(0.0, 1.0)).round() as usize;
        d.get(i).copied()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The comparison as it was first written: every key of every board looked up on
    /// every board. `differing` must say exactly what it says.
    fn differing_by_lookups(
        views: &[(String, View)],
        dead: &BTreeSet<Address>,
    ) -> BTreeMap<Key, String> {
        let keys: BTreeSet<&Key> = views.iter().flat_map(|(_, v)| v.keys()).collect();
        let from_dead = |key: &Key| {
            (views.iter()).any(|(_, v)| v.get(key).is_some_and(|(_, s)| dead.contains(s)))
        };
        let orphans: BTreeSet<&Arc<str>> = (keys.iter())
            .filter(|k| {
                k.1.is_empty() && from_dead(k) && views.iter().any(|(_, v)| !v.contains_key(*k))
            })
            .map(|k| &k.0)
            .collect();
        let mut out = BTreeMap::new();
        for key in keys {
            if orphans.contains(&key.0) || from_dead(key) {
                continue;
            }
            let held: Vec<Option<&Value>> = views
                .iter()
                .map(|(_, v)| v.get(key).map(|h| &h.0))
                .collect();
            if let Some(k) = held.iter().position(|h| *h != held[0]) {
                let show = |h: Option<&Value>| h.map_or("nothing".to_owned(), ToString::to_string);
                let what = if key.1.is_empty() {
                    key.0.to_string()
                } else {
                    format!("{}.{}", key.0, key.1)
                };
                let text = format!(
                    "{what}: {} holds {}, {} holds {}",
                    views[0].0,
                    show(held[0]),
                    views[k].0,
                    show(held[k])
                );
                out.insert(key.clone(), text);
            }
        }
        out
    }

    /// Draws below `n`, from a seed (a linear congruential generator).
    fn draws(mut seed: u64) -> impl FnMut(u64) -> u64 {
        move |n| {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 33) % n
        }
    }

    #[test]
    fn a_live_view_is_the_view_a_board_would_give_after_any_change() {
        use slate_model::{AttrDecl, ClassDef, Clock, NewObject, ValueType};
        let board = Board::builder().clock(Clock::manual()).build();
        let int = |name: &str| AttrDecl::new(name, ValueType::Int);
        board
            .define(ClassDef::new("Target").attr(int("found")).attr(int("x")))
            .unwrap();
        board
            .define(ClassDef::new("Decoy").parent("Target"))
            .unwrap();
        board
            .define(ClassDef::new("Rock").attr(int("found")))
            .unwrap();
        board.create("Target", "t0").unwrap();
        let mut live = LiveView::new(&board);
        let mut draw = draws(11);
        let names = ["t0", "t1", "t2", "t3"];
        let source = Address::new("team/r2/exec").unwrap();
        for step in 0..2000 {
            let name = names[draw(4) as usize];
            let value = draw(5) as i64;
            let _ = match draw(8) {
                // Objects of a team class, of a subclass, of another class, by one name.
                0 => board
                    .create(["Target", "Decoy", "Rock"][draw(3) as usize], name)
                    .map(drop)
                    .map_err(drop),
                1 => board.delete(name).map(drop).map_err(drop),
                2 => board
                    .create_with(NewObject::new("Target", name).owner(source.clone()))
                    .map(drop)
                    .map_err(drop),
                // A class-level value: not an object's own.
                3 => board.write("Target", "x", value).map(drop).map_err(drop),
                // A batch that fails half-way applies nothing.
                4 => {
                    let mut batch = board.batch();
                    batch.write(name, "found", value).delete("nobody");
                    batch.commit().map(drop).map_err(drop)
                }
                5 => board.write(name, "x", value).map(drop).map_err(drop),
                _ => board.write(name, "found", value).map(drop).map_err(drop),
            };
            if draw(3) == 0 {
                assert_eq!(*live.refresh(&board), view(&board), "step {step}");
            }
        }
        assert_eq!(*live.refresh(&board), view(&board));
    }

    #[test]
    fn one_walk_per_board_finds_what_a_lookup_of_every_key_finds() {
        let sources =
            ["team/r1/exec", "team/r2/exec", "team/r3/exec"].map(|a| Address::new(a).unwrap());
        let dead: BTreeSet<Address> = [sources[2].clone()].into();
        let mut draw = draws(7);
        let mut differences = 0;
        for _ in 0..500 {
            let boards = 1 + draw(4) as usize;
            let views: Vec<(String, View)> = (0..boards)
                .map(|b| {
                    let mut view = View::new();
                    for object in ["t1", "t2", "w1"] {
                        for attr in ["", "found_by", "visited"] {
                            if draw(4) == 0 {
                                continue;
                            }
                            let value = match attr {
                                "" => Value::Bool(true),
                                _ => Value::Int(draw(2) as i64),
                            };
                            let source = sources[draw(3) as usize].clone();
                            view.insert((object.into(), attr.into()), (value, source));
                        }
                    }
                    (format!("board{b}"), view)
                })
                .collect();
            let expected = differing_by_lookups(&views, &dead);
            differences += expected.len();
            let refs: Vec<(String, &View)> = views.iter().map(|(a, v)| (a.clone(), v)).collect();
            assert_eq!(differing(&refs, &dead), expected, "{views:?}");
        }
        assert!(
            differences > 100,
            "the draws must make differences: {differences}"
        );
    }
}
