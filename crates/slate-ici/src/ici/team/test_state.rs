//! The team protocol's unit tests' module: one `State` alone on its own simulated
//! network, built the way `Ici::new` builds it (its `Module` class defined, a watch on
//! its own writes).

use std::sync::Arc;
use std::time::Duration;

use slate_model::{Address, Board, Filter};
use slate_testing::addr;

use super::frame::{Member, RobotHello, StreamTag};
use crate::ici::classes::ClassSet;
use crate::ici::frame::{Frame, Lifecycle};
use crate::ici::state::State;
use crate::ici::{IciConfig, module_class};
use crate::{LinkKind, MsgKind, SimNet};

/// The state of module `me` with `config`, alone on a network of seed 1.
pub(crate) fn alone(me: &str, config: IciConfig) -> (SimNet, State) {
    let net = SimNet::new(1);
    let me = addr(me);
    let board = Arc::new(
        Board::builder()
            .clock(net.clock())
            .address(me.clone())
            .build(),
    );
    board.define(module_class()).unwrap();
    let watch = board.watch(Filter::all().own_writes_only()).unwrap();
    let state = State::new(board, net.join(&me), config, watch);
    (net, state)
}

/// Where the tests' time line starts.
pub(crate) const START: Duration = Duration::from_secs(10);

pub(crate) fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

/// Messages of `kind` the state sent on `link`.
pub(crate) fn sent(st: &State, link: LinkKind, kind: MsgKind) -> u64 {
    let traffic = st.stats.traffic.get(&(link, kind));
    traffic.map_or(0, |t| t.sent_msgs)
}

/// Runs the NACK timers `at` after [`START`].
pub(crate) fn tick_at(st: &mut State, at: Duration) {
    st.now = START + at;
    st.nack_tick();
}

/// The hello of `gateway`'s robot in epoch `epoch` (the gateway's incarnation; the tag
/// follows from both), listing `members` (their index is their place), alive and
/// listening, interested in everything and exporting nothing.
pub(crate) fn robot_hello(gateway: &Address, epoch: u64, members: &[&str]) -> RobotHello {
    let member = |name: &&str| Member {
        name: (*name).into(),
        incarnation: 5,
        inner_seq: 0,
        alive: true,
        listener: true,
    };
    RobotHello {
        version: 1,
        tag: StreamTag::of(gateway, epoch),
        gw_incarnation: epoch,
        observer: false,
        interest: ClassSet::all(),
        exports: ClassSet::none(),
        members: members.iter().map(member).collect(),
    }
}

/// An empty ICI lifecycle frame at stream position `seq`: the smallest inner message.
pub(crate) fn lifecycle(seq: u64) -> Vec<u8> {
    Frame::Lifecycle(Lifecycle {
        seq,
        ..Lifecycle::default()
    })
    .encode()
}
