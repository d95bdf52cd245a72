use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use slate_model::{
    AttrDecl, Board, BoardEvent, ChainError, ClassDef, Clock, FnError, Trigger, Update, Value,
    ValueType, WriteError,
};

use crate::support::{board, with_vehicle};

fn counter() -> (Arc<AtomicUsize>, impl Fn() -> usize) {
    let c = Arc::new(AtomicUsize::new(0));
    let read = {
        let c = c.clone();
        move || c.load(Ordering::SeqCst)
    };
    (c, read)
}

#[test]
fn on_write_runs_after_the_packet_is_stored_and_sees_the_previous_one() {
    let b = with_vehicle();
    b.write("v", "speed", 1.0).unwrap();
    b.on_write("Vehicle", "speed", |call| {
        let now = call.read(call.object(), "speed")?;
        assert_eq!(&now, call.packet(), "the new packet is already stored");
        let before = call
            .previous()
            .map(|p| p.value.as_f64().unwrap())
            .unwrap_or(-1.0);
        call.write(call.object(), "wheels", (before as i64) + 10)?;
        Ok(())
    })
    .unwrap();
    let rev = b.write("v", "speed", 2.0).unwrap();
    assert_eq!(b.read("v", "wheels").unwrap().value, Value::Int(11));
    assert!(
        b.revision() > rev,
        "the function's write is a later revision"
    );
}

#[test]
fn on_read_computes_the_value_returned_without_storing_it() {
    let b = with_vehicle();
    b.write("v", "speed", Update::new(2.0).confidence(1.0))
        .unwrap();
    // Extrapolate: report twice the stored speed, with lower confidence.
    b.on_read("Vehicle", "speed", |call| {
        let mut p = call.packet().clone();
        p.value = Value::Real(p.value.as_f64().unwrap() * 2.0);
        p.confidence *= 0.5;
        call.set_packet(p);
        Ok(())
    })
    .unwrap();
    let p = b.read("v", "speed").unwrap();
    assert_eq!((p.value.as_f64(), p.confidence), (Some(4.0), 0.5));
    assert_eq!(
        b.snapshot().read("v", "speed").unwrap().value.as_f64(),
        Some(4.0),
        "snapshots run them too"
    );
    assert_eq!(
        b.snapshot().own_values(b.info("v").unwrap().id)[0]
            .1
            .value
            .as_f64(),
        Some(2.0),
        "stored value unchanged"
    );
}

#[test]
fn class_functions_reach_subclasses_created_after_attaching() {
    let b = board();
    let (writes, write_count) = counter();
    let (reads, read_count) = counter();
    b.on_write("Vehicle", "speed", move |_| {
        writes.fetch_add(1, Ordering::SeqCst);
        Ok(())
    })
    .unwrap();
    b.on_read("Vehicle", "speed", move |call| {
        reads.fetch_add(1, Ordering::SeqCst);
        call.set_value(42.0);
        Ok(())
    })
    .unwrap();
    // A subclass defined after the functions were attached, and an instance of it.
    b.define(ClassDef::new("Rover").parent("Gsr")).unwrap();
    b.create("Rover", "late").unwrap();
    b.write("late", "speed", 1.0).unwrap();
    assert_eq!(b.read("late", "speed").unwrap().value.as_f64(), Some(42.0));
    assert_eq!((write_count(), read_count()), (1, 1));
    // Existing instances of existing subclasses too, and functions attached to one object
    // apply to that object only.
    b.create("Gsr", "early").unwrap();
    let (own, own_count) = counter();
    b.on_write("early", "speed", move |_| {
        own.fetch_add(1, Ordering::SeqCst);
        Ok(())
    })
    .unwrap();
    b.write("early", "speed", 1.0).unwrap();
    b.write("late", "speed", 1.0).unwrap();
    assert_eq!((write_count(), own_count()), (3, 1));
}

#[test]
fn functions_run_in_order_inherited_first_then_own() {
    let b = board();
    b.create("Gsr", "g").unwrap();
    let log = Arc::new(parking_lot_free::Log::default());
    for (target, tag) in [
        ("g", "object"),
        ("Gsr", "gsr"),
        ("Vehicle", "vehicle-1"),
        ("Vehicle", "vehicle-2"),
    ] {
        let log = log.clone();
        b.on_write(target, "speed", move |_| {
            log.push(tag);
            Ok(())
        })
        .unwrap();
    }
    b.write("g", "speed", 1.0).unwrap();
    assert_eq!(log.take(), ["vehicle-1", "vehicle-2", "gsr", "object"]);
}

#[test]
fn a_failing_function_is_isolated_and_reported() {
    let b = with_vehicle();
    let events = b.events();
    let (ran, ran_count) = counter();
    b.on_write("Vehicle", "speed", |_| Err(FnError::from("sensor offline")))
        .unwrap();
    b.on_write("Vehicle", "speed", |_| panic!("bug in a module"))
        .unwrap();
    b.on_write("Vehicle", "speed", move |_| {
        ran.fetch_add(1, Ordering::SeqCst);
        Ok(())
    })
    .unwrap();
    b.on_read("Vehicle", "speed", |call| {
        call.set_value("not a real");
        Ok(())
    })
    .unwrap();
    b.write("v", "speed", 3.0)
        .expect("the write itself succeeds");
    assert_eq!(
        ran_count(),
        1,
        "the functions after the failing ones still ran"
    );
    assert_eq!(
        b.read("v", "speed").unwrap().value.as_f64(),
        Some(3.0),
        "an invalid computed value is discarded"
    );
    let got: Vec<BoardEvent> = events.try_iter().collect();
    let errors: Vec<String> = got
        .iter()
        .map(|e| match e {
            BoardEvent::FunctionFailed { error, .. } => error.clone(),
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(errors.len(), 3, "{errors:?}");
    assert_eq!(errors[0], "sensor offline");
    assert_eq!(errors[1], "panicked: bug in a module");
    assert!(
        errors[2].contains("expected a value of type real"),
        "{}",
        errors[2]
    );
    assert_eq!(b.stats().function_failures, 3);
    // The board still works, from every thread.
    b.write("v", "speed", 4.0).unwrap();
}

fn chain_board(depth: usize) -> Board {
    let b = Board::builder()
        .clock(Clock::manual())
        .max_depth(depth)
        .build();
    let attrs = (0..20).fold(ClassDef::new("Relay"), |c, i| {
        c.attr(AttrDecl::new(&format!("a{i}"), ValueType::Int))
    });
    b.define(attrs).unwrap();
    b.create("Relay", "r").unwrap();
    // a0 -> a1 -> a2 -> ... each write triggers the next.
    for i in 0..19 {
        let next = format!("a{}", i + 1);
        b.on_write("Relay", &format!("a{i}"), move |call| {
            let v = call.packet().value.clone();
            call.write("r", &next, v)?;
            Ok(())
        })
        .unwrap();
    }
    b
}

#[test]
fn chains_are_cut_at_the_depth_limit() {
    let b = chain_board(4);
    let events = b.events();
    b.write("r", "a0", 7).unwrap();
    // a0 is the root write; functions at depths 1..=4 wrote a1..a4; a5 was refused.
    for i in 0..=4 {
        assert_eq!(
            b.read("r", &format!("a{i}")).unwrap().value,
            Value::Int(7),
            "a{i}"
        );
    }
    assert_eq!(b.read("r", "a5").unwrap().value, Value::None);
    let cut = events.try_iter().find_map(|e| match e {
        BoardEvent::ChainCut(c) => Some(c),
        _ => None,
    });
    assert_eq!(
        cut,
        Some(ChainError::DepthLimit {
            limit: 4,
            object: "r".into(),
            attr: "a5".into()
        })
    );
    // A longer limit lets the chain run further.
    let b = chain_board(10);
    b.write("r", "a0", 1).unwrap();
    assert_eq!(b.read("r", "a10").unwrap().value, Value::Int(1));
    assert_eq!(b.read("r", "a11").unwrap().value, Value::None);
}

#[test]
fn a_cycle_is_reported_and_does_not_loop() {
    let b = with_vehicle();
    b.on_write("Vehicle", "speed", |call| {
        call.write(call.object(), "wheels", 4)?;
        Ok(())
    })
    .unwrap();
    b.on_write("Vehicle", "wheels", |call| {
        let r = call.write(call.object(), "speed", 1.0);
        assert!(
            matches!(r, Err(WriteError::Chain(ChainError::Cycle { .. }))),
            "{r:?}"
        );
        r.map(|_| ()).map_err(FnError::from)
    })
    .unwrap();
    let events = b.events();
    b.write("v", "speed", 5.0).unwrap();
    assert_eq!(b.read("v", "speed").unwrap().value.as_f64(), Some(5.0));
    assert_eq!(b.read("v", "wheels").unwrap().value, Value::Int(4));
    assert_eq!(
        cycle_cut(&events).unwrap(),
        ["v.speed", "v.wheels", "v.speed"]
    );
    assert_eq!(b.stats().chain_cuts, 1);
}

/// The path of the first chain the board cut as a cycle, among the events so far.
fn cycle_cut(events: &crossbeam_channel::Receiver<BoardEvent>) -> Option<Vec<String>> {
    events.try_iter().find_map(|e| match e {
        BoardEvent::ChainCut(ChainError::Cycle { path }) => Some(path),
        _ => None,
    })
}

#[test]
fn functions_may_read_and_write_the_board_without_deadlock() {
    let b = with_vehicle();
    b.create("Obstacle", "o").unwrap();
    b.on_read("Obstacle", "range", |call| {
        // A read function that reads another object, queries, and writes (allowed live).
        let speed = call.read("v", "speed")?.value.as_f64().unwrap_or(0.0);
        let n = call.instances("Vehicle")?.len() as f64;
        call.write("v", "mode", "ranged")?;
        call.set_value(speed * 10.0 + n);
        Ok(())
    })
    .unwrap();
    b.write("v", "speed", 2.0).unwrap();
    assert_eq!(b.read("o", "range").unwrap().value.as_f64(), Some(21.0));
    assert_eq!(b.read("v", "mode").unwrap().value, Value::from("ranged"));
    // In a snapshot, the same function may read but its write is refused (and reported).
    let events = b.events();
    let snap_value = b.snapshot().read("o", "range").unwrap();
    assert_eq!(
        snap_value.value.as_f64(),
        Some(100.0),
        "the failed function left the stored value"
    );
    assert!(events.try_iter().any(|e| matches!(
        e,
        BoardEvent::FunctionFailed {
            trigger: Trigger::Read,
            ..
        }
    )));
}

/// A tiny thread-safe log (std Mutex) for order assertions.
mod parking_lot_free {
    use std::sync::Mutex;

    #[derive(Default)]
    pub struct Log(Mutex<Vec<&'static str>>);

    impl Log {
        pub fn push(&self, s: &'static str) {
            self.0.lock().unwrap().push(s);
        }
        pub fn take(&self) -> Vec<&'static str> {
            std::mem::take(&mut *self.0.lock().unwrap())
        }
    }
}

#[test]
fn a_token_carries_the_chain_to_accesses_made_outside_the_call() {
    let b = Arc::new(board());
    b.create("Vehicle", "v").unwrap();
    // Functions that reach the board through an Arc and a token, as a binding does.
    let weak = Arc::downgrade(&b);
    b.on_write("Vehicle", "speed", move |call| {
        let token = call.token().expect("a live write");
        let board = weak.upgrade().expect("the board");
        board.write_as(&token, call.object(), "wheels", 4)?;
        Ok(())
    })
    .unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    let weak = Arc::downgrade(&b);
    b.on_write("Vehicle", "wheels", move |call| {
        let token = call.token().expect("a live write");
        let board = weak.upgrade().expect("the board");
        let speed = board.read_as(&token, call.object(), "speed")?;
        let again = board.write_as(&token, call.object(), "speed", 1.0);
        let _ = tx.send((speed.value.as_f64(), again));
        Ok(())
    })
    .unwrap();
    let events = b.events();
    b.write("v", "speed", 5.0).unwrap();
    // Functions run in the writer's thread: the answer is there once `write` returns.
    let (speed, again) = rx.try_recv().expect("the write function ran");
    assert_eq!(speed, Some(5.0), "read_as reads the board");
    assert!(
        matches!(again, Err(WriteError::Chain(ChainError::Cycle { .. }))),
        "write_as is cut as a cycle: {again:?}"
    );
    assert_eq!(b.read("v", "speed").unwrap().value.as_f64(), Some(5.0));
    assert_eq!(b.read("v", "wheels").unwrap().value, Value::Int(4));
    assert_eq!(
        cycle_cut(&events).unwrap(),
        ["v.speed", "v.wheels", "v.speed"]
    );
}

#[test]
fn functions_run_inside_a_snapshot_get_no_token() {
    let b = with_vehicle();
    let (tx, rx) = std::sync::mpsc::channel();
    b.on_read("Vehicle", "mode", move |call| {
        let _ = tx.send(call.token().is_some());
        Ok(())
    })
    .unwrap();
    b.read("v", "mode").unwrap();
    assert!(
        rx.try_recv().expect("the read function ran"),
        "a live read has a token"
    );
    b.snapshot().read("v", "mode").unwrap();
    assert!(
        !rx.try_recv().expect("the read function ran"),
        "a snapshot's read has none"
    );
}

/// Attaches to `Vehicle.<attr>` a function that calls `access` on the board it captured
/// (not through its `Call`), at most `bound` times in all, so that a board that does not
/// cut the recursion fails the test instead of overflowing the stack.
fn recurse_through_the_board(
    b: &Arc<Board>,
    attr: &str,
    trigger: Trigger,
    bound: usize,
    access: impl Fn(&Board) + Send + Sync + 'static,
) -> impl Fn() -> usize {
    let (runs, count) = counter();
    let weak = Arc::downgrade(b);
    let f = move |_: &mut slate_model::Call<'_>| {
        if runs.fetch_add(1, Ordering::SeqCst) < bound
            && let Some(board) = weak.upgrade()
        {
            access(&board);
        }
        Ok(())
    };
    match trigger {
        Trigger::Read => b.on_read("Vehicle", attr, f).unwrap(),
        _ => b.on_write("Vehicle", attr, f).unwrap(),
    }
    count
}

#[test]
fn a_read_function_that_reads_through_the_board_is_cut_as_a_cycle() {
    let b = Arc::new(board());
    b.create("Vehicle", "v").unwrap();
    let runs = recurse_through_the_board(&b, "speed", Trigger::Read, 100, |board| {
        let again = board.read("v", "speed");
        assert!(
            matches!(
                again,
                Err(slate_model::ReadError::Chain(ChainError::Cycle { .. }))
            ),
            "{again:?}"
        );
    });
    let events = b.events();
    assert_eq!(b.read("v", "speed").unwrap().value.as_f64(), Some(0.0));
    assert_eq!(runs(), 1, "the nested read ran no function");
    assert_eq!(cycle_cut(&events).unwrap(), ["v.speed", "v.speed"]);
    assert_eq!(b.stats().function_failures, 0);
}

/// Writes 5.0 to `v.speed` on a board whose write function of `speed` runs `access`
/// through the board; asserts the function ran once and the cycle was cut at v.speed,
/// and returns the speed read then.
fn speed_after_a_cut_write_cycle(access: impl Fn(&Board) + Send + Sync + 'static) -> Option<f64> {
    let b = Arc::new(board());
    b.create("Vehicle", "v").unwrap();
    let runs = recurse_through_the_board(&b, "speed", Trigger::Write, 100, access);
    let events = b.events();
    b.write("v", "speed", 5.0).unwrap();
    assert_eq!(runs(), 1);
    assert_eq!(cycle_cut(&events).unwrap(), ["v.speed", "v.speed"]);
    b.read("v", "speed").unwrap().value.as_f64()
}

#[test]
fn a_write_function_that_writes_its_attribute_through_the_board_is_cut_as_a_cycle() {
    let speed = speed_after_a_cut_write_cycle(|board| {
        let again = board.write("v", "speed", 1.0);
        assert!(
            matches!(again, Err(WriteError::Chain(ChainError::Cycle { .. }))),
            "{again:?}"
        );
    });
    assert_eq!(speed, Some(5.0));
}

#[test]
fn a_batch_committed_by_a_function_stays_in_its_chain() {
    let speed = speed_after_a_cut_write_cycle(|board| {
        let mut batch = board.batch();
        batch.write("v", "speed", 2.0);
        // The batch is stored; the function it would run again is cut.
        batch.commit().unwrap();
    });
    assert_eq!(speed, Some(2.0));
}

#[test]
fn functions_that_call_each_others_boards_are_cut_as_a_cycle() {
    let a = Arc::new(board());
    let b = Arc::new(board());
    a.create("Vehicle", "v").unwrap();
    b.create("Vehicle", "v").unwrap();
    let weak_b = Arc::downgrade(&b);
    let runs_a = recurse_through_the_board(&a, "mode", Trigger::Read, 100, move |_| {
        if let Some(b) = weak_b.upgrade() {
            let _ = b.read("v", "mode");
        }
    });
    let weak_a = Arc::downgrade(&a);
    let runs_b = recurse_through_the_board(&b, "mode", Trigger::Read, 100, move |_| {
        if let Some(a) = weak_a.upgrade() {
            let _ = a.read("v", "mode");
        }
    });
    let events = a.events();
    assert_eq!(a.read("v", "mode").unwrap().value, Value::from("idle"));
    assert_eq!((runs_a(), runs_b()), (1, 1));
    assert_eq!(cycle_cut(&events).unwrap(), ["v.mode", "v.mode"]);
}

#[test]
fn a_function_on_another_thread_starts_its_own_chain() {
    let b = Arc::new(board());
    b.create("Vehicle", "v").unwrap();
    let runs = recurse_through_the_board(&b, "speed", Trigger::Write, 2, |board| {
        // Not this thread's chain: the other thread's write runs the function again.
        std::thread::scope(|s| {
            s.spawn(|| board.write("v", "speed", 1.0).unwrap());
        });
    });
    b.write("v", "speed", 5.0).unwrap();
    assert_eq!(runs(), 3);
}

/// Runs `f` on a thread with a large stack (and waits for it), so that a board without
/// the bound on nesting fails the assertion, not the run.
fn on_a_large_stack(f: impl FnOnce() + Send + 'static) {
    std::thread::Builder::new()
        .stack_size(256 << 20)
        .spawn(f)
        .unwrap()
        .join()
        .unwrap();
}

#[test]
fn a_thread_nests_no_more_functions_than_its_stack_allows_whatever_the_limit() {
    let b = Arc::new(
        Board::builder()
            .clock(Clock::manual())
            .max_depth(100_000)
            .build(),
    );
    b.define(ClassDef::new("Hop").attr(AttrDecl::new("x", ValueType::Int)))
        .unwrap();
    let hops = 3 * slate_model::MAX_NESTED_FUNCTIONS;
    for i in 0..hops {
        b.create("Hop", &format!("h{i}")).unwrap();
    }
    let (runs, count) = counter();
    // Each hop's function reads the next hop through the board it captured.
    let weak = Arc::downgrade(&b);
    b.on_read("Hop", "x", move |call| {
        runs.fetch_add(1, Ordering::SeqCst);
        let next: usize = call.object()[1..].parse().unwrap_or(usize::MAX);
        if let (Some(board), true) = (weak.upgrade(), next + 1 < hops) {
            board.read(&format!("h{}", next + 1), "x")?;
        }
        Ok(())
    })
    .unwrap();
    let events = b.events();
    let b2 = b.clone();
    on_a_large_stack(move || drop(b2.read("h0", "x").unwrap()));
    assert_eq!(count(), slate_model::MAX_NESTED_FUNCTIONS);
    let cut = events.try_iter().find_map(|e| match e {
        BoardEvent::ChainCut(c) => Some(c),
        _ => None,
    });
    assert!(
        matches!(cut, Some(ChainError::DepthLimit { limit, .. }) if limit == slate_model::MAX_NESTED_FUNCTIONS),
        "{cut:?}"
    );
}

#[test]
fn functions_hopping_across_many_boards_are_bounded_too() {
    let hops = 2 * slate_model::MAX_NESTED_FUNCTIONS;
    let boards: Vec<Arc<Board>> = (0..hops).map(|_| Arc::new(board())).collect();
    let (runs, count) = counter();
    for (i, b) in boards.iter().enumerate() {
        b.create("Vehicle", "v").unwrap();
        let next = boards.get(i + 1).map(Arc::downgrade);
        let runs = runs.clone();
        b.on_read("Vehicle", "mode", move |_| {
            runs.fetch_add(1, Ordering::SeqCst);
            if let Some(next) = next.as_ref().and_then(std::sync::Weak::upgrade) {
                next.read("v", "mode")?;
            }
            Ok(())
        })
        .unwrap();
    }
    let first = boards[0].clone();
    on_a_large_stack(move || drop(first.read("v", "mode").unwrap()));
    assert_eq!(count(), slate_model::MAX_NESTED_FUNCTIONS);
}

#[test]
fn a_detached_function_no_longer_runs_and_others_stay() {
    let b = board();
    b.define(ClassDef::new("A").attr(AttrDecl::new("x", ValueType::Real)))
        .unwrap();
    b.create("A", "a").unwrap();
    let runs = Arc::new(AtomicUsize::new(0));
    let counted = {
        let runs = runs.clone();
        move |_: &mut slate_model::Call<'_>| {
            runs.fetch_add(1, Ordering::SeqCst);
            Ok(())
        }
    };
    b.on_write("A", "x", counted.clone()).unwrap();
    let f: slate_model::FnRef = Arc::new(Named(counted));
    b.attach("A", "x", Trigger::Write, f.clone()).unwrap();
    b.write("a", "x", 1.0).unwrap();
    assert_eq!(runs.load(Ordering::SeqCst), 2);
    assert!(b.detach("A", "x", Trigger::Write, &f).unwrap());
    assert!(!b.detach("A", "x", Trigger::Write, &f).unwrap());
    b.write("a", "x", 2.0).unwrap();
    assert_eq!(runs.load(Ordering::SeqCst), 3);
}

/// A closure as an [`slate_model::ActiveFn`] the test can hold on to.
struct Named<F>(F);

impl<F> slate_model::ActiveFn for Named<F>
where
    F: Fn(&mut slate_model::Call<'_>) -> Result<(), FnError> + Send + Sync,
{
    fn name(&self) -> &str {
        "counted"
    }
    fn call(&self, call: &mut slate_model::Call<'_>) -> Result<(), FnError> {
        (self.0)(call)
    }
}

#[test]
fn a_function_failing_on_a_thousand_writes_makes_a_bounded_number_of_events_and_each_is_counted() {
    // Issue 17, bounded in total: a peer's writes at will make an on-write function fail
    // at will. Each failure is counted; events are at most one a second per function,
    // each saying how many it stands for.
    let b = Board::builder().clock(Clock::manual()).build();
    b.define(ClassDef::new("Vehicle").attr(AttrDecl::new("speed", ValueType::Real)))
        .unwrap();
    b.create("Vehicle", "v").unwrap();
    b.on_write("Vehicle", "speed", |_| Err(FnError::from("no")))
        .unwrap();
    let events = b.events();
    for i in 0..1000 {
        b.clock()
            .advance(std::time::Duration::from_millis(5))
            .unwrap();
        b.write("v", "speed", f64::from(i)).unwrap();
    }
    assert_eq!(b.stats().function_failures, 1000);
    let told: Vec<u64> = events
        .try_iter()
        .filter_map(|e| match e {
            BoardEvent::FunctionFailed { suppressed, .. } => Some(1 + suppressed),
            _ => None,
        })
        .collect();
    assert!((5..=6).contains(&told.len()), "{} events", told.len());
    assert!(told.iter().sum::<u64>() <= 1000, "{told:?}");
    assert!(told.iter().sum::<u64>() >= 800, "{told:?}");
}
