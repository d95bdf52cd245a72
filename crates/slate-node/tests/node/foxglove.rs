//! The Foxglove server a node serves (`NodeBuilder::foxglove`): where it listens, that
//! closing the node stops it, and a port in use as a start error that says what to do.
//! The protocol itself (channels, schemas, packets) is tested through `slate node
//! --foxglove` with a WebSocket client, in slate-cli's `tests/cli/foxglove.rs`.

use std::net::{TcpListener, TcpStream};

use slate_ici::SimNet;
use slate_node::StartError;

use crate::support::{eventually, on_net};

#[test]
fn a_node_serves_foxglove_on_a_free_port_and_stops_it_at_close() {
    let net = SimNet::new(1);
    let node = on_net(&net, "t/r1/nav", "object gsr : Vehicle;")
        .foxglove("127.0.0.1:0".parse().unwrap())
        .start()
        .unwrap();
    let addr = node.foxglove_addr().expect("a Foxglove address");
    assert_ne!(addr.port(), 0);
    assert!(TcpStream::connect(addr).is_ok());
    node.close();
    assert_eq!(node.foxglove_addr(), None);
    let stopped = eventually(|| TcpStream::connect(addr).is_err());
    assert!(stopped, "{addr} still accepts connections after close");
}

#[test]
fn a_foxglove_port_in_use_is_a_start_error_that_says_what_to_do() {
    let taken = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = taken.local_addr().unwrap();
    let net = SimNet::new(1);
    let Err(e) = on_net(&net, "t/r1/nav", "").foxglove(addr).start() else {
        panic!("a node started on a Foxglove port in use");
    };
    assert!(matches!(e, StartError::Foxglove(_)), "{e:?}");
    let text = e.to_string();
    assert!(
        text.contains(&format!("cannot serve Foxglove on {addr}")) && text.contains("127.0.0.1:0"),
        "{text}"
    );
}
