//! The redb database of a node's state: one table each for the module it belongs to,
//! the class definitions, the objects and the packets, every value JSON.

use std::path::{Path, PathBuf};
use std::str::FromStr;

use redb::{Database, ReadableTable, TableDefinition};
use serde_json::{Value as Json, json};
use slate_ici::HeldPlan;
use slate_model::{Address, ClassDef, Context, NewObject, Packet};
use slate_plans::{PlanProgress, PlanState};

use super::pending::{ObjectRecord, Pending};
use super::{Durability, StateError};
use crate::record::message;

/// The database's file name in the state directory.
pub const FILE: &str = "board.redb";

/// `address`: the module whose board this is; `format`: [`FORMAT`].
const META: TableDefinition<&str, &str> = TableDefinition::new("meta");
/// Class name → its definition (the JSON of a recording's `/slate/classes`).
const CLASSES: TableDefinition<&str, &[u8]> = TableDefinition::new("classes");
/// Object name → `{"class", "context", "owner"}`.
const OBJECTS: TableDefinition<&str, &[u8]> = TableDefinition::new("objects");
/// `(object or class, attribute)` → `{"value", "accuracy", "confidence", "hlc", "source"}`.
const PACKETS: TableDefinition<(&str, &str), &[u8]> = TableDefinition::new("packets");
/// Plan name → `{"from", "circuit", "origin", "text", "next_step", "state", "fired",
/// "trigger_held"}`: the plans other modules sent that the node runs ([`HeldPlan`]).
/// A row of an earlier build without the last three takes the plan up as pending.
const PLANS: TableDefinition<&str, &[u8]> = TableDefinition::new("plans");
/// The layout of the tables above; a store of another format is refused.
const FORMAT: &str = "1";

/// A packet as stored: its value is JSON until the board says the attribute's type.
#[derive(Clone, Debug, PartialEq)]
pub struct SavedPacket {
    /// Object (or class, for a class-level value).
    pub object: String,
    /// Attribute.
    pub attr: String,
    /// The value as stored (`null`: cleared).
    pub value: Json,
    /// The packet, its value left `None`.
    pub packet: Packet,
}

/// Everything a store holds, read back.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Saved {
    /// Class definitions, in name order.
    pub classes: Vec<ClassDef>,
    /// Objects, in name order.
    pub objects: Vec<NewObject>,
    /// Packets, by object then attribute.
    pub packets: Vec<SavedPacket>,
    /// Plans other modules sent that the node ran, by name.
    pub plans: Vec<HeldPlan>,
}

/// A node's state directory, open.
pub struct Store {
    db: Database,
    dir: PathBuf,
    durability: Durability,
}

impl Store {
    /// Opens (or creates) the store in `dir` for the module `address`: an error naming
    /// the directory if it cannot be opened, is damaged, or holds another module's board.
    pub fn open(
        dir: &Path,
        address: &Address,
        durability: Durability,
    ) -> Result<Store, StateError> {
        let open_error = |why: String| StateError::Open {
            dir: dir.to_owned(),
            why,
        };
        std::fs::create_dir_all(dir).map_err(|e| open_error(e.to_string()))?;
        unless_it_panics(dir, || {
            let db = Database::create(dir.join(FILE)).map_err(|e| database_error(dir, e))?;
            let store = Store {
                db,
                dir: dir.to_owned(),
                durability,
            };
            store.claim(address)?;
            Ok(store)
        })
    }

    /// The directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Checks that the store is of this format and this module's (marking a new one so).
    fn claim(&self, address: &Address) -> Result<(), StateError> {
        let txn = self.db.begin_write().map_err(|e| self.corrupt(e))?;
        {
            let mut meta = txn.open_table(META).map_err(|e| self.corrupt(e))?;
            let stored = |key| -> Result<Option<String>, StateError> {
                let v = meta.get(key).map_err(|e| self.corrupt(e))?;
                Ok(v.map(|v| v.value().to_owned()))
            };
            let (format, owner) = (stored("format")?, stored("address")?);
            self.check(format.as_deref(), owner.as_deref(), address)?;
            meta.insert("format", FORMAT).map_err(|e| self.corrupt(e))?;
            meta.insert("address", address.as_str())
                .map_err(|e| self.corrupt(e))?;
        }
        txn.commit().map_err(|e| self.write_error(e))
    }

    fn check(
        &self,
        format: Option<&str>,
        owner: Option<&str>,
        address: &Address,
    ) -> Result<(), StateError> {
        if let Some(f) = format.filter(|f| *f != FORMAT) {
            return Err(StateError::Corrupt {
                dir: self.dir.clone(),
                why: format!("store format {f}, this slate reads {FORMAT}"),
            });
        }
        match owner {
            Some(o) if o != address.as_str() => Err(StateError::OtherModule {
                dir: self.dir.clone(),
                stored: o.to_owned(),
                node: address.to_string(),
            }),
            _ => Ok(()),
        }
    }

    /// Everything the store holds.
    pub fn load(&self) -> Result<Saved, StateError> {
        unless_it_panics(&self.dir, || self.read_all())
    }

    fn read_all(&self) -> Result<Saved, StateError> {
        let txn = self.db.begin_read().map_err(|e| self.corrupt(e))?;
        let mut saved = Saved::default();
        let Ok(classes) = txn.open_table(CLASSES) else {
            return Ok(saved); // a store never committed to holds no table yet
        };
        for row in classes.iter().map_err(|e| self.corrupt(e))? {
            let (name, bytes) = row.map_err(|e| self.corrupt(e))?;
            let def = parse(bytes.value()).and_then(|j| crate::record::class_def(&j));
            saved
                .classes
                .push(def.ok_or_else(|| self.bad_entry("class", name.value()))?);
        }
        let objects = txn.open_table(OBJECTS).map_err(|e| self.corrupt(e))?;
        for row in objects.iter().map_err(|e| self.corrupt(e))? {
            let (name, bytes) = row.map_err(|e| self.corrupt(e))?;
            let object = parse(bytes.value()).and_then(|j| new_object(name.value(), &j));
            saved
                .objects
                .push(object.ok_or_else(|| self.bad_entry("object", name.value()))?);
        }
        let packets = txn.open_table(PACKETS).map_err(|e| self.corrupt(e))?;
        for row in packets.iter().map_err(|e| self.corrupt(e))? {
            let (key, bytes) = row.map_err(|e| self.corrupt(e))?;
            let (object, attr) = key.value();
            let packet = parse(bytes.value()).and_then(|j| saved_packet(object, attr, &j));
            let what = format!("{object}.{attr}");
            saved
                .packets
                .push(packet.ok_or_else(|| self.bad_entry("packet", &what))?);
        }
        // A store of an earlier build has no plans table: it held no plans.
        if let Ok(plans) = txn.open_table(PLANS) {
            for row in plans.iter().map_err(|e| self.corrupt(e))? {
                let (name, bytes) = row.map_err(|e| self.corrupt(e))?;
                let plan = parse(bytes.value()).and_then(|j| held_plan(name.value(), &j));
                saved
                    .plans
                    .push(plan.ok_or_else(|| self.bad_entry("plan", name.value()))?);
            }
        }
        Ok(saved)
    }

    /// Writes what is pending in one transaction, with the store's durability.
    pub(crate) fn commit(&self, p: &Pending) -> Result<(), StateError> {
        let mut txn = self.db.begin_write().map_err(|e| self.write_error(e))?;
        txn.set_durability(match self.durability {
            Durability::Immediate => redb::Durability::Immediate,
            Durability::Eventual => redb::Durability::Eventual,
        });
        if p.wipe {
            for table in [CLASSES, OBJECTS] {
                txn.delete_table(table).map_err(|e| self.write_error(e))?;
            }
            txn.delete_table(PACKETS).map_err(|e| self.write_error(e))?;
        }
        self.write(&txn, p)?;
        txn.commit().map_err(|e| self.write_error(e))
    }

    fn write(&self, txn: &redb::WriteTransaction, p: &Pending) -> Result<(), StateError> {
        let w = |e: redb::Error| self.write_error(e);
        let mut classes = txn.open_table(CLASSES).map_err(|e| w(e.into()))?;
        let mut objects = txn.open_table(OBJECTS).map_err(|e| w(e.into()))?;
        let mut packets = txn.open_table(PACKETS).map_err(|e| w(e.into()))?;
        if let Some(defs) = &p.classes {
            classes.retain(|_, _| false).map_err(|e| w(e.into()))?;
            for def in defs {
                let bytes = to_bytes(&message::class_def(def));
                classes
                    .insert(def.name.as_str(), &*bytes)
                    .map_err(|e| w(e.into()))?;
            }
        }
        for name in &p.deleted {
            objects.remove(&**name).map_err(|e| w(e.into()))?;
            let range = (&**name, "")..=(&**name, "\u{10ffff}");
            packets
                .retain_in::<(&str, &str), _>(range, |_, _| false)
                .map_err(|e| w(e.into()))?;
        }
        for (name, r) in &p.objects {
            let bytes = to_bytes(&object_json(r));
            objects.insert(&**name, &*bytes).map_err(|e| w(e.into()))?;
        }
        for ((object, attr), packet) in &p.packets {
            let bytes = to_bytes(&packet_json(packet));
            packets
                .insert((&**object, &**attr), &*bytes)
                .map_err(|e| w(e.into()))?;
        }
        match &p.plans {
            Some(held) => self.write_plans(txn, held),
            None => Ok(()),
        }
    }

    /// Replaces the plans the store holds by `held`.
    fn write_plans(
        &self,
        txn: &redb::WriteTransaction,
        held: &[HeldPlan],
    ) -> Result<(), StateError> {
        let w = |e: redb::Error| self.write_error(e);
        let mut plans = txn.open_table(PLANS).map_err(|e| w(e.into()))?;
        plans.retain(|_, _| false).map_err(|e| w(e.into()))?;
        for plan in held {
            let bytes = to_bytes(&plan_json(plan));
            plans
                .insert(plan.name.as_str(), &*bytes)
                .map_err(|e| w(e.into()))?;
        }
        Ok(())
    }

    fn corrupt(&self, e: impl Into<redb::Error>) -> StateError {
        let e: redb::Error = e.into();
        match e {
            redb::Error::Io(io) if !damaged(&io) => StateError::Open {
                dir: self.dir.clone(),
                why: io.to_string(),
            },
            other => StateError::Corrupt {
                dir: self.dir.clone(),
                why: other.to_string(),
            },
        }
    }

    fn bad_entry(&self, what: &str, name: &str) -> StateError {
        StateError::Corrupt {
            dir: self.dir.clone(),
            why: format!("the {what} entry `{name}` cannot be read"),
        }
    }

    fn write_error(&self, e: impl Into<redb::Error>) -> StateError {
        StateError::Write {
            dir: self.dir.clone(),
            why: e.into().to_string(),
        }
    }
}

/// Why the database of `dir` did not open: damaged (or not a redb file), or not
/// openable at all (permissions, another process holds it).
fn database_error(dir: &Path, e: redb::DatabaseError) -> StateError {
    let dir = dir.to_owned();
    match e {
        redb::DatabaseError::Storage(redb::StorageError::Io(io)) if !damaged(&io) => {
            StateError::Open {
                dir,
                why: io.to_string(),
            }
        }
        redb::DatabaseError::DatabaseAlreadyOpen => StateError::Open {
            dir,
            why: "another process has it open".into(),
        },
        other => StateError::Corrupt {
            dir,
            why: other.to_string(),
        },
    }
}

/// Runs `f`, a read of a store's file; a panic in it is the file's damage, as an error.
/// redb checks its pages' checksums, but some damage makes it index out of bounds
/// instead: a state directory must never crash the node that reads it.
fn unless_it_panics<T>(
    dir: &Path,
    f: impl FnOnce() -> Result<T, StateError>,
) -> Result<T, StateError> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).unwrap_or_else(|_| {
        Err(StateError::Corrupt {
            dir: dir.to_owned(),
            why: "its database is damaged (the reader failed inside it)".into(),
        })
    })
}

/// Does an I/O error say the file's bytes are wrong (rather than that it cannot be
/// reached)? redb reports a file too short or not its own this way.
fn damaged(e: &std::io::Error) -> bool {
    matches!(
        e.kind(),
        std::io::ErrorKind::InvalidData | std::io::ErrorKind::UnexpectedEof
    )
}

fn parse(bytes: &[u8]) -> Option<Json> {
    serde_json::from_slice(bytes).ok()
}

fn to_bytes(j: &Json) -> Vec<u8> {
    serde_json::to_vec(j).unwrap_or_default()
}

fn object_json(r: &ObjectRecord) -> Json {
    json!({
        "class": &*r.class, "context": r.context.to_string(), "owner": r.owner.as_str(),
    })
}

fn new_object(name: &str, j: &Json) -> Option<NewObject> {
    let context = Context::from_str(j["context"].as_str()?).ok()?;
    let owner = Address::new(j["owner"].as_str()?).ok()?;
    Some(
        NewObject::new(j["class"].as_str()?, name)
            .context(context)
            .owner(owner),
    )
}

fn packet_json(p: &Packet) -> Json {
    json!({
        "value": message::value(&p.value), "accuracy": p.accuracy,
        "confidence": p.confidence, "hlc": p.timestamp.raw(), "source": p.source.as_str(),
    })
}

fn saved_packet(object: &str, attr: &str, j: &Json) -> Option<SavedPacket> {
    Some(SavedPacket {
        object: object.to_owned(),
        attr: attr.to_owned(),
        value: j["value"].clone(),
        packet: crate::record::packet_meta(j)?,
    })
}

fn plan_json(p: &HeldPlan) -> Json {
    json!({
        "from": p.from.as_str(), "circuit": p.circuit, "origin": p.origin.as_str(),
        "text": p.text, "next_step": p.next_step, "state": p.progress.state.name(),
        "fired": p.progress.fired, "trigger_held": p.progress.trigger_held,
    })
}

/// Where a stored plan was (pending and unfired for a row without it).
fn plan_progress(j: &Json) -> Option<PlanProgress> {
    let state = match j["state"].as_str() {
        None | Some("pending") => PlanState::Pending,
        Some("active") => PlanState::Active,
        Some(_) => return None,
    };
    Some(PlanProgress {
        state,
        fired: j["fired"].as_u64().unwrap_or(0),
        trigger_held: j["trigger_held"].as_bool().unwrap_or(false),
    })
}

fn held_plan(name: &str, j: &Json) -> Option<HeldPlan> {
    Some(HeldPlan {
        from: Address::new(j["from"].as_str()?).ok()?,
        circuit: j["circuit"].as_u64()?,
        origin: Address::new(j["origin"].as_str()?).ok()?,
        name: name.to_owned(),
        text: j["text"].as_str()?.to_owned(),
        next_step: j["next_step"].as_u64()?,
        progress: plan_progress(j)?,
    })
}
